// Relocalization against a map built from the synthetic RGB-D scene: the full pipeline (BoW,
// EPnP-RANSAC, optimization, projection passes) and the narrow second projection pass started
// from a rough pose, as an inaccurate EPnP pose would leave it.
#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "slam/bow/database.hpp"
#include "slam/core/error.hpp"
#include "slam/features/orb_extractor.hpp"
#include "slam/frame/frame.hpp"
#include "slam/map/map.hpp"
#include "slam/reloc/relocalizer.hpp"
#include "slam/synthetic/synthetic_scene.hpp"
#include "tests/slam/support/slam_test_support.hpp"

namespace coloc::slam::reloc {
namespace {

// Frames of the synthetic scene with features, depth and BoW, and a one-keyframe map whose
// points come straight from the keyframe's depth at its true pose (world = scene world).
class SyntheticMap {
 public:
  explicit SyntheticMap(int frames) : scene_(options(frames)) {
    const auto s = scene_.settings();
    extractor_ = std::make_unique<features::OrbExtractor>();
    geometry_ = std::make_shared<frame::FrameGeometry>(frame::FrameGeometry::make(
        s.camera, s.depth->bf, s.depth->close_depth, extractor_->scale_factors()));
  }

  frame::Frame make_frame(int index) { return frame_of(scene_, index, *this); }

  // A frame of any scene, with the features, geometry and BoW of `like`.
  static frame::Frame frame_of(const synthetic::SyntheticRgbdScene& scene, int index,
                               SyntheticMap& like) {
    const synthetic::SyntheticFrame f = scene.frame(index);
    cv::Mat grey;
    cv::cvtColor(f.color, grey, cv::COLOR_BGR2GRAY);
    frame::Frame out(FrameId(static_cast<std::uint64_t>(index) + 1), f.timestamp,
                     like.extractor_->extract(grey), f.depth, like.geometry_);
    test_support::vocabulary().transform(out.features.descriptors, out.bow, out.feature_vector);
    return out;
  }

  // Points for every `stride`-th keypoint with depth (a sparser map has fewer matches). A
  // non-zero `offset` makes a look-alike place: the same view and points, moved by it.
  KeyframeId add_keyframe(int index, std::size_t stride = 1,
                          const Eigen::Vector3d& offset = Eigen::Vector3d::Zero()) {
    map::Keyframe kf;
    kf.id = map_.next_keyframe_id();
    kf.frame = make_frame(index);
    kf.frame.cam_from_world = (SE3(SO3(), offset) * scene_.world_from_cam(index)).inverse();
    kf.frame.has_pose = true;
    const KeyframeId id = kf.id;
    const frame::Frame& f = map_.add_keyframe(std::move(kf)).frame;
    for (std::size_t i = 0; i < f.size(); i += stride) {
      if (f.has_depth(i)) map_.add_point(f.unproject_world(i), id, static_cast<std::uint32_t>(i));
    }
    database_.add(id.value(), f.bow);
    return id;
  }

  const synthetic::SyntheticRgbdScene& scene() const { return scene_; }
  const map::Map& map() const { return map_; }
  const bow::BowDatabase& database() const { return database_; }

