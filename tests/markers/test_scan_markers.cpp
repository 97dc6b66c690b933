// Scan markers end to end on a synthetic scan with known marker poses: an E57 (written with our
// e57io writer) holding one spherical panorama station and one station of six pinhole cube
// faces, markers rendered by ray casting. The corners found must match the truth within 2 mm.

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>

#include "e57io/writer.hpp"
#include "markers/dictionary.hpp"
#include "markers/panorama.hpp"
#include "markers/scan_markers.hpp"
#include "markers/synthetic.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::markers {
namespace {

constexpr double kSize = 0.1675;  // the paper's markers
const char* const kDictionary = "DICT_4X4_50";

struct TruthMarker {
  int id;
  SE3 global_from_marker;
};

// A marker on a vertical wall at `centre` whose printed face looks along `normal` (horizontal).
SE3 wall_marker(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d z = normal.normalized();
  const Eigen::Vector3d y = Eigen::Vector3d::UnitZ();
  Eigen::Matrix3d r;
  r.col(0) = y.cross(z);
  r.col(1) = y;
  r.col(2) = z;
  return SE3(SO3::from_matrix(r), centre);
}

e57::Pose to_e57(const SE3& pose) {
  const Eigen::Quaterniond& q = pose.quaternion();
  return {{q.w(), q.x(), q.y(), q.z()},
          {pose.translation().x(), pose.translation().y(), pose.translation().z()}};
}

std::vector<std::uint8_t> encode(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
  return bytes;
}

cv::Mat background(int width, int height, unsigned seed) {
  cv::Mat image(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::NORMAL, 120, 6);
  return image;
}

struct SyntheticScan {
  std::vector<TruthMarker> markers;
  SE3 global_from_a, global_from_b;
};

// Station A (spherical panorama) and station B (six pinhole faces) 1.2 m apart in a room; five
// markers between 1.2 and 2.6 m from the stations, and a sixth 4.5 m away (beyond the 3 m
// range filter) seen by station A only.
SyntheticScan write_scan(const std::filesystem::path& path, int pano_width) {
  SyntheticScan scan;
  scan.global_from_a = SE3(SO3::from_axis_angle(Eigen::Vector3d::UnitZ(), 0.4), {10.0, 5.0, 1.6});
  scan.global_from_b = SE3(SO3::from_axis_angle(Eigen::Vector3d(0.05, 0.02, 1).normalized(), -1.0),
                           {11.0, 5.6, 1.5});
  const Eigen::Vector3d a = scan.global_from_a.translation();
  scan.markers = {
      {3, wall_marker(a + Eigen::Vector3d(2.0, 0.3, -0.2), {-1, 0.1, 0})},
      {7, wall_marker(a + Eigen::Vector3d(1.2, 1.6, 0.3), {-0.3, -1, 0})},
      {11, wall_marker(a + Eigen::Vector3d(-1.5, -0.4, -0.4), {1, 0.2, 0})},
      {19, wall_marker(a + Eigen::Vector3d(0.9, -1.7, 0.5), {-0.2, 1, 0})},
      {23, wall_marker(a + Eigen::Vector3d(2.4, 1.2, 0.1), {-1, -0.4, 0})},
      {42, wall_marker(a + Eigen::Vector3d(-0.5, 4.5, 0.0), {0, -1, 0})},
  };
  const auto dictionary = make_dictionary(kDictionary);
  e57::Writer writer(path);

  const PanoramaModel model = PanoramaModel::equirectangular(pano_width);
  cv::Mat pano = background(model.width, model.height, 1);
  for (const TruthMarker& m : scan.markers) {
    render_marker_panorama(pano, model, scan.global_from_a.inverse() * m.global_from_marker,
                           *dictionary, m.id, kSize);
  }
  e57::Image2D sph;
  sph.name = "station A";
  sph.representation = e57::ImageRepresentation::kSpherical;
  sph.pose = to_e57(scan.global_from_a);
  sph.width = model.width;
  sph.height = model.height;
  sph.pixel_width = model.pixel_width;
  sph.pixel_height = model.pixel_height;
  writer.add_image(sph, encode(pano));

  const int face_size = 2048;
  const PinholeCamera camera = cube_face_camera(face_size);
  const auto rotations = cube_face_rotations();
  for (int f = 0; f < kCubeFaces; ++f) {
    const SE3 global_from_face = scan.global_from_b * SE3(rotations[f], Eigen::Vector3d::Zero());
    cv::Mat face = background(face_size, face_size, 10 + f);
    for (const TruthMarker& m : scan.markers) {
      render_marker(face, camera, global_from_face.inverse() * m.global_from_marker, *dictionary,
                    m.id, kSize);
    }
    e57::Image2D im;
    im.name = std::string("station B face ") + cube_face_name(f);
    im.representation = e57::ImageRepresentation::kPinhole;
    im.pose = to_e57(global_from_face);
    im.width = im.height = face_size;
    im.pixel_width = im.pixel_height = 1e-5;
    im.focal_length = camera.fx * 1e-5;
    im.principal_point_x = camera.cx;
    im.principal_point_y = camera.cy;
    writer.add_image(im, encode(face));
  }
  writer.close();
  return scan;
}

ScanMarkerOptions options_for_test() {
  ScanMarkerOptions o;
  o.detector.dictionary = kDictionary;
  o.pose.marker_size = kSize;
  o.quiet = true;
  return o;
}

TEST(ScanMarkers, RecoversMarkerCornersWithinTwoMillimetres) {
  const auto dir = coloc::testing::temp_dir("markers_scan");
  const SyntheticScan truth = write_scan(dir / "scan.e57", 8192);
  ScanMarkerOptions options = options_for_test();
  options.debug_dir = dir / "debug";
  const ScanMarkersResult result = scan_markers(dir / "scan.e57", options);

  EXPECT_EQ(result.images_searched, 7);  // the panorama and six pinhole faces
  EXPECT_EQ(result.faces_searched, 12);  // 6 cube faces of the panorama + 6 pinhole faces
  EXPECT_EQ(result.map.images.size(), 12u);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir / "debug"),
                          std::filesystem::directory_iterator()),
            12);
  // Marker 42 is 4.5 m away: detected but rejected by the 3 m filter.
  EXPECT_EQ(result.map.markers.count(42), 0u);
  EXPECT_TRUE(std::any_of(result.rejected.begin(), result.rejected.end(), [](const auto& r) {
    return r.id == 42 && r.reason == Rejection::kDistance;
  }));
  double worst = 0.0, sum = 0.0;
  int n = 0, fused = 0;
  for (const TruthMarker& m : truth.markers) {
    if (m.id == 42) continue;
    ASSERT_EQ(result.map.markers.count(m.id), 1u) << "marker " << m.id << " not found";
    const MapMarker& found = result.map.markers.at(m.id);
    if (found.sightings >= 2) ++fused;
    EXPECT_DOUBLE_EQ(found.edge_length, kSize);
    const auto local = marker_corners(kSize);
    for (int c = 0; c < 4; ++c) {
      const double e = (found.corners[c] - m.global_from_marker * local[c]).norm();
      worst = std::max(worst, e);
      sum += e;
      ++n;
    }
    EXPECT_LT(found.residual, 0.003);
  }
  std::printf("synthetic scan: %d corners, error mean %.2f mm, max %.2f mm\n", n, 1e3 * sum / n,
              1e3 * worst);
  EXPECT_LT(worst, 0.002);
  EXPECT_GE(fused, 3);  // markers seen from both stations

  // The map file round trip keeps what registration needs.
  write_marker_map(dir / "markers.yaml", result.map);
  const MarkerMap back = read_marker_map(dir / "markers.yaml");
  EXPECT_EQ(back.markers.size(), result.map.markers.size());
  EXPECT_EQ(back.source, (dir / "scan.e57").string());
}

