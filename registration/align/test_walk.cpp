#include "registration/align/test_walk.hpp"

#include <spdlog/spdlog.h>

#include <optional>

#include "slam/core/error.hpp"
#include "slam/core/progress.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/localize/localizer.hpp"
#include "slam/tracking/image_features.hpp"

namespace coloc::registration::align {

namespace fs = std::filesystem;
using slam::localize::LocalizationState;

LocalizedWalk localize_walk(const fs::path& map_path, const slam::bow::Vocabulary& vocabulary,
                            const WalkOptions& o) {
  if (o.every == 0) throw Error("must be >= 1", {.field = "every"});
  const auto map = slam::localize::load_localization_map(map_path, vocabulary);
  const settings::Settings settings = o.config.empty()
                                          ? slam::localize::settings_saved_in(*map, map_path)
                                          : settings::load_settings(o.config);
  // The settings' DepthMapFactor says how the walk's raw depth becomes metres.
  dataset::SequenceOptions sequence_options;
  if (settings.depth) sequence_options.depth_scale = settings.depth->depth_map_factor;
  const auto sequence = dataset::open_sequence(o.sequence, sequence_options);
  const slam::localize::LocalizerOptions options = slam::localize::options_from_settings(settings);
  slam::localize::Localizer localizer(*map, vocabulary, settings, options);
  // The features tracking extracts (Camera.RGB decides the channel weights), so the sampled
  // frames' features are the ones the localizer saw.
  slam::tracking::FeatureExtraction extraction(options.extractor, settings.camera,
                                               settings.rgb_order);
  LocalizedWalk walk;
  walk.frames = sequence->size();
  std::vector<SE3> sampled_poses;
  std::vector<double> sampled_times;
  Progress progress("localizing the test walk", sequence->size(), o.quiet);
  for (std::size_t i = 0; i < sequence->size(); ++i) {
    progress.set(i + 1);
    std::optional<dataset::Frame> frame;
    try {
      frame = sequence->frame(i);
    } catch (const Error& e) {
      spdlog::warn("frame {} skipped: {}", i, e.what());
      ++walk.skipped;
      continue;
    }
    const auto r = localizer.localize(frame->color, frame->depth, frame->timestamp);
    // Bridged poses drift: the walk's views refine the registration, so only poses localized in
    // the map count.
    if (r.state == LocalizationState::kLost || r.state == LocalizationState::kOdometry) continue;
    walk.trajectory.push_back({r.timestamp, r.world_from_cam});
    if (walk.localized++ % o.every != 0) continue;
    walk.features.push_back(extraction(frame->color).features);
    sampled_poses.push_back(r.world_from_cam.inverse());
    sampled_times.push_back(r.timestamp);
  }
  progress.finish();
  if (walk.localized == 0)
    throw Error("no frame of the test walk localized in the map", {.file = o.sequence.string()});
  // Views are built once `features` stops growing (they point into it).
  for (std::size_t k = 0; k < walk.features.size(); ++k)
    walk.views.push_back({KeyframeId{}, sampled_times[k], &walk.features[k], sampled_poses[k]});
  return walk;
}

}  // namespace coloc::registration::align
