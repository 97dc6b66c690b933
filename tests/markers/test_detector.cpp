// Detection on real photographs from ../shared/data (see its README) and on error inputs.

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <regex>
#include <set>

#include "markers/detector.hpp"
#include "markers/dictionary.hpp"
#include "markers/marker_pose.hpp"
#include "slam/core/align.hpp"
#include "slam/core/error.hpp"
#include "tests/markers/helpers.hpp"
#include "tests/testing/data.hpp"

namespace coloc::markers {
namespace {

std::set<int> ids_of(const std::vector<MarkerObservation>& observations) {
  std::set<int> ids;
  for (const auto& o : observations)
    ids.insert(o.id);
  return ids;
}

cv::Mat read_image(const std::filesystem::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  if (image.empty()) ADD_FAILURE() << "cannot read " << path;
  return image;
}

TEST(Detector, OpenCvTutorialSingleMarkers) {
  COLOC_REQUIRE_DATA(dir, "aruco_opencv_tutorial");
  const MarkerDetector detector({.dictionary = "DICT_6X6_250"});
  const auto observations = detector.detect(read_image(dir / "singlemarkersoriginal.jpg"));
  EXPECT_EQ(ids_of(observations), (std::set<int>{23, 40, 62, 98, 124, 203}));
  // With the tutorial's calibration every marker's IPPE pose reprojects within a pixel.
  const Camera camera = test::read_opencv_camera(dir / "tutorial_camera_params.yml", 640, 480);
  for (const auto& obs : observations) {
    EXPECT_EQ(obs.image_width, 640);
    EXPECT_EQ(obs.image_height, 480);
    const auto pose = estimate_marker_pose(camera, obs, {.marker_size = 0.05});
    ASSERT_TRUE(pose.has_value()) << obs.id;
    EXPECT_LT(pose->reprojection_error_px(), 1.0) << obs.id;
  }
}

// Edge-line refinement on real (JPEG, distorted) photos: same markers, corners within a pixel of
// the sub-pixel ones, poses still consistent.
TEST(Detector, EdgeLineRefinementOnRealPhotos) {
  COLOC_REQUIRE_DATA(dir, "aruco_opencv_tutorial");
  const cv::Mat image = read_image(dir / "singlemarkersoriginal.jpg");
  const auto sub = MarkerDetector({.dictionary = "DICT_6X6_250"}).detect(image);
  const auto edges = MarkerDetector({.dictionary = "DICT_6X6_250",
                                     .corner_refinement = CornerRefinement::kEdgeLines})
                         .detect(image);
  ASSERT_EQ(sub.size(), edges.size());
  const Camera camera = test::read_opencv_camera(dir / "tutorial_camera_params.yml", 640, 480);
  for (std::size_t i = 0; i < sub.size(); ++i) {
    EXPECT_EQ(sub[i].id, edges[i].id);
    for (int c = 0; c < 4; ++c)
      EXPECT_LT((sub[i].corners[c] - edges[i].corners[c]).norm(), 1.0);
    const auto pose = estimate_marker_pose(camera, edges[i], {.marker_size = 0.05});
    ASSERT_TRUE(pose.has_value());
    EXPECT_LT(pose->reprojection_error_px(), 1.0);
  }
}

TEST(Detector, OpenCvTutorialDetectorParametersFileLoads) {
  COLOC_REQUIRE_DATA(dir, "aruco_opencv_tutorial");
  const MarkerDetector detector(
      {.dictionary = "6x6_250", .parameters_file = dir / "detector_params.yml"});
  EXPECT_EQ(detector.detect(read_image(dir / "singlemarkersoriginal.jpg")).size(), 6u);
}

// GridBoard 5x7 with the tutorial's custom dictionary: markers 0.04 m, gaps 0.01 m, id = row * 5
// + column. The board's geometry checks the single-marker poses. The tutorial's calibration fits
// this photo only roughly (a full-board PnP leaves 2.9 px RMS), so positions are compared up to
// scale, and rotations after resolving each marker's IPPE ambiguity with the board's rotation.
TEST(Detector, GridBoardPosesAgreeWithBoardGeometry) {
  COLOC_REQUIRE_DATA(dir, "aruco_opencv_tutorial");
  const MarkerDetector detector({.dictionary = (dir / "tutorial_dict.yml").string()});
  const auto observations = detector.detect(read_image(dir / "gboriginal.png"));
  std::set<int> expected;
  for (int i = 0; i < 35; ++i)
    expected.insert(i);
  EXPECT_EQ(ids_of(observations), expected);

  const Camera camera = test::read_opencv_camera(dir / "tutorial_camera_params.yml", 640, 480);
  std::vector<MarkerPose> poses;
  std::vector<Eigen::Vector3d> measured, board;
  for (const auto& obs : observations) {
    const auto pose = estimate_marker_pose(camera, obs, {.marker_size = 0.04});
    ASSERT_TRUE(pose.has_value());
    EXPECT_LT(pose->reprojection_error_px(), 2.0);
    poses.push_back(*pose);
    measured.push_back(pose->camera_from_marker().translation());
    board.emplace_back(0.05 * (obs.id % 5), -0.05 * (obs.id / 5), 0.0);
  }
  const AlignmentResult fit = align_points(board, measured, {.estimate_scale = true});
  ASSERT_TRUE(fit.usable);
  RecordProperty("centre_rms_mm", std::to_string(fit.rmse * 1e3));
  // Single-marker depth from 40 px markers at 0.6 m is good to ~1 % (a 0.5 px edge error).
  EXPECT_LT(fit.rmse, 0.010);
  EXPECT_NEAR(fit.dst_from_src.scale(), 1.0, 0.15);

  // All markers share the board's rotation. The photo is oblique, yet many markers are
  // ambiguous; the unambiguous ones agree, and the prior they give resolves the others.
  std::vector<SO3> confident;
  int ambiguous = 0;
  for (const MarkerPose& p : poses) {
    if (p.ambiguous) {
      ++ambiguous;
    } else {
      confident.push_back(p.camera_from_marker().so3());
    }
  }
  ASSERT_GE(confident.size(), 5u);
  EXPECT_GE(ambiguous, 1);
  const SO3 prior = confident.front();
  for (const SO3& r : confident) {
    EXPECT_LT((prior.inverse() * r).angle(), 10.0 * M_PI / 180.0);
  }
  for (const MarkerPose& p : poses) {
    const MarkerPose resolved = choose_closest(p, prior);
    EXPECT_LT((prior.inverse() * resolved.camera_from_marker().so3()).angle(), 12.0 * M_PI / 180.0)
        << "marker " << p.id;
  }
}

TEST(Detector, DuckietownAprilTags) {
  COLOC_REQUIRE_DATA(dir, "apriltag_duckietown");
  const MarkerDetector detector({.dictionary = "DICT_APRILTAG_36h11"});
  // multiple_tags_test intrinsics of test_info.yaml; tags 0.065 m.
  PinholeCamera camera = test::vga_camera();
  camera.fx = 338.563277422543;
  camera.fy = 338.939280638548;
  camera.cx = 336.45495347495824;
  camera.cy = 230.486982216255;
  const std::set<int> known{22, 24, 58, 85, 144, 198};
  int total = 0;
  std::vector<double> errors;
  for (int i = 1; i <= 10; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "test_image_multiple_%02d.png", i);
    const auto observations = detector.detect(read_image(dir / name));
    EXPECT_GE(observations.size(), 3u) << name;
    total += static_cast<int>(observations.size());
    for (const auto& obs : observations) {
      EXPECT_TRUE(known.count(obs.id)) << name << ": unexpected id " << obs.id;
      const auto pose = estimate_marker_pose(camera, obs, {.marker_size = 0.065});
      ASSERT_TRUE(pose.has_value());
      // The Duckiebot's lens distortion is not in test_info.yaml: a few pixels remain.
      EXPECT_LT(pose->reprojection_error_px(), 5.0) << name << " id " << obs.id;
      errors.push_back(pose->reprojection_error_px());
      EXPECT_GT(pose->distance(), 0.05);
      EXPECT_LT(pose->distance(), 3.0);
    }
  }
  EXPECT_GE(total, 38);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 2.0);
}

