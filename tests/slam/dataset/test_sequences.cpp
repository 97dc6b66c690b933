#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/core.hpp>

#include "slam/core/error.hpp"
#include "slam/dataset/image_folder.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/dataset/slice.hpp"
#include "tests/testing/data.hpp"

namespace coloc::dataset {
namespace {

TEST(TumSequence, AssociatesRgbAndDepthWithin20ms) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_xyz_37f");
  const auto seq = open_sequence(dir);
  EXPECT_EQ(seq->format(), "tum");
  EXPECT_EQ(seq->folder(), dir);  // what errors about the sequence name
  // 37 colour and 37 depth images; 36 pairs lie within 20 ms (colour 31 is 20.2 ms from its
  // depth image). The greedy nearest-first pairing of associate.py would keep only 32.
  ASSERT_EQ(seq->size(), 36u);
  const Frame f = seq->frame(0);
  EXPECT_DOUBLE_EQ(f.timestamp, 1305031102.175304);
  EXPECT_EQ(f.depth_path.filename(), "1305031102.160407.png");
  ASSERT_EQ(f.color.type(), CV_8UC3);
  ASSERT_EQ(f.depth.type(), CV_32FC1);
  EXPECT_EQ(f.color.size(), cv::Size(640, 480));
  // Depth is in metres (5000 units per metre): the fr1/xyz desk is 0.5-3 m away.
  double lo = 0.0;
  double hi = 0.0;
  cv::minMaxLoc(f.depth, &lo, &hi, nullptr, nullptr, f.depth > 0);
  EXPECT_GT(lo, 0.3);
  EXPECT_LT(hi, 6.0);
  EXPECT_GT(cv::countNonZero(f.depth), 200000);
  EXPECT_GT(seq->ground_truth().size(), 100u);
  for (std::size_t i = 1; i < seq->size(); ++i)
    EXPECT_GT(seq->timestamp(i), seq->timestamp(i - 1));
}

TEST(TumSequence, ReadsAssociationsFile) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_rpy_180f");
  const auto seq = open_sequence(dir);
  ASSERT_EQ(seq->size(), 180u);
  EXPECT_DOUBLE_EQ(seq->timestamp(0), 1305031229.528748);
  const Frame last = seq->frame(179);
  EXPECT_FALSE(last.color.empty());
  EXPECT_FALSE(last.depth.empty());
  EXPECT_FALSE(seq->ground_truth().empty());
}

// Lists naming every frame twice were mapped as two frames per timestamp (a trajectory eval
// refuses): a repeated timestamp is refused, both lines named.
TEST(TumSequence, RepeatedTimestampsAreRefusedNamingTheLines) {
  const auto dir = coloc::testing::temp_dir("tum_repeated");
  std::ofstream(dir / "rgb.txt") << "# rgb\n1.0 rgb/a.png\n2.0 rgb/b.png\n1.0 rgb/a.png\n";
  std::ofstream(dir / "depth.txt") << "1.0 depth/a.png\n2.0 depth/b.png\n";
  try {
    open_sequence(dir);
    FAIL() << "a repeated timestamp was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, (dir / "rgb.txt").string());
    EXPECT_EQ(e.context().line, 4);
    EXPECT_NE(e.message().find("lines 2 and 4"), std::string::npos) << e.what();
  }
  std::filesystem::remove(dir / "rgb.txt");
  std::ofstream(dir / "associations.txt") << "1.0 rgb/a.png 1.0 depth/a.png\n"
                                             "1.0 rgb/a.png 1.0 depth/a.png\n";
  try {
    open_sequence(dir);
    FAIL() << "a repeated association was accepted";
  } catch (const Error& e) {
    EXPECT_NE(e.message().find("lines 1 and 2"), std::string::npos) << e.what();
  }
}

