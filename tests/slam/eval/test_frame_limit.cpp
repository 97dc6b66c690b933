#include <gtest/gtest.h>

#include "slam/core/error.hpp"
#include "slam/eval/frame_limit.hpp"
#include "tests/testing/data.hpp"

namespace coloc::eval {
namespace {

settings::Settings tum1_settings() {
  return settings::load_settings(std::filesystem::path(COLOC_TEST_SOURCE_DIR) / "Examples" /
                                 "RGB-D" / "TUM1.yaml");
}

std::unique_ptr<dataset::Sequence> open_with(const std::filesystem::path& dir,
                                             const settings::Settings& s) {
  return dataset::open_sequence(dir, {.depth_scale = s.depth->depth_map_factor});
}

// The bounds of the `coloc eval frame-limit` check (tests/slam/eval/frame_limit_check.py), on
// the library: a working matcher and pose optimizer on a slow, sharp clip stay far below the
// degrees and centimetres of a broken one, and the shipped 20 ms rolling-shutter readout lowers
// the limit against the global-shutter model (a wrong sign or row order raises it).
TEST(FrameLimit, RealTumClipIsSolvedAndTheReadoutLowersTheLimit) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const settings::Settings settings = tum1_settings();
  const auto sequence = open_with(dir, settings);
  std::size_t calls = 0;
  const FrameLimitResult r =
      measure_frame_limit(*sequence, settings, {}, [&](std::size_t done, std::size_t total) {
        ++calls;
        EXPECT_EQ(done, calls);
        EXPECT_EQ(total, sequence->size());
      });
  EXPECT_EQ(calls, sequence->size());
  EXPECT_DOUBLE_EQ(r.readout, settings.readout_time.value_or(0.0));
  EXPECT_GT(r.readout, 0.0);
  EXPECT_GE(r.pairs.size(), 34u);
  EXPECT_EQ(r.translation_mm.count, r.pairs.size());
  EXPECT_LT(r.rotation_deg.rmse, 0.6);
  EXPECT_LT(r.translation_mm.rmse, 8.0);
  EXPECT_GT(r.inliers.median, 200.0);
  const auto worst = r.worst(3);
  ASSERT_EQ(worst.size(), 3u);
  EXPECT_DOUBLE_EQ(worst[0].translation_mm, r.translation_mm.max);
  EXPECT_GE(worst[0].translation_mm, worst[1].translation_mm);
  EXPECT_GE(worst[1].translation_mm, worst[2].translation_mm);
  for (const FramePairError& p : r.pairs) {
    EXPECT_GE(p.frame, 1u);
    EXPECT_GE(p.matches, 10u);
    EXPECT_LE(static_cast<std::size_t>(p.inliers), p.matches);
  }
  const FrameLimitResult global_shutter =
      measure_frame_limit(*sequence, settings, {.readout = 0.0});
  EXPECT_EQ(global_shutter.readout, 0.0);
  EXPECT_GT(global_shutter.translation_mm.rmse, 1.2 * r.translation_mm.rmse);
}

TEST(FrameLimit, MissingGroundTruthOrDepthModelIsAnErrorNamingTheInput) {
  const settings::Settings settings = tum1_settings();
  settings::Settings no_depth = settings;
  no_depth.depth.reset();
  COLOC_REQUIRE_DATA(tum, "tum_fr1_xyz_37f");
  try {
    measure_frame_limit(*open_with(tum, settings), no_depth);
    FAIL() << "settings without depth accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, settings.source.string());
  }
  COLOC_REQUIRE_DATA(realsense, "realsense_d435_10f");  // a clip without ground truth
  try {
    measure_frame_limit(*open_with(realsense, settings), settings);
    FAIL() << "a sequence without ground truth accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ground truth"), std::string::npos);
    EXPECT_EQ(e.context().file, realsense.string());
  }
}

TEST(FrameLimit, OptionsCheckNamesTheField) {
  FrameLimitOptions o;
  EXPECT_NO_THROW(o.check());
  o.window_px = 0.0;
  try {
    o.check();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "window_px");
  }
  EXPECT_THROW((FrameLimitOptions{.readout = -0.1}.check()), Error);
  EXPECT_THROW((FrameLimitOptions{.max_ratio = 1.5}.check()), Error);
  EXPECT_THROW((FrameLimitOptions{.min_matches = 2}.check()), Error);
}

}  // namespace
}  // namespace coloc::eval