TEST(Detector, FrankaEyeToHandTagSeenInEveryImage) {
  COLOC_REQUIRE_DATA(dir, "handeye_visp_franka/eye-to-hand");
  const MarkerDetector detector({.dictionary = "DICT_APRILTAG_36h11"});
  PinholeCamera camera = test::vga_camera();
  camera.fx = 607.5931396484375;
  camera.fy = 607.574951171875;
  camera.cx = 323.46282958984375;
  camera.cy = 243.25529479980469;
  for (int i = 1; i <= 8; ++i) {
    const auto path = dir / ("franka_image-" + std::to_string(i) + ".png");
    const auto observations = detector.detect(read_image(path));
    ASSERT_EQ(observations.size(), 1u) << path;
    EXPECT_EQ(observations[0].id, 10);
    const auto pose = estimate_marker_pose(camera, observations[0], {.marker_size = 0.048});
    ASSERT_TRUE(pose.has_value());
    EXPECT_LT(pose->reprojection_error_px(), 1.0);
  }
}

struct ExpectedTag {
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners;
};

std::vector<ExpectedTag> read_expected(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<ExpectedTag> tags;
  std::string line;
  const std::regex number(R"([-+]?[0-9]*\.?[0-9]+)");
  while (std::getline(in, line)) {
    std::vector<double> v;
    for (auto it = std::sregex_iterator(line.begin(), line.end(), number);
         it != std::sregex_iterator(); ++it) {
      v.push_back(std::stod(it->str()));
    }
    if (v.size() != 9) continue;
    ExpectedTag tag;
    tag.id = static_cast<int>(v[0]);
    for (int c = 0; c < 4; ++c)
      tag.corners[c] = {v[1 + 2 * c], v[2 + 2 * c]};
    tags.push_back(tag);
  }
  return tags;
}

