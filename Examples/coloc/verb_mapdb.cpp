// coloc mapdb info|verify|export-trajectory|export-ply MAP.db: the map database (slam/mapdb)
// from the command line. Outputs are written to a temporary and renamed into place.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/slam_inputs.hpp"
#include "Examples/coloc/verbs.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/ply_writer.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/row_progress.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/mapdb/mapdb.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
namespace mapdb = slam::mapdb;

std::string hex(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::string transform_text(const std::optional<Sim3>& t) {
  if (!t) return "none";
  const Eigen::Quaterniond& q = t->so3().quaternion();
  std::ostringstream s;
  s << "scale " << t->scale() << ", t (" << t->translation().transpose() << "), q (x " << q.x()
    << ", y " << q.y() << ", z " << q.z() << ", w " << q.w() << ")";
  return s.str();
}

void print_info(const fs::path& file, const mapdb::MapInfo& i, bool json) {
  const mapdb::MapMetadata& m = i.metadata;
  const mapdb::MapCounts& c = i.counts;
  const double per_kf = c.keyframes ? static_cast<double>(i.file_bytes) / c.keyframes : 0.0;
  const std::string camera = m.camera ? model_name(*m.camera) : "none";
  if (json) {
    print_json({{"file", file.string()},
                {"bytes", i.file_bytes},
                {"schema_version", i.schema_version},
                {"coloc_version", m.coloc_version},
                {"saved_utc", m.saved_utc},
                {"vocabulary_checksum", hex(m.vocabulary_checksum)},
                {"vocabulary_words", m.vocabulary_words},
                {"frame_name", m.frame_name},
                {"frame_transform", transform_text(m.frame_from_slam)},
                {"camera", camera},
                {"keyframes", c.keyframes},
                {"map_points", c.points},
                {"observations", c.observations},
                {"markers", c.markers},
                {"covisibility_edges", c.covisibility},
                {"loop_edges", c.loop_edges},
                {"erased_keyframes", c.erased_keyframes},
                {"gravity_windows", c.gravity_windows},
                {"gyro_links", c.gyro_links},
                {"keyframe_depths", c.keyframe_depths},
                {"bytes_per_keyframe", per_kf}});
    return;
  }
  std::cout << "file: " << file.string() << " (" << i.file_bytes << " bytes, "
            << static_cast<long long>(per_kf) << " per keyframe)\n"
            << "schema version " << i.schema_version << ", saved by coloc " << m.coloc_version
            << " at " << m.saved_utc << "\n"
            << "vocabulary: checksum " << hex(m.vocabulary_checksum) << ", " << m.vocabulary_words
            << " words\n"
            << "frame: " << m.frame_name
            << ", transform from slam: " << transform_text(m.frame_from_slam)
            << "\ncamera: " << camera << "\n"
            << "keyframes " << c.keyframes << ", map points " << c.points << ", observations "
            << c.observations << ", markers " << c.markers << ", covisibility edges "
            << c.covisibility << ", loop edges " << c.loop_edges << ", erased keyframes "
            << c.erased_keyframes << "\n"
            << "IMU: gravity windows " << c.gravity_windows << ", gyro links " << c.gyro_links
            << "\n"
            << "keyframe depth images " << c.keyframe_depths << "\n";
}

void run_verify(const fs::path& file, const fs::path& vocabulary_path, bool json) {
  std::optional<slam::bow::Vocabulary> vocabulary;
  if (!vocabulary_path.empty()) vocabulary = load_vocabulary(vocabulary_path);
  RowProgress progress("verify", json);
  const mapdb::VerifyReport r =
      mapdb::verify_map(file, vocabulary ? &*vocabulary : nullptr, progress.callback());
  progress.finish();
  if (json) {
    print_json({{"file", file.string()}, {"ok", r.ok()}, {"problems", r.problems}});
  } else {
    for (const std::string& p : r.problems)
      std::cout << "problem: " << p << "\n";
    if (r.ok())
      std::cout << file.string() << ": ok (" << r.info.counts.keyframes << " keyframes, "
                << r.info.counts.points << " map points"
                << (vocabulary ? ", vocabulary matches" : "") << ")\n";
  }
  if (!r.ok())
    throw CliFailure(file.string() + ": " + std::to_string(r.problems.size()) + " problem(s)");
}

void export_trajectory(const fs::path& file, const fs::path& out) {
  { const AtomicFile probe(out); }  // an unwritable output fails before the map is read
  const Trajectory t = mapdb::read_keyframe_trajectory(file);
  write_tum_trajectory(out, t);  // atomic
  std::cout << "wrote " << t.size() << " keyframe poses (world_from_cam, TUM format) to "
            << out.string() << "\n";
}

void export_ply(const fs::path& file, const fs::path& out, std::uint32_t min_observations) {
  const mapdb::MapInfo info = mapdb::read_map_info(file);
  PlyWriter ply(out,
                {{"x", PlyType::kFloat},
                 {"y", PlyType::kFloat},
                 {"z", PlyType::kFloat},
                 {"nx", PlyType::kFloat},
                 {"ny", PlyType::kFloat},
                 {"nz", PlyType::kFloat},
                 {"observations", PlyType::kUint}},
                "coloc map points of " + file.filename().string() + " in frame '" +
                    info.metadata.frame_name + "' (metres)");
  Progress progress("export-ply", info.counts.points);
  mapdb::for_each_point(file, [&](const mapdb::PointRecord& p) {
    progress.advance();
    if (p.observations < min_observations) return;
    const Eigen::Vector3f x = p.position.cast<float>(), n = p.normal.cast<float>();
    ply.add(x.x(), x.y(), x.z(), n.x(), n.y(), n.z(), p.observations);
  });
  progress.finish();
  ply.commit();
  const std::uint64_t written = ply.vertices();
  std::cout << "wrote " << written << " map points to " << out.string() << "\n";
}

}  // namespace

