#pragma once
// The test walk of Table 2 (table2.hpp; `coloc eval table2 --sequence`): a sequence that did not
// build the map, localized frame by frame in a registered map (slam/localize, localization only),
// as the paper evaluates (Michiels et al. 2024, section 6: a second recording localized in the
// registered map). Every localized pose is kept for the TRUE co-location error against ground
// truth; every `every`-th localized frame also keeps its undistorted ORB features, to be matched
// against the scan rendered at its localized pose (the paper's three metrics).
#include <cstddef>
#include <filesystem>
#include <vector>

#include "registration/align/refine.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::registration::align {

struct WalkOptions {
  std::filesystem::path sequence;
  std::filesystem::path config;  // empty: the settings saved in the map
  std::size_t every = 15;        // frames matched against the scan: one in `every` localized
  bool quiet = false;            // no progress bar (on stderr)
};

struct LocalizedWalk {
  std::size_t frames = 0, localized = 0, skipped = 0;
  Trajectory trajectory;  // world_from_cam of every localized frame, in the map's frame
  std::vector<slam::features::OrbFeatures> features;  // of the sampled frames
  // Views of the sampled frames (pointing into `features`: do not copy or grow it).
  std::vector<MatchView> views;
};

// Throws coloc::Error naming the map or sequence file when either cannot be read, or when no
// frame of the walk localized.
LocalizedWalk localize_walk(const std::filesystem::path& map_path,
                            const slam::bow::Vocabulary& vocabulary, const WalkOptions& options);

}  // namespace coloc::registration::align