 private:
  static synthetic::SyntheticSceneOptions options(int frames) {
    synthetic::SyntheticSceneOptions o;
    o.frames = frames;
    return o;
  }
  synthetic::SyntheticRgbdScene scene_;
  std::unique_ptr<features::OrbExtractor> extractor_;
  std::shared_ptr<const frame::FrameGeometry> geometry_;
  map::Map map_;
  bow::BowDatabase database_;
};

TEST(Relocalization, OptionsCheckNamesTheBadField) {
  RelocalizationOptions o;
  EXPECT_NO_THROW(o.check());
  o.narrow_min_inliers = o.min_inliers;
  try {
    o.check();
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("narrow_min_inliers"), std::string::npos);
  }
  o = {};
  o.narrow_radius_px = 0.0;
  EXPECT_THROW(o.check(), Error);
  o = {};
  o.wide_max_distance = 300;
  EXPECT_THROW(o.check(), Error);
}

// Pose errors of an estimated cam_from_world against the scene's truth at `index`.
struct PoseError {
  double translation_m = 0.0;
  double rotation_rad = 0.0;
};
PoseError pose_error(const SyntheticMap& m, int index, const SE3& cam_from_world) {
  const SE3 truth = m.scene().world_from_cam(index);
  const SE3 estimate = cam_from_world.inverse();
  return {translation_distance(truth, estimate), rotation_distance(truth, estimate)};
}

// Dense map (a point for every keypoint with depth): the BoW matches alone give enough inliers.
// Sparse map (every 4th keypoint): fewer BoW matches, so the wide projection pass has to add
// the rest. Either way the pose must come out within 2 cm and 0.5 degrees of the truth.
TEST(Relocalization, RelocalizesSyntheticFramesAgainstDenseAndSparseMaps) {
  for (const std::size_t stride : {1u, 4u}) {
    SyntheticMap m(40);
    const KeyframeId kf = m.add_keyframe(0, stride);
    for (const int j : {10, 20, 39}) {
      frame::Frame f = m.make_frame(j);
      const RelocalizationResult r = relocalize(f, m.map(), m.database());
      ASSERT_TRUE(r.success) << "stride " << stride << " frame " << j;
      EXPECT_EQ(r.keyframe, kf);
      EXPECT_GE(r.inliers, 50);
      EXPECT_EQ(static_cast<int>(f.tracked_count()), r.inliers);  // outliers were dropped
      EXPECT_GE(r.pnp_inliers, RelocalizationOptions{}.min_ransac_inliers);
      if (stride == 4) {
        EXPECT_GT(r.wide_pass_matches, 0) << "frame " << j;
      }
      const PoseError e = pose_error(m, j, f.cam_from_world);
      EXPECT_LT(e.translation_m, 0.02) << "stride " << stride << " frame " << j;
      EXPECT_LT(e.rotation_rad, 0.5 * std::numbers::pi / 180.0)
          << "stride " << stride << " frame " << j;
      std::cout << "stride " << stride << " frame " << j << ": bow " << r.bow_matches << " pnp "
                << r.pnp_inliers << " optimized " << r.optimized_inliers << " wide +"
                << r.wide_pass_matches << " -> " << r.wide_pass_inliers << " inliers " << r.inliers
                << ", error " << 1e3 * e.translation_m << " mm\n";
    }
  }
}

// A frame of another room (other texture seed) matches nothing: failure, no matches left.
TEST(Relocalization, FailsCleanlyOnAnUnknownPlace) {
  SyntheticMap m(2);
  m.add_keyframe(0);
  synthetic::SyntheticSceneOptions other;
  other.seed = 99;
  other.frames = 1;
  frame::Frame f = SyntheticMap::frame_of(synthetic::SyntheticRgbdScene(other), 0, m);
  const RelocalizationResult r = relocalize(f, m.map(), m.database());
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.inliers, 0);
  EXPECT_EQ(f.tracked_count(), 0u);
}

// A look-alike place 1 m away (the same view and points, moved): both keyframes relocalize the
// frame, each at its own place. Tracking lost a moment ago knows where the camera can be: the
// prior passes over the look-alike outside its bound and, of the poses inside, takes the
// nearest, whichever candidate comes first.
TEST(Relocalization, APriorPassesOverALookAlikePlace) {
  SyntheticMap m(20);
  const Eigen::Vector3d offset(1.0, 0.0, 0.0);
  const KeyframeId right = m.add_keyframe(0);
  const KeyframeId look_alike = m.add_keyframe(0, 1, offset);
  const int j = 10;
  const Eigen::Vector3d centre = m.scene().world_from_cam(j).translation();
  const auto relocalize_near = [&](const Eigen::Vector3d& where, double bound,
                                   std::vector<KeyframeId> first) {
    frame::Frame f = m.make_frame(j);
    RelocalizationPrior prior{
        .keyframes = std::move(first), .world_centre = where, .max_distance_m = bound};
    const RelocalizationResult r = relocalize(f, m.map(), m.database(), {}, prior);
    return std::pair(r, f.cam_from_world);
  };
  // Tried first, the look-alike is outside the bound: passed over, and the right place wins.
  const auto [r, pose] = relocalize_near(centre, 0.3, {look_alike});
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.keyframe, right);
  EXPECT_EQ(r.implausible, 1);
  EXPECT_NEAR(r.nearest_implausible_m, 1.0, 0.05);
  EXPECT_LT(pose_error(m, j, pose).translation_m, 0.02);
  // Both inside a wide bound: the nearer one wins, in either order.
  for (const auto& first : {std::vector{right}, std::vector{look_alike}}) {
    EXPECT_EQ(relocalize_near(centre, 5.0, first).first.keyframe, right);
    EXPECT_EQ(relocalize_near(centre + offset, 5.0, first).first.keyframe, look_alike);
  }
  // Neither inside: the frame stays lost, with nothing matched.
  const auto [none, unused] = relocalize_near(centre + Eigen::Vector3d(0, 0, 3), 0.5, {});
  EXPECT_FALSE(none.success);
  EXPECT_EQ(none.implausible, 2);
}