TEST(ScanMarkers, FiltersRejectWithTheirReason) {
  const auto dictionary = make_dictionary(kDictionary);
  const PinholeCamera camera = cube_face_camera(1024);
  cv::Mat image = background(1024, 1024, 3);
  // 1.5 m in front of the camera, turned 35 degrees (an oblique view: not ambiguous).
  const SE3 face_from_marker(SO3::from_axis_angle(Eigen::Vector3d::UnitX(), M_PI) *
                                 SO3::from_axis_angle(Eigen::Vector3d::UnitY(), 0.6),
                             Eigen::Vector3d(0.1, 0.0, 1.5));
  render_marker(image, camera, face_from_marker, *dictionary, 4, kSize);
  const SE3 global_from_image(SO3(), Eigen::Vector3d(1, 2, 3));
  const MarkerDetector detector({.dictionary = kDictionary});
  ScanMarkerOptions options = options_for_test();

  ImageSightings ok = sightings_in_image(image, camera, global_from_image, "f", detector, options);
  ASSERT_EQ(ok.sightings.size(), 1u);
  EXPECT_LT((ok.sightings[0].corners[0] -
             (global_from_image * face_from_marker * marker_corners(kSize)[0]))
                .norm(),
            0.003);
  options.max_distance = 1.0;
  ImageSightings far = sightings_in_image(image, camera, global_from_image, "f", detector, options);
  ASSERT_EQ(far.rejected.size(), 1u);
  EXPECT_EQ(far.rejected[0].reason, Rejection::kDistance);
  EXPECT_NEAR(far.rejected[0].distance, std::hypot(0.1, 1.5), 0.01);
  options = options_for_test();
  options.max_reprojection_error_px = 1e-4;
  ImageSightings strict =
      sightings_in_image(image, camera, global_from_image, "f", detector, options);
  ASSERT_EQ(strict.rejected.size(), 1u);
  EXPECT_EQ(strict.rejected[0].reason, Rejection::kReprojection);
  // The same id twice in one image: both rejected.
  render_marker(image, camera, SE3(face_from_marker.so3(), Eigen::Vector3d(-0.4, 0.2, 1.5)),
                *dictionary, 4, kSize);
  ImageSightings twice =
      sightings_in_image(image, camera, global_from_image, "f", detector, options_for_test());
  EXPECT_TRUE(twice.sightings.empty());
  ASSERT_EQ(twice.rejected.size(), 2u);
  EXPECT_EQ(twice.rejected[0].reason, Rejection::kDuplicateId);
}