// coloc map --frames A:B: the slice reads the whole sequence's frames A..B-1, nothing else.
TEST(SequenceSlice, ReadsTheRangeOnly) {
  COLOC_REQUIRE_DATA(dir, "tum_fr1_rpy_180f");
  const auto whole = open_sequence(dir);
  const double t10 = whole->timestamp(10), t19 = whole->timestamp(19);
  const auto part = slice(open_sequence(dir), 10, 20);
  EXPECT_EQ(part->size(), 10u);
  EXPECT_DOUBLE_EQ(part->timestamp(0), t10);
  EXPECT_DOUBLE_EQ(part->frame(9).timestamp, t19);
  EXPECT_EQ(part->ground_truth().size(), whole->ground_truth().size());
  EXPECT_EQ(slice(open_sequence(dir), 170, 1000)->size(), 10u);  // clamped to the end
  EXPECT_THROW(slice(open_sequence(dir), 180, 200), Error);      // empty
  EXPECT_EQ(parse_frame_range("10:20", "--frames"),
            std::make_pair(std::size_t{10}, std::size_t{20}));
  EXPECT_EQ(parse_frame_range(":5", "--frames").first, 0u);
  EXPECT_EQ(parse_frame_range("7:", "--frames").second, std::numeric_limits<std::size_t>::max());
  for (const char* bad : {"10", "a:3", "-1:4", "3:x", "1.5:4"}) {
    try {
      parse_frame_range(bad, "--frames");
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--frames"), std::string::npos) << e.what();
    }
  }
}

TEST(SevenScenesSequence, ReadsFramesPosesAndInvalidDepth) {
  COLOC_REQUIRE_DATA(dir, "sevenscenes_600f");
  const auto seq = open_sequence(dir);
  EXPECT_EQ(seq->format(), "7scenes");
  ASSERT_EQ(seq->size(), 600u);
  ASSERT_EQ(seq->ground_truth().size(), 600u);
  // frame-000000.pose.txt, first row: 0.9093129 0.27262229 -0.31422433 -0.34045634
  const SE3& p0 = seq->ground_truth()[0].world_from_cam;
  // KinectFusion's rotations are not exactly orthonormal; we project them onto SO(3).
  EXPECT_NEAR(p0.rotation()(0, 0), 0.9093129, 1e-4);
  EXPECT_NEAR(p0.translation().x(), -0.34045634, 1e-8);
  EXPECT_NEAR(seq->timestamp(30), 1.0, 1e-12);
  const Frame f = seq->frame(10);
  double hi = 0.0;
  cv::minMaxLoc(f.depth, nullptr, &hi);
  EXPECT_LT(hi, 10.0);  // 65535 (invalid) became 0, not 65.5 m
  ASSERT_TRUE(seq->camera().has_value());
  EXPECT_DOUBLE_EQ(intrinsic_matrix(*seq->camera())(0, 0), 585.0);
  EXPECT_THROW(seq->frame(600), Error);
}

TEST(EurocSequence, StereoImuGroundTruthAndIntrinsics) {
  COLOC_REQUIRE_DATA(dir, "euroc_v101_30f");
  const auto seq = open_sequence(dir);
  EXPECT_EQ(seq->format(), "euroc");
  ASSERT_EQ(seq->size(), 30u);
  const Frame f = seq->frame(0);
  EXPECT_EQ(f.color.type(), CV_8UC1);
  EXPECT_EQ(f.color.size(), cv::Size(752, 480));
  EXPECT_FALSE(f.right.empty());
  EXPECT_TRUE(f.depth.empty());
  // ~145 s of IMU at 200 Hz; accelerometer norm near gravity at rest.
  ASSERT_GT(seq->imu().size(), 25000u);
  EXPECT_NEAR(seq->imu().front().accel.norm(), 9.81, 0.5);
  const auto between = seq->imu_between(seq->timestamp(0), seq->timestamp(1));
  EXPECT_GE(between.size(), 9u);  // 50 ms at 200 Hz
  EXPECT_LE(between.size(), 11u);
  ASSERT_FALSE(seq->ground_truth().empty());
  const SE3& world_from_cam = seq->ground_truth().front().world_from_cam;
  EXPECT_NEAR(world_from_cam.translation().x(), 0.8687393558, 1e-9);
  // Vicon's world z is up: the camera's y axis (image down) points down, its optical axis is
  // near horizontal.
  EXPECT_LT(world_from_cam.rotation().col(1).z(), -0.8);
  EXPECT_LT(std::abs(world_from_cam.rotation().col(2).z()), 0.5);
  ASSERT_TRUE(seq->camera().has_value());
  EXPECT_DOUBLE_EQ(intrinsic_matrix(*seq->camera())(0, 0), 458.654);
}