// The narrow pass, started from a rough pose as few, clustered BoW matches would leave it: the
// pose is rolled 0.12 rad (about 7 degrees) about the optical axis, so the wide pass (10 px)
// only finds the points near the image centre; its optimization repairs the pose but leaves
// between 30 and 50 inliers. The narrow pass (3 px, Hamming <= 64) at the repaired pose must
// bring the support to >= 50 and the pose within 2 cm and 0.5 degrees of the truth. Without
// the narrow pass the same frames stay below 50 inliers (relocalization would fail).
TEST(Relocalization, NarrowPassRecoversMatchesAfterARoughPose) {
  SyntheticMap m(21);
  const KeyframeId kf_id = m.add_keyframe(0, 4);
  const map::Keyframe& kf = *m.map().keyframe(kf_id);
  const RelocalizationOptions options;
  RelocalizationOptions wide_only;
  wide_only.narrow_min_inliers = wide_only.min_inliers - 1;  // the narrow pass never runs
  for (const int j : {5, 10, 20}) {
    const SE3 rough = SE3(SO3::exp(Eigen::Vector3d(0.0, 0.0, 0.12)), Eigen::Vector3d::Zero()) *
                      m.scene().world_from_cam(j).inverse();
    frame::Frame f = m.make_frame(j);
    f.points.assign(f.size(), MapPointId::invalid());
    f.outlier.assign(f.size(), 0);
    f.cam_from_world = rough;
    frame::Frame g = f;
    RelocalizationResult r;
    const int inliers = search_by_projection_passes(f, kf, m.map(), options, r);
    EXPECT_GT(r.wide_pass_inliers, options.narrow_min_inliers) << "frame " << j;
    EXPECT_LT(r.wide_pass_inliers, options.min_inliers) << "frame " << j;
    EXPECT_GE(r.narrow_pass_matches, 20) << "frame " << j;
    EXPECT_GE(r.narrow_pass_inliers, options.min_inliers) << "frame " << j;
    EXPECT_EQ(inliers, r.narrow_pass_inliers);
    EXPECT_EQ(r.inliers, inliers);
    const PoseError e = pose_error(m, j, f.cam_from_world);
    EXPECT_LT(e.translation_m, 0.02) << "frame " << j;
    EXPECT_LT(e.rotation_rad, 0.5 * std::numbers::pi / 180.0) << "frame " << j;

    RelocalizationResult w;
    EXPECT_LT(search_by_projection_passes(g, kf, m.map(), wide_only, w), options.min_inliers);
    EXPECT_EQ(w.narrow_pass_matches, 0);
    std::cout << "frame " << j << ": wide +" << r.wide_pass_matches << " -> " << r.wide_pass_inliers
              << " inliers, narrow +" << r.narrow_pass_matches << " -> " << r.narrow_pass_inliers
              << " inliers, error " << 1e3 * e.translation_m << " mm, "
              << e.rotation_rad * 180.0 / std::numbers::pi << " deg\n";
  }
}

}  // namespace
}  // namespace coloc::slam::reloc
