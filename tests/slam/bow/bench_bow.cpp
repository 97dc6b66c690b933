// Google Benchmark: vocabulary transform (descriptors -> BoW + direct index) and BoW matching
// of two real TUM frames with the shipped vocabulary.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "slam/bow/matcher.hpp"
#include "slam/bow/vocabulary.hpp"
#include "slam/features/orb_extractor.hpp"
#include "tests/testing/data.hpp"

namespace {

namespace fs = std::filesystem;
using namespace coloc::slam;

struct Setup {
  bow::Vocabulary vocabulary;
  features::OrbFeatures a;
  features::OrbFeatures b;
  bool ok = false;
};

Setup& setup() {
  static Setup s = [] {
    Setup out;
    const fs::path dir = coloc::testing::shared_data("tum_fr1_xyz_37f/rgb");
    const char* env = std::getenv("COLOC_SOURCE_DIR");
    const fs::path source = env != nullptr ? fs::path(env) : fs::path(COLOC_TEST_SOURCE_DIR);
    const fs::path vocabulary = source / "Vocabulary" / "coloc_orb_k10_L5.cvoc";
    if (dir.empty() || !fs::exists(vocabulary)) return out;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir))
      files.push_back(e.path());
    std::sort(files.begin(), files.end());
    features::OrbExtractor extractor;
    out.a = extractor.extract(cv::imread(files[0].string(), cv::IMREAD_GRAYSCALE));
    out.b = extractor.extract(cv::imread(files[10].string(), cv::IMREAD_GRAYSCALE));
    out.vocabulary = bow::Vocabulary::load(vocabulary);
    out.ok = true;
    return out;
  }();
  return s;
}

void BM_Transform(benchmark::State& state) {
  Setup& s = setup();
  if (!s.ok) {
    state.SkipWithError("data or vocabulary missing");
    return;
  }
  bow::BowVector bow;
  bow::FeatureVector direct;
  for (auto _ : state) {
    s.vocabulary.transform(s.a.descriptors, bow, direct);
    benchmark::DoNotOptimize(bow.entries.data());
  }
}
BENCHMARK(BM_Transform)->Unit(benchmark::kMicrosecond);

void BM_MatchByBow(benchmark::State& state) {
  Setup& s = setup();
  if (!s.ok) {
    state.SkipWithError("data or vocabulary missing");
    return;
  }
  bow::BowVector bow;
  bow::FeatureVector da;
  bow::FeatureVector db;
  s.vocabulary.transform(s.a.descriptors, bow, da);
  s.vocabulary.transform(s.b.descriptors, bow, db);
  for (auto _ : state) {
    auto matches = bow::match_by_bow(s.a, da, s.b, db);
    benchmark::DoNotOptimize(matches.data());
  }
}
BENCHMARK(BM_MatchByBow)->Unit(benchmark::kMicrosecond);

}  // namespace