// Corner distances between a detection and an expected tag under the best of the 4 cyclic shifts
// in both winding orders (the .txt files list corners in another order than OpenCV's).
std::array<double, 4> corner_errors(const MarkerObservation& obs, const ExpectedTag& tag) {
  std::array<double, 4> best{1e9, 1e9, 1e9, 1e9};
  for (int dir : {1, -1}) {
    for (int shift = 0; shift < 4; ++shift) {
      std::array<double, 4> e{};
      for (int c = 0; c < 4; ++c) {
        e[c] = (obs.corners[c] - tag.corners[((shift + dir * c) % 4 + 4) % 4]).norm();
      }
      if (*std::max_element(e.begin(), e.end()) < *std::max_element(best.begin(), best.end())) {
        best = e;
      }
    }
  }
  return best;
}

struct NasaResult {
  int expected = 0, matched = 0, unmatched = 0;
  double mean_px = 0.0, max_px = 0.0;
};

// Detections farther than 3 px from every expected tag count as unmatched: the photos show more
// tags (cube faces, all id 0) than the reference lists, so these are not necessarily false.
NasaResult run_nasa(const std::filesystem::path& dir, CornerRefinement refinement) {
  const MarkerDetector detector(
      {.dictionary = "DICT_APRILTAG_36h11", .corner_refinement = refinement});
  NasaResult r;
  double sum = 0.0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".jpg") continue;
    const auto expected =
        read_expected(std::filesystem::path(entry.path()).replace_extension(".txt"));
    EXPECT_FALSE(expected.empty()) << entry.path();
    r.expected += static_cast<int>(expected.size());
    for (const auto& obs : detector.detect(read_image(entry.path()))) {
      std::array<double, 4> best{1e9, 1e9, 1e9, 1e9};
      for (const auto& tag : expected) {
        if (tag.id != obs.id) continue;
        const auto e = corner_errors(obs, tag);
        if (*std::max_element(e.begin(), e.end()) < *std::max_element(best.begin(), best.end())) {
          best = e;
        }
      }
      if (*std::max_element(best.begin(), best.end()) > 3.0) {
        ++r.unmatched;
        continue;
      }
      ++r.matched;
      for (double e : best) {
        sum += e;
        r.max_px = std::max(r.max_px, e);
      }
    }
  }
  r.mean_px = sum / std::max(1, 4 * r.matched);
  return r;
}

