// coloc e57 info|verify|extract-images|to-ply FILE ..., and coloc bench e57 [FILE]: our own E57
// reader/writer (e57io) from the command line.

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string_view>

#include "Examples/coloc/cli_common.hpp"
#include "Examples/coloc/verbs.hpp"
#include "e57io/reader.hpp"
#include "e57io/synthetic.hpp"
#include "e57io/writer.hpp"
#include "slam/core/atomic_file.hpp"
#include "slam/core/ply_writer.hpp"
#include "slam/core/progress.hpp"
#include "slam/core/timing.hpp"

namespace coloc::cli {
namespace {

namespace fs = std::filesystem;
using e57::field_bit;
using e57::PointField;

const char* kind_name(e57::FieldKind k) {
  switch (k) {
    case e57::FieldKind::kInteger:
      return "Integer";
    case e57::FieldKind::kScaledInteger:
      return "ScaledInteger";
    case e57::FieldKind::kFloat:
      return "Float";
  }
  return "?";
}

std::string field_text(const e57::PrototypeField& f) {
  std::ostringstream s;
  s << f.name << " (" << kind_name(f.spec.kind);
  if (f.spec.kind == e57::FieldKind::kFloat) {
    s << (f.spec.single_precision ? " single" : " double");
  } else {
    s << " [" << f.spec.minimum << ", " << f.spec.maximum << "]";
    if (f.spec.kind == e57::FieldKind::kScaledInteger) s << " x " << f.spec.scale;
  }
  s << ")";
  return s.str();
}

std::string pose_text(const std::optional<e57::Pose>& p) {
  if (!p) return "none";
  char buf[200];
  std::snprintf(buf, sizeof buf, "t (%.6g, %.6g, %.6g) q (w %.6g, x %.6g, y %.6g, z %.6g)",
                p->translation.x, p->translation.y, p->translation.z, p->rotation.w, p->rotation.x,
                p->rotation.y, p->rotation.z);
  return buf;
}

Json pose_json(const std::optional<e57::Pose>& p) {
  if (!p) return nullptr;
  return {{"translation", {p->translation.x, p->translation.y, p->translation.z}},
          {"rotation_wxyz", {p->rotation.w, p->rotation.x, p->rotation.y, p->rotation.z}}};
}

void print_info_text(const e57::Reader& r) {
  const e57::FileInfo& info = r.info();
  std::cout << "file: " << r.path().string() << " (" << info.physical_length << " bytes, E57 "
            << info.version_major << "." << info.version_minor << ")\n"
            << "guid: " << info.guid << "\nwriter: " << info.library_version << "\n"
            << "scans: " << r.scans().size() << "\n";
  for (std::size_t i = 0; i < r.scans().size(); ++i) {
    const e57::Data3D& s = r.scans()[i];
    std::cout << "  [" << i << "] '" << s.name << "' " << s.guid << ": " << s.point_count
              << " points\n      fields:";
    for (const auto& f : s.prototype)
      std::cout << ' ' << field_text(f);
    std::cout << "\n      pose: " << pose_text(s.pose) << "\n";
    if (const auto& b = s.cartesian_bounds) {
      std::printf("      bounds: x [%.6g, %.6g] y [%.6g, %.6g] z [%.6g, %.6g]\n", b->x_min,
                  b->x_max, b->y_min, b->y_max, b->z_min, b->z_max);
      std::fflush(stdout);
    }
  }
  std::cout << "images: " << r.images().size() << "\n";
  for (std::size_t i = 0; i < r.images().size(); ++i) {
    const e57::Image2D& im = r.images()[i];
    std::cout << "  [" << i << "] '" << im.name << "' " << e57::to_string(im.representation) << ' '
              << (im.format == e57::ImageFormat::kJpeg ? "jpeg" : "png") << ' ' << im.width << 'x'
              << im.height << " (" << im.image.length << " bytes)";
    if (im.representation == e57::ImageRepresentation::kPinhole) {
      std::cout << " focal " << im.focal_length << " m, pixel " << im.pixel_width << " m";
    }
    std::cout << "\n      pose: " << pose_text(im.pose) << "\n";
  }
}

Json scan_json(const e57::Data3D& s) {
  Json fields = Json::array();
  for (const auto& f : s.prototype)
    fields.push_back({{"name", f.name}, {"type", kind_name(f.spec.kind)}});
  Json bounds = nullptr;
  if (const auto& b = s.cartesian_bounds)
    bounds = {b->x_min, b->x_max, b->y_min, b->y_max, b->z_min, b->z_max};
  return {{"name", s.name},
          {"guid", s.guid},
          {"points", s.point_count},
          {"fields", fields},
          {"pose", pose_json(s.pose)},
          {"cartesian_bounds", bounds}};
}

Json image_json(const e57::Image2D& im) {
  return {{"name", im.name},
          {"representation", e57::to_string(im.representation)},
          {"format", im.format == e57::ImageFormat::kJpeg ? "jpeg" : "png"},
          {"width", im.width},
          {"height", im.height},
          {"bytes", im.image.length},
          {"focal_length", im.focal_length},
          {"pixel_width", im.pixel_width},
          {"pixel_height", im.pixel_height},
          {"principal_point", {im.principal_point_x, im.principal_point_y}},
          {"associated_scan", im.associated_data3d_guid},
          {"pose", pose_json(im.pose)}};
}

void print_info_json(const e57::Reader& r) {
  const e57::FileInfo& info = r.info();
  Json scans = Json::array(), images = Json::array();
  for (const e57::Data3D& s : r.scans())
    scans.push_back(scan_json(s));
  for (const e57::Image2D& im : r.images())
    images.push_back(image_json(im));
  print_json({{"file", r.path().string()},
              {"bytes", info.physical_length},
              {"guid", info.guid},
              {"writer", info.library_version},
              {"scans", scans},
              {"images", images}});
}

std::string safe_name(const std::string& s) {
  std::string out;
  for (char c : s)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-') ? c : '_';
  return out;
}

void write_bytes(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
  write_file_atomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), false);
}

