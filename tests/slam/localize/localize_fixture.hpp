#pragma once
// The real thing the localization tests stand on: a twin room walk (6 s, rendered by
// registration/twin), mapped by the SLAM system (sequential, loop closing, global BA as
// `coloc map` does), saved with the SQLite map database. Built once per build tree and shared
// by every test process (ctest runs each test as its own process): the first one builds it under
// a file lock into a temporary folder and renames it into place; the others load it.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "registration/twin/generator.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/mapdb/mapdb.hpp"
#include "slam/settings/settings.hpp"
#include "slam/system/system.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::localize::test {

struct LocalizeFixture {
  std::filesystem::path dir, sequence, map;
  Trajectory mapped;     // every frame's world_from_cam as SLAM left it (map frame)
  Trajectory keyframes;  // the saved keyframes' world_from_cam
};

inline constexpr double kFixtureSeconds = 6.0;

// The rotation between two poses, degrees.
inline double angle_deg(const SE3& a, const SE3& b) {
  return (a.so3().inverse() * b.so3()).log().norm() * 180.0 / M_PI;
}

inline void build_fixture(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  registration::twin::GenerateOptions g =
      registration::twin::preset_options(registration::twin::Preset::kRoom);
  g.seed = 1;
  g.max_duration = kFixtureSeconds;
  g.write_scan = false;
  g.quiet = true;
  registration::twin::generate_twin(g, dir);
  const fs::path config = dir / "sequence" / "camera.yaml";
  const settings::Settings settings = settings::load_settings(config);
  dataset::SequenceOptions so;
  so.depth_scale = settings.depth->depth_map_factor;
  const auto sequence = dataset::open_sequence(dir / "sequence", so);
  system::SystemOptions options;
  options.tracking.wait_for_sink = true;  // deterministic
  options.detect_markers = false;
  system::System slam(settings, test_support::vocabulary(), options);
  for (std::size_t i = 0; i < sequence->size(); ++i) {
    const dataset::Frame f = sequence->frame(i);
    // The camera's channel order, as `coloc map` hands frames to tracking.
    slam.track(dataset::to_camera_order(f.color, settings.rgb_order), f.depth, f.timestamp);
  }
  slam.optimize_map();
  write_tum_trajectory(dir / "mapped.txt", slam.trajectory());
  mapdb::MapMetadata metadata;
  metadata.vocabulary_checksum = mapdb::vocabulary_checksum(test_support::vocabulary());
  metadata.vocabulary_words = test_support::vocabulary().word_count();
  std::ifstream in(config);
  std::ostringstream text;
  text << in.rdbuf();
  metadata.settings = text.str();
  metadata.camera = settings.camera;
  slam.with_map([&](const map::Map& m) { return mapdb::save_map(m, metadata, dir / "map.db"); });
}

inline const LocalizeFixture& fixture() {
  namespace fs = std::filesystem;
  static const LocalizeFixture kFixture = [] {
    const fs::path dir = fs::path(COLOC_LOCALIZE_FIXTURE_DIR) / "twin_room_6s_v2";
    fs::create_directories(dir.parent_path());
    if (!fs::exists(dir / "map.db")) {
      const std::string lock_path = dir.string() + ".lock";
      const int fd = ::open(lock_path.c_str(), O_CREAT | O_RDWR, 0644);
      if (fd >= 0) ::flock(fd, LOCK_EX);
      if (!fs::exists(dir / "map.db")) {
        const fs::path tmp = dir.string() + ".tmp-" + std::to_string(::getpid());
        fs::remove_all(tmp);
        build_fixture(tmp);
        fs::rename(tmp, dir);
      }
      if (fd >= 0) ::close(fd);  // releases the lock
    }
    LocalizeFixture out;
    out.dir = dir;
    out.sequence = dir / "sequence";
    out.map = dir / "map.db";
    out.mapped = read_tum_trajectory(dir / "mapped.txt");
    out.keyframes = mapdb::read_keyframe_trajectory(out.map);
    return out;
  }();
  return kFixture;
}

}  // namespace coloc::slam::localize::test