TEST(Sequence, ErrorsNameTheFile) {
  const auto dir = testing::temp_dir("bad_tum");
  std::ofstream(dir / "rgb.txt") << "# header\n1.0 rgb/missing.png\n";
  std::ofstream(dir / "depth.txt") << "1.001 depth/missing.png\n";
  const auto seq = open_sequence(dir);
  ASSERT_EQ(seq->size(), 1u);
  try {
    seq->frame(0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(e.context().file.find("missing.png"), std::string::npos);
  }
  std::ofstream(dir / "depth.txt") << "oops depth/missing.png\n";
  try {
    open_sequence(dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 1);
    EXPECT_NE(e.context().file.find("depth.txt"), std::string::npos);
  }
  EXPECT_THROW(open_sequence(dir / "nothing"), Error);
  std::ofstream(dir / "depth.txt") << "1.001 depth/missing.png\n";
  std::ofstream(dir / "imu.txt") << "# t gx gy gz ax ay az\n0.995 0.1 0.2 0.3 0 0 9.81\n"
                                 << "0.990 0 0 0 0 0 9.8\n1.0 0 0 x 0 0 9.8\n";
  try {
    open_sequence(dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().line, 4);  // the bad IMU row is named
  }
  std::ofstream(dir / "imu.txt") << "0.995 0.1 0.2 0.3 0 0 9.81\n0.990 0 0 0 0 0 9.8\n";
  const auto with_imu = open_sequence(dir);
  ASSERT_EQ(with_imu->imu().size(), 2u);
  EXPECT_DOUBLE_EQ(with_imu->imu()[0].timestamp, 0.990);  // sorted by time
  EXPECT_DOUBLE_EQ(with_imu->imu()[1].gyro.y(), 0.2);
  EXPECT_THROW(open_sequence(testing::temp_dir("empty_seq")), Error);
}

// Training images: colour and grey images at any depth of the tree, depth images left out by
// their folder or file name below the given folder (not by the folder's own name).
TEST(ImageFolder, FindsColourImagesAndSkipsDepth) {
  const auto dir = testing::temp_dir("depth_named_root");
  std::filesystem::create_directories(dir / "rgb");
  std::filesystem::create_directories(dir / "depth");
  for (const char* name :
       {"rgb/b.png", "a.JPG", "rgb/c.jpeg", "depth/d.png", "frame.depth.png", "notes.txt"})
    std::ofstream(dir / name) << "x";
  const auto images = find_colour_images(dir);
  ASSERT_EQ(images.size(), 3u);
  EXPECT_EQ(images[0], dir / "a.JPG");  // sorted by path
  EXPECT_EQ(images[1], dir / "rgb/b.png");
  EXPECT_EQ(images[2], dir / "rgb/c.jpeg");
  const auto second = every_nth(images, 2);
  ASSERT_EQ(second.size(), 2u);
  EXPECT_EQ(second[1], images[2]);
  EXPECT_EQ(every_nth(images, 0).size(), 3u);
  EXPECT_THROW(find_colour_images(dir / "missing"), Error);
}

}  // namespace
}  // namespace coloc::dataset