void add_mapdb_bench(CLI::App& bench);

void add_mapdb_verb(CLI::App& app, CLI::App& bench) {
  CLI::App& cmd = *app.add_subcommand("mapdb", "Inspect and export map files (SQLite)");
  cmd.require_subcommand(1);
  auto file = std::make_shared<fs::path>();
  auto out = std::make_shared<fs::path>();
  auto vocabulary = std::make_shared<fs::path>();
  auto json = std::make_shared<bool>(false);
  auto min_obs = std::make_shared<std::uint32_t>(0);

  CLI::App& info = *cmd.add_subcommand("info", "Metadata and counts (reads no keyframe)");
  info.add_option("MAP", *file, "Map file")->required()->check(CLI::ExistingFile);
  info.add_flag("--json", *json, "Machine-readable output on stdout");
  info.callback([=] { print_info(*file, mapdb::read_map_info(*file), *json); });

  CLI::App& verify = *cmd.add_subcommand(
      "verify", "integrity_check, tables, blob sizes, references, checksums (exit 1 on problems)");
  verify.add_option("MAP", *file, "Map file")->required()->check(CLI::ExistingFile);
  verify.add_option("--vocabulary", *vocabulary,
                    "Also check that the map was built with this vocabulary");
  verify.add_flag("--json", *json, "Machine-readable output on stdout");
  verify.callback([=] { run_verify(*file, *vocabulary, *json); });

  CLI::App& traj =
      *cmd.add_subcommand("export-trajectory", "Keyframe poses (world_from_cam) in TUM format");
  traj.add_option("MAP", *file, "Map file")->required()->check(CLI::ExistingFile);
  traj.add_option("OUT", *out, "Output trajectory")->required();
  traj.callback([=] { export_trajectory(*file, *out); });

  CLI::App& ply = *cmd.add_subcommand("export-ply", "Map points as binary PLY");
  ply.add_option("MAP", *file, "Map file")->required()->check(CLI::ExistingFile);
  ply.add_option("OUT", *out, "Output .ply")->required();
  ply.add_option("--min-observations", *min_obs, "Only points seen by at least N keyframes");
  ply.callback([=] { export_ply(*file, *out, *min_obs); });

  add_mapdb_bench(bench);
}

}  // namespace coloc::cli