void extract_images(const std::string& file, const std::string& dir) {
  fs::create_directories(dir);
  // Claimed first: an unwritable folder fails before any image is read; images.yaml appears,
  // complete, only after every image it lists.
  AtomicFile yaml_file(fs::path(dir) / "images.yaml");
  const e57::Reader r(file);
  std::ostringstream yaml;
  yaml << "# Images of " << file << ". Pinhole intrinsics in pixels: fx = focal_length / "
       << "pixel_width, fy = focal_length / pixel_height.\n# pose: world_from_camera (E57 "
       << "rigidBodyTransform), translation in metres, quaternion w x y z.\nimages:\n";
  yaml.precision(17);
  for (std::size_t i = 0; i < r.images().size(); ++i) {
    const e57::Image2D& im = r.images()[i];
    const std::string base = std::to_string(i) + "_" + safe_name(im.name);
    const std::string name = base + (im.format == e57::ImageFormat::kJpeg ? ".jpg" : ".png");
    write_bytes(fs::path(dir) / name, r.read_image(i));
    yaml << "  - file: \"" << name << "\"\n    name: \"" << im.name << "\"\n"
         << "    representation: " << e57::to_string(im.representation) << "\n"
         << "    width: " << im.width << "\n    height: " << im.height << "\n"
         << "    pixel_width: " << im.pixel_width << "\n    pixel_height: " << im.pixel_height
         << "\n";
    if (im.mask) {
      write_bytes(fs::path(dir) / (base + "_mask.png"), r.read_image_mask(i));
      yaml << "    mask: \"" << base << "_mask.png\"\n";
    }
    if (im.representation == e57::ImageRepresentation::kPinhole) {
      yaml << "    focal_length: " << im.focal_length << "\n";
      if (im.pixel_width > 0 && im.pixel_height > 0) {
        yaml << "    fx: " << im.focal_length / im.pixel_width
             << "\n    fy: " << im.focal_length / im.pixel_height << "\n";
      }
      yaml << "    cx: " << im.principal_point_x << "\n    cy: " << im.principal_point_y << "\n";
    }
    if (!im.associated_data3d_guid.empty()) {
      yaml << "    associated_scan: \"" << im.associated_data3d_guid << "\"\n";
    }
    if (im.pose) {
      const auto& p = *im.pose;
      yaml << "    pose:\n      translation: [" << p.translation.x << ", " << p.translation.y
           << ", " << p.translation.z << "]\n      rotation_wxyz: [" << p.rotation.w << ", "
           << p.rotation.x << ", " << p.rotation.y << ", " << p.rotation.z << "]\n";
    }
  }
  write_file_atomically(yaml_file.target(), yaml.str());
  std::cout << "wrote " << r.images().size() << " images and images.yaml to " << dir << "\n";
}