TEST(Detector, NasaAprilTagsMatchExpectedCorners) {
  COLOC_REQUIRE_DATA(dir, "apriltag_nasa_flickr");
  // The reference corners are OpenCV's AprilTag quad fit: with that refinement we must reproduce
  // them exactly (ids, corners, pixel convention).
  const NasaResult april = run_nasa(dir, CornerRefinement::kAprilTag);
  std::printf(
      "NASA, AprilTag refinement: %d of %d matched, %d other, corner error mean %.3f max %.3f px\n",
      april.matched, april.expected, april.unmatched, april.mean_px, april.max_px);
  EXPECT_GE(april.matched, 14);
  EXPECT_EQ(april.unmatched, 0);
  EXPECT_LT(april.max_px, 0.1);
  // Our default (ArUco contour + cell-scaled sub-pixel refinement) finds more of these small
  // (~25 px, 3 px cells) JPEG tags and stays within about a pixel of the AprilTag fit.
  const NasaResult subpix = run_nasa(dir, CornerRefinement::kSubpixel);
  std::printf(
      "NASA, sub-pixel refinement: %d of %d matched, %d other, corner error mean %.3f max %.3f "
      "px\n",
      subpix.matched, subpix.expected, subpix.unmatched, subpix.mean_px, subpix.max_px);
  EXPECT_GE(subpix.matched, 18);
  EXPECT_LE(subpix.unmatched, 3);
  EXPECT_LT(subpix.mean_px, 1.2);
  EXPECT_LT(subpix.max_px, 3.0);
}

TEST(Detector, BadInputsAreErrors) {
  EXPECT_THROW(MarkerDetector({.dictionary = "DICT_9X9_7"}), Error);
  EXPECT_THROW(MarkerDetector({.dictionary = "DICT_4X4_50", .refinement_window = 0}), Error);
  EXPECT_THROW(MarkerDetector({.dictionary = "DICT_4X4_50", .parameters_file = "/nonexistent.yml"}),
               Error);
  const MarkerDetector detector({.dictionary = "dict_apriltag_36H11"});
  EXPECT_THROW(detector.detect(cv::Mat()), Error);
  EXPECT_THROW(detector.detect(cv::Mat(10, 10, CV_16UC1, cv::Scalar(0))), Error);
  // A blank image is a valid input with no markers.
  EXPECT_TRUE(detector.detect(cv::Mat(100, 100, CV_8UC3, cv::Scalar(200, 200, 200))).empty());

  const auto tmp = coloc::testing::temp_dir("markers_bad_params");
  {
    std::ofstream out(tmp / "params.yml");
    out << "%YAML:1.0\nadaptiveThreshConstant: 7\nminMarkerPerimeterRat: 0.05\n";
  }
  try {
    MarkerDetector d({.dictionary = "DICT_4X4_50", .parameters_file = tmp / "params.yml"});
    FAIL() << "unknown key accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "minMarkerPerimeterRat");
  }
  {
    std::ofstream out(tmp / "dict.yml");
    out << "%YAML:1.0\nnmarkers: 2\nmarkersize: 4\nmarker_0: \"1010101010101010\"\n";
  }
  try {
    make_dictionary((tmp / "dict.yml").string());
    FAIL() << "short dictionary accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "marker_1");
  }
}

}  // namespace
}  // namespace coloc::markers
