#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "e57io/reader.hpp"
#include "registration/twin/generator.hpp"
#include "registration/twin/image_writer.hpp"
#include "slam/core/error.hpp"
#include "slam/core/trajectory.hpp"
#include "slam/dataset/sequence.hpp"
#include "slam/eval/trajectory_error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::registration::twin {
namespace {

namespace fs = std::filesystem;

// A small, fast twin: room preset, 1 s of 320x240 frames, small textures and cube faces.
GenerateOptions small_options() {
  GenerateOptions o = preset_options(Preset::kRoom);
  o.seed = 42;
  o.camera = GenerateOptions::default_camera(320, 240);
  o.max_duration = 1.0;
  o.texture_size = 256;
  o.scan.face_size = 96;
  o.scan.point_step = 4;
  o.quiet = true;
  return o;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> data_lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] != '#') out.push_back(line);
  }
  return out;
}

class TwinGenerator : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_a_ = new fs::path(coloc::testing::temp_dir("twin_gen_a"));
    dir_b_ = new fs::path(coloc::testing::temp_dir("twin_gen_b"));
    summary_ = new GenerateSummary(generate_twin(small_options(), *dir_a_));
    generate_twin(small_options(), *dir_b_);
  }
  static void TearDownTestSuite() {
    delete dir_a_;
    delete dir_b_;
    delete summary_;
  }
  static fs::path* dir_a_;
  static fs::path* dir_b_;
  static GenerateSummary* summary_;
};
fs::path* TwinGenerator::dir_a_ = nullptr;
fs::path* TwinGenerator::dir_b_ = nullptr;
GenerateSummary* TwinGenerator::summary_ = nullptr;

TEST_F(TwinGenerator, TumLayoutIsCompleteAndReadable) {
  const fs::path seq = *dir_a_ / "sequence";
  const GenerateSummary& s = *summary_;
  EXPECT_EQ(s.frames, 31u);  // 1 s at 30 Hz, both ends included
  const auto rgb = data_lines(seq / "rgb.txt");
  const auto depth = data_lines(seq / "depth.txt");
  const auto assoc = data_lines(seq / "associations.txt");
  ASSERT_EQ(rgb.size(), s.frames);
  ASSERT_EQ(depth.size(), s.frames);
  ASSERT_EQ(assoc.size(), s.frames);
  for (std::size_t i = 0; i < s.frames; i += 10) {
    std::istringstream l(rgb[i]), d(depth[i]);
    double t = 0, td = 0;
    std::string f, fd;
    l >> t >> f;
    d >> td >> fd;
    EXPECT_DOUBLE_EQ(t, td);
    const cv::Mat img = cv::imread((seq / f).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat dep = cv::imread((seq / fd).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(img.type(), CV_8UC3);
    ASSERT_EQ(dep.type(), CV_16U);
    EXPECT_EQ(img.cols, 320);
    EXPECT_EQ(dep.rows, 240);
    EXPECT_GT(cv::countNonZero(dep), static_cast<int>(dep.total() * 8 / 10));
  }
  const Trajectory gt = read_tum_trajectory(seq / "groundtruth.txt");
  ASSERT_EQ(gt.size(), s.frames);
  EXPECT_NEAR(gt[1].timestamp - gt[0].timestamp, 1.0 / 30, 1e-6);
  // The ground truth gives zero error against itself, and matches the frame stamps.
  const auto pairs = associate_by_time(gt, gt, 0.001);
  EXPECT_EQ(pairs.size(), gt.size());
  EXPECT_GE(data_lines(seq / "imu.txt").size(), 195u);
  EXPECT_EQ(data_lines(seq / "imu.txt").size(), s.imu_samples);
  EXPECT_EQ(read_tum_trajectory(*dir_a_ / "headset" / "headset.txt").size(), s.headset_poses);
  EXPECT_EQ(s.headset_poses, 91u);
  const std::string settings = slurp(seq / "camera.yaml");
  EXPECT_NE(settings.find("Camera1.fx:"), std::string::npos);
  EXPECT_NE(settings.find("RGBD.DepthMapFactor: 1000.0"), std::string::npos);
  EXPECT_NE(settings.find("IMU.T_b_c1"), std::string::npos);
  // SLAM looks for the twin's markers (OpenCV's numeric id, as the twin's files write it).
  EXPECT_NE(settings.find("Markers.dictionary: \"0\"\nMarkers.size: 0.1675"), std::string::npos);
  EXPECT_EQ(data_lines(*dir_a_ / "groundtruth" / "markers.txt").size(), s.markers);
}

TEST_F(TwinGenerator, FoundationReadersLoadTheSequence) {
  dataset::SequenceOptions so;
  so.depth_scale = 1000.0;  // the twin writes millimetres, as the RealSense does
  const auto seq = dataset::open_tum(*dir_a_ / "sequence", so);
  ASSERT_EQ(seq->size(), summary_->frames);
  const dataset::Frame f = seq->frame(5);
  EXPECT_EQ(f.color.cols, 320);
  ASSERT_EQ(f.depth.type(), CV_32FC1);
  double lo = 0, hi = 0;
  cv::minMaxLoc(f.depth, &lo, &hi);
  EXPECT_GT(hi, 0.4);
  EXPECT_LT(hi, 6.1);  // the D455 model's range limit
  ASSERT_EQ(seq->ground_truth().size(), summary_->frames);
  // The first second starts at rest (nearly collinear positions): compare without alignment.
  eval::AteOptions ao;
  ao.alignment = eval::Alignment::kNone;
  const eval::AteResult ate = eval::compute_ate(seq->ground_truth(), seq->ground_truth(), ao);
  EXPECT_LT(ate.translation.rmse, 1e-9);
}

TEST_F(TwinGenerator, SameSeedGivesByteIdenticalOutput) {
  std::size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(*dir_a_)) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), *dir_a_);
    ASSERT_TRUE(fs::exists(*dir_b_ / rel)) << rel;
    EXPECT_TRUE(slurp(entry.path()) == slurp(*dir_b_ / rel)) << rel << " differs";
    ++files;
  }
  EXPECT_GT(files, 60u);
}