// Appends the valid points of scan `si` as PLY records; returns how many.
std::uint64_t append_scan_points(const e57::Reader& r, std::size_t si, bool colour, bool local,
                                 PlyWriter& f, Progress& progress) {
  std::uint64_t written = 0;
  const e57::Data3D& s = r.scans()[si];
  const e57::Pose pose = (s.pose && !local) ? *s.pose : e57::Pose{};
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z)
          .normalized();
  const Eigen::Matrix3d rotation = q.toRotationMatrix();
  const Eigen::Vector3d t(pose.translation.x, pose.translation.y, pose.translation.z);
  std::uint32_t mask = field_bit(PointField::kCartesianX) | field_bit(PointField::kCartesianY) |
                       field_bit(PointField::kCartesianZ);
  if (s.field_mask & field_bit(PointField::kCartesianInvalidState)) {
    mask |= field_bit(PointField::kCartesianInvalidState);
  }
  if (colour) {
    mask |= field_bit(PointField::kColorRed) | field_bit(PointField::kColorGreen) |
            field_bit(PointField::kColorBlue);
  }
  const e57::ColorLimits lim = s.color_limits.value_or(e57::ColorLimits{0, 255, 0, 255, 0, 255});
  auto to_byte = [](double v, double lo, double hi) {
    const double x = hi > lo ? (v - lo) / (hi - lo) * 255.0 : v;
    return static_cast<std::uint8_t>(std::clamp(x + 0.5, 0.0, 255.0));
  };
  e57::PointStream stream = r.open_points(si, mask);
  e57::PointBuffer b;
  std::vector<char> rec;
  while (const std::size_t n = stream.read(b, 1 << 16)) {
    rec.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (b.present(PointField::kCartesianInvalidState) && b.cartesian_invalid_state[i] != 0) {
        continue;
      }
      const Eigen::Vector3d p =
          rotation * Eigen::Vector3d(b.cartesian_x[i], b.cartesian_y[i], b.cartesian_z[i]) + t;
      const float xyz[3] = {static_cast<float>(p.x()), static_cast<float>(p.y()),
                            static_cast<float>(p.z())};
      rec.insert(rec.end(), reinterpret_cast<const char*>(xyz),
                 reinterpret_cast<const char*>(xyz) + sizeof xyz);
      if (colour) {
        rec.push_back(static_cast<char>(to_byte(b.color_red[i], lim.red_min, lim.red_max)));
        rec.push_back(static_cast<char>(to_byte(b.color_green[i], lim.green_min, lim.green_max)));
        rec.push_back(static_cast<char>(to_byte(b.color_blue[i], lim.blue_min, lim.blue_max)));
      }
      ++written;
    }
    f.add_bytes(rec.data(), rec.size());
    progress.advance(n);
  }
  return written;
}

