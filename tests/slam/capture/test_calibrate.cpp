// `coloc calibrate` on real calibration photos of the shared data: the chessboard photos of the
// ViSP Franka set (whose camera's factory intrinsics are stored beside them) and the ChArUco
// photos of OpenCV's tutorial.
#include <gtest/gtest.h>

#include "slam/capture/calibrate.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::capture {
namespace {

namespace fs = std::filesystem;

TEST(CaptureCalibrate, ChessboardPhotosMatchTheFactoryIntrinsics) {
  COLOC_REQUIRE_DATA(dir, "handeye_visp_franka/eye-in-hand");
  std::vector<fs::path> images;
  for (int i = 1; i <= 8; ++i)
    images.push_back(dir / ("franka_image-" + std::to_string(i) + ".png"));
  CalibrateOptions o{.cols = 9, .rows = 6, .square = 0.0236};
  const CameraCalibration c = calibrate_camera(images, o);
  EXPECT_GE(c.used(), 6u);
  EXPECT_LT(c.rms_px, 0.5);
  // franka_camera.xml: px 607.59, py 607.57, u0 323.46, v0 243.26 (RealSense factory values).
  EXPECT_NEAR(c.camera.fx, 607.59, 0.03 * 607.59);
  EXPECT_NEAR(c.camera.fy, 607.57, 0.03 * 607.57);
  EXPECT_NEAR(c.camera.cx, 323.46, 10.0);
  EXPECT_NEAR(c.camera.cy, 243.26, 10.0);
  for (const auto& r : c.images)
    if (r.used) {
      EXPECT_LT(r.rms_px, 1.0) << r.path;
    }
}

TEST(CaptureCalibrate, CharucoPhotosAndImagesWithoutABoard) {
  COLOC_REQUIRE_DATA(dir, "aruco_opencv_tutorial");
  std::vector<fs::path> images = {dir / "img_00.jpg", dir / "img_01.jpg", dir / "img_02.jpg",
                                  dir / "img_03.jpg", dir / "singlemarkersoriginal.jpg"};
  CalibrateOptions o{.target = CalibrateOptions::Target::kCharuco,
                     .cols = 5,
                     .rows = 7,
                     .square = 0.04,
                     .marker = 0.02};
  const CameraCalibration c = calibrate_camera(images, o);
  EXPECT_EQ(c.used(), 4u);
  EXPECT_FALSE(c.images[4].used);
  EXPECT_NE(c.images[4].note.find("no ChArUco board"), std::string::npos);
  EXPECT_LT(c.rms_px, 1.0);
  // tutorial_camera_charuco.yml (OpenCV's own calibration from the same 4 photos): fx 452.5,
  // fy 456.8.
  EXPECT_NEAR(c.camera.fx, 452.5, 0.05 * 452.5);
  EXPECT_NEAR(c.camera.fy, 456.8, 0.05 * 456.8);
  // The same photo twice adds nothing and is named.
  images = {dir / "img_00.jpg", dir / "img_01.jpg", dir / "img_02.jpg", dir / "img_03.jpg",
            dir / "img_00.jpg"};
  const CameraCalibration d = calibrate_camera(images, o);
  EXPECT_NE(d.images[4].note.find("same view as img_00.jpg"), std::string::npos)
      << d.images[4].note;
  EXPECT_THROW(calibrate_camera({dir / "missing.jpg"}, o), Error);
}

}  // namespace
}  // namespace coloc::capture