TEST_F(TwinGenerator, ScanFilesHoldStationsPointsAndFaces) {
  const GenerateSummary& s = *summary_;
  EXPECT_EQ(s.stations, 2u);
  // 6 faces of 96^2 sampled every 4 pixels: all directions hit the closed room.
  EXPECT_EQ(s.scan_points, 2u * 6u * 24u * 24u);
  const std::string ply = slurp(*dir_a_ / "scan" / "scan.ply");
  // The count as PlyWriter writes it (zero-padded, patched in place when the stream ends), and
  // 15 bytes a vertex (float xyz, uchar rgb) after the header.
  const std::size_t count_at = ply.find("element vertex ");
  ASSERT_NE(count_at, std::string::npos);
  EXPECT_EQ(std::stoull(ply.substr(count_at + 15, 20)), s.scan_points);
  const std::size_t body = ply.find("end_header\n") + 11;
  EXPECT_EQ(ply.size() - body, 15u * s.scan_points);
  const auto stations = data_lines(*dir_a_ / "scan" / "stations.txt");
  ASSERT_EQ(stations.size(), 2u);
  EXPECT_EQ(data_lines(*dir_a_ / "scan" / "faces.txt").size(), 12u);
  const e57::Reader reader(*dir_a_ / "scan" / "scan.e57");
  ASSERT_EQ(reader.scans().size(), 2u);
  ASSERT_EQ(reader.images().size(), 12u);
  std::uint64_t points = 0;
  for (const auto& scan : reader.scans())
    points += scan.point_count;
  EXPECT_EQ(points, s.scan_points);
  std::istringstream l(stations[1]);
  int index = 0;
  double tx = 0, ty = 0, tz = 0;
  l >> index >> tx >> ty >> tz;
  ASSERT_TRUE(reader.scans()[1].pose.has_value());
  EXPECT_NEAR(reader.scans()[1].pose->translation.x, tx, 1e-9);
  EXPECT_NEAR(reader.scans()[1].pose->translation.z, tz, 1e-9);
  const auto& im = reader.images()[7];
  EXPECT_EQ(im.width, 96);
  EXPECT_NEAR(im.focal_length / im.pixel_width, 48.0, 1e-9);
  const std::vector<std::uint8_t> jpeg = reader.read_image(7);
  const cv::Mat face = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  EXPECT_EQ(face.cols, 96);
}

TEST(TwinImageWriter, WritesInOrderAndReportsFailures) {
  const fs::path dir = coloc::testing::temp_dir("twin_png");
  {
    AsyncPngWriter w(2);
    for (int i = 0; i < 6; ++i) {
      w.write(dir / (std::to_string(i) + ".png"), cv::Mat(8, 8, CV_8UC3, cv::Scalar(i, 0, 0)));
    }
    w.close();
  }
  for (int i = 0; i < 6; ++i) {
    const cv::Mat m = cv::imread((dir / (std::to_string(i) + ".png")).string());
    ASSERT_FALSE(m.empty()) << i;
    EXPECT_EQ(m.at<cv::Vec3b>(0, 0)[0], i);
  }
  AsyncPngWriter bad;
  bad.write(dir / "missing" / "x.png", cv::Mat(8, 8, CV_8UC1, cv::Scalar(1)));
  EXPECT_THROW(bad.close(), Error);
}

TEST(TwinGeneratorOptions, RejectsBadOptions) {
  GenerateOptions o = small_options();
  o.fps = 0;
  EXPECT_THROW(o.check(), Error);
  o = small_options();
  o.scan.point_step = 0;
  EXPECT_THROW(o.check(), Error);
  EXPECT_THROW(parse_preset("castle"), Error);
}

}  // namespace
}  // namespace coloc::registration::twin