TEST(ScanMarkers, ScanWithoutPosedImagesIsAClearError) {
  const auto dir = coloc::testing::temp_dir("markers_scan_noposes");
  {
    e57::Writer writer(dir / "unposed.e57");
    e57::Image2D im;
    im.name = "no pose";
    im.representation = e57::ImageRepresentation::kPinhole;
    im.width = im.height = 64;
    im.pixel_width = im.pixel_height = 1e-5;
    im.focal_length = 32e-5;
    im.principal_point_x = im.principal_point_y = 31.5;
    writer.add_image(im, encode(background(64, 64, 1)));
    writer.close();
  }
  try {
    scan_markers(dir / "unposed.e57", options_for_test());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().file, (dir / "unposed.e57").string());
    EXPECT_NE(std::string(e.what()).find("no image with a pose"), std::string::npos) << e.what();
  }
  EXPECT_THROW(scan_markers(dir / "missing.e57", options_for_test()), Error);
}

TEST(ScanMarkers, ScanWithoutMarkersGivesAnEmptyMapNotAnError) {
  const auto dir = coloc::testing::temp_dir("markers_scan_empty");
  {
    e57::Writer writer(dir / "empty.e57");
    const PinholeCamera camera = cube_face_camera(256);
    e57::Image2D im;
    im.name = "blank";
    im.representation = e57::ImageRepresentation::kPinhole;
    im.pose = to_e57(SE3());
    im.width = im.height = 256;
    im.pixel_width = im.pixel_height = 1e-5;
    im.focal_length = camera.fx * 1e-5;
    im.principal_point_x = im.principal_point_y = camera.cx;
    writer.add_image(im, encode(background(256, 256, 2)));
    writer.close();
  }
  const ScanMarkersResult result = scan_markers(dir / "empty.e57", options_for_test());
  EXPECT_EQ(result.images_searched, 1);
  EXPECT_TRUE(result.map.markers.empty());
}

TEST(ScanMarkers, RealScanImagesWithoutMarkers) {
  COLOC_REQUIRE_DATA(file, "e57/cry-inc-e57/tiny_pc_and_images.e57");
  const ScanMarkersResult result = scan_markers(file, options_for_test());
  EXPECT_GE(result.images_searched, 1);
  EXPECT_TRUE(result.map.markers.empty());
}

}  // namespace
}  // namespace coloc::markers