// Binary little-endian PLY of every valid cartesian point, in the file (world) frame unless
// `local`; colour scaled to 0..255 by the scan's colorLimits.
void to_ply(const std::string& file, const std::string& out, bool local) {
  // Checked before the scan is opened: an unwritable output fails at once, and a failure later
  // leaves an existing PLY as it was (PlyWriter replaces it only when complete).
  { const AtomicFile probe(out); }
  const e57::Reader r(file);
  bool colour = !r.scans().empty();
  std::uint64_t total = 0;
  for (const auto& s : r.scans()) {
    if (!(s.field_mask & field_bit(PointField::kCartesianX))) {
      throw CliFailure("scan '" + s.name + "' has no cartesian coordinates");
    }
    colour = colour && (s.field_mask & field_bit(PointField::kColorRed));
    total += s.point_count;
  }
  std::vector<PlyProperty> properties = {
      {"x", PlyType::kFloat}, {"y", PlyType::kFloat}, {"z", PlyType::kFloat}};
  if (colour)
    properties.insert(
        properties.end(),
        {{"red", PlyType::kUchar}, {"green", PlyType::kUchar}, {"blue", PlyType::kUchar}});
  PlyWriter f(out, properties, "written by coloc e57 to-ply");
  std::uint64_t written = 0;
  Progress progress("to-ply", total);
  for (std::size_t si = 0; si < r.scans().size(); ++si)
    written += append_scan_points(r, si, colour, local, f, progress);
  progress.finish();
  f.commit();
  std::cout << "wrote " << written << " points to " << out << "\n";
}

// Peak resident memory since the last reset_peak_memory() (Linux /proc), in MiB.
void reset_peak_memory() {
  std::ofstream("/proc/self/clear_refs") << "5";
}
double peak_memory_mib() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

fs::path generate_synthetic(std::size_t n) {
  fs::path path = fs::temp_directory_path() / "coloc_bench_e57.e57";
  Progress progress("writing synthetic E57", n);
  e57::write_synthetic_scan(path, n, 1 << 18, [&](std::size_t done) { progress.set(done); });
  progress.finish();
  return path;
}

struct E57BenchArgs {
  std::string file;
  std::size_t points = 20'000'000;
  std::size_t chunk = 1 << 16;
  int repeats = 3;
  double crc_fraction = 1.0;
};

// Per field (x, y, z, red, green, blue), eight partial sums: point i of a chunk goes into sum
// i % 8 (chunks start at multiples of 8 within a scan). The eight chains of adds overlap instead
// of each add waiting on the last, and the order is fixed, so another reader summing the same
// way gets the same bits.
using Sums = std::array<std::array<double, 8>, 6>;

template <typename T>
void add_lanes(const T* v, std::size_t n, std::array<double, 8>& sums) {
  std::array<double, 8> s = sums;
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    for (std::size_t j = 0; j < 8; ++j)
      s[j] += static_cast<double>(v[i + j]);
  }
  for (; i < n; ++i)
    s[i % 8] += static_cast<double>(v[i]);
  sums = s;
}

// Cartesian coordinates present (colour optional): the points the sums are about.
bool has_summed_fields(const e57::PointBuffer& b) {
  return b.present(PointField::kCartesianX) && b.present(PointField::kCartesianY) &&
         b.present(PointField::kCartesianZ) &&
         b.present(PointField::kColorRed) == b.present(PointField::kColorGreen) &&
         b.present(PointField::kColorRed) == b.present(PointField::kColorBlue);
}

// One scan read `a.repeats` times: the best wall and CPU times, the points, and the sums of the
// last pass added to `sums` (what the reader delivered, so it cannot be optimised away).
struct ScanRead {
  double wall = 1e30;
  double cpu = 1e30;
  std::uint64_t points = 0;
};

