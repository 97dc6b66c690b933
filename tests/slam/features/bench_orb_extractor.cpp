// Google Benchmark: our ORB extractor against cv::ORB on a 640x480 TUM frame, one thread.
// (`coloc bench orb` prints the same comparison over many TUM and 7-Scenes frames.)

#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "slam/features/orb_extractor.hpp"
#include "tests/testing/data.hpp"

namespace {

namespace fs = std::filesystem;

cv::Mat load_frame() {
  const fs::path dir = coloc::testing::shared_data("tum_fr1_xyz_37f/rgb");
  if (dir.empty()) return {};
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return cv::imread(files.front().string(), cv::IMREAD_GRAYSCALE);
}

void BM_OursOrb1000(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat image = load_frame();
  if (image.empty()) {
    state.SkipWithError("tum_fr1_xyz_37f not found");
    return;
  }
  coloc::slam::features::OrbExtractor extractor;
  for (auto _ : state) {
    auto f = extractor.extract(image);
    benchmark::DoNotOptimize(f);
  }
}
BENCHMARK(BM_OursOrb1000)->Unit(benchmark::kMillisecond);

void BM_OpenCvOrb1000(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat image = load_frame();
  if (image.empty()) {
    state.SkipWithError("tum_fr1_xyz_37f not found");
    return;
  }
  auto orb = cv::ORB::create(1000, 1.2f, 8);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  for (auto _ : state) {
    orb->detectAndCompute(image, cv::noArray(), keypoints, descriptors);
    benchmark::DoNotOptimize(descriptors.data);
  }
}
BENCHMARK(BM_OpenCvOrb1000)->Unit(benchmark::kMillisecond);

}  // namespace