ScanRead read_scan(const e57::Reader& r, std::size_t s, const E57BenchArgs& a, Sums& sums) {
  constexpr std::array<PointField, 6> kSummed = {PointField::kCartesianX, PointField::kCartesianY,
                                                 PointField::kCartesianZ, PointField::kColorRed,
                                                 PointField::kColorGreen, PointField::kColorBlue};
  // ScaledInteger XYZ + colour where present (the DESIGN target), else whatever there is.
  std::uint32_t mask = 0;
  for (const PointField f : kSummed)
    mask |= field_bit(f);
  mask &= r.scans()[s].field_mask;
  ScanRead best;
  Sums scan_sums{};
  for (int rep = 0; rep < a.repeats; ++rep) {
    // The reader decodes on this thread only, so its CPU time is the read's cost without the
    // time other processes held the core.
    const Stopwatch wall_watch;
    const ThreadCpuStopwatch cpu_watch;
    e57::PointStream stream = r.open_points(s, mask);
    e57::PointBuffer chunk;
    best.points = 0;
    scan_sums = sums;
    while (const std::size_t n = stream.read(chunk, a.chunk)) {
      best.points += n;
      if (!has_summed_fields(chunk)) continue;
      add_lanes(chunk.cartesian_x.data(), n, scan_sums[0]);
      add_lanes(chunk.cartesian_y.data(), n, scan_sums[1]);
      add_lanes(chunk.cartesian_z.data(), n, scan_sums[2]);
      if (chunk.present(PointField::kColorRed)) {
        add_lanes(chunk.color_red.data(), n, scan_sums[3]);
        add_lanes(chunk.color_green.data(), n, scan_sums[4]);
        add_lanes(chunk.color_blue.data(), n, scan_sums[5]);
      }
    }
    best.wall = std::min(best.wall, wall_watch.elapsed_seconds());
    best.cpu = std::min(best.cpu, cpu_watch.elapsed_seconds());
  }
  sums = scan_sums;
  return best;
}

void bench_e57(const E57BenchArgs& a) {
  const fs::path path = a.file.empty() ? generate_synthetic(a.points) : fs::path(a.file);
  // Opening (header, XML, model) counts in the whole-file figure: another reader's time to
  // read a file includes it too.
  const Stopwatch open_wall_watch;
  const ThreadCpuStopwatch open_cpu_watch;
  const e57::Reader r(path, {.checksums = e57::ChecksumPolicy::sampled(a.crc_fraction)});
  const double open_wall = open_wall_watch.elapsed_seconds();
  const double open_cpu = open_cpu_watch.elapsed_seconds();
  std::printf("file: %s (%.1f MB), CRC check fraction %.2f, chunk %zu points\n",
              path.string().c_str(), static_cast<double>(fs::file_size(path)) / 1e6, a.crc_fraction,
              a.chunk);
  // Every value of the last pass is summed (see Sums), so the sums can be compared with another
  // reader's on the same file.
  Sums sums{};
  std::uint64_t total_points = 0;
  double total_wall = open_wall;
  double total_cpu = open_cpu;
  for (std::size_t s = 0; s < r.scans().size(); ++s) {
    reset_peak_memory();
    const double base = peak_memory_mib();
    const ScanRead scan = read_scan(r, s, a, sums);
    total_points += scan.points;
    total_wall += scan.wall;
    total_cpu += scan.cpu;
    std::printf(
        "scan %zu '%s': %llu points; best of %d: %.1f ms wall = %.1f M points/s, %.1f ms CPU = "
        "%.1f M points/s; peak memory during reads %.1f MiB (%.1f MiB above the process "
        "baseline)\n",
        s, r.scans()[s].name.c_str(), static_cast<unsigned long long>(scan.points), a.repeats,
        scan.wall * 1e3, static_cast<double>(scan.points) / scan.wall / 1e6, scan.cpu * 1e3,
        static_cast<double>(scan.points) / std::max(scan.cpu, 1e-9) / 1e6, peak_memory_mib(),
        peak_memory_mib() - base);
  }
  std::array<double, 6> total{};
  for (std::size_t k = 0; k < total.size(); ++k)
    total[k] = ((sums[k][0] + sums[k][1]) + (sums[k][2] + sums[k][3])) +
               ((sums[k][4] + sums[k][5]) + (sums[k][6] + sums[k][7]));
  std::printf(
      "opening and all %zu scans: %llu points in %.1f ms wall = %.1f M points/s, %.1f ms CPU = "
      "%.1f M points/s (opening %.1f ms wall)\nsums x %.6f y %.6f z %.6f r %.1f g %.1f b %.1f\n",
      r.scans().size(), static_cast<unsigned long long>(total_points), total_wall * 1e3,
      static_cast<double>(total_points) / std::max(total_wall, 1e-9) / 1e6, total_cpu * 1e3,
      static_cast<double>(total_points) / std::max(total_cpu, 1e-9) / 1e6, open_wall * 1e3,
      total[0], total[1], total[2], total[3], total[4], total[5]);
}

}  // namespace

void add_e57_verb(CLI::App& app, CLI::App& bench) {
  CLI::App& e57cmd = *app.add_subcommand("e57", "Inspect and convert ASTM E57 scans (e57io)");
  e57cmd.require_subcommand(1);

  auto file = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  CLI::App& info = *e57cmd.add_subcommand("info", "Scans, point counts, fields, bounds, images");
  info.add_option("FILE", *file, "E57 file")->required()->check(CLI::ExistingFile);
  info.add_flag("--json", *json, "Machine-readable output on stdout");
  info.callback([file, json] {
    const e57::Reader r(*file);
    if (*json) {
      print_info_json(r);
    } else {
      print_info_text(r);
    }
  });

  CLI::App& verify = *e57cmd.add_subcommand("verify", "Full CRC and structure check");
  verify.add_option("FILE", *file, "E57 file")->required()->check(CLI::ExistingFile);
  verify.callback([file] {
    const e57::Reader r(*file);
    r.verify();
    std::uint64_t points = 0;
    for (const auto& s : r.scans())
      points += s.point_count;
    std::cout << "ok: " << r.scans().size() << " scans, " << points << " points, "
              << r.images().size() << " images; every page CRC and every section verified\n";
  });

  auto dir = std::make_shared<std::string>();
  CLI::App& ex = *e57cmd.add_subcommand(
      "extract-images", "Write every image (JPEG/PNG) plus images.yaml with intrinsics and poses");
  ex.add_option("FILE", *file, "E57 file")->required()->check(CLI::ExistingFile);
  ex.add_option("DIR", *dir, "Output directory")->required();
  ex.callback([file, dir] { extract_images(*file, *dir); });

  auto local = std::make_shared<bool>(false);
  CLI::App& ply = *e57cmd.add_subcommand("to-ply", "Valid cartesian points as binary PLY");
  ply.add_option("FILE", *file, "E57 file")->required()->check(CLI::ExistingFile);
  ply.add_option("OUT", *dir, "Output .ply")->required();
  ply.add_flag("--local", *local, "Keep each scan's local frame (do not apply its pose)");
  ply.callback([file, dir, local] { to_ply(*file, *dir, *local); });

  auto args = std::make_shared<E57BenchArgs>();
  CLI::App& b = *bench.add_subcommand(
      "e57", "E57 read throughput (points/s) and peak memory; synthetic file if none given");
  b.alias("e57-read");
  b.add_option("FILE", args->file, "E57 file (default: generate a synthetic scan)")
      ->check(CLI::ExistingFile);
  b.add_option("--points", args->points, "Points of the synthetic scan")->capture_default_str();
  b.add_option("--chunk", args->chunk, "Points per read() call")->capture_default_str();
  b.add_option("--repeats", args->repeats, "Timed passes (best is reported)")
      ->capture_default_str();
  b.add_option("--crc", args->crc_fraction, "Fraction of pages whose CRC is checked")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  b.callback([args] { bench_e57(*args); });
}

}  // namespace coloc::cli
