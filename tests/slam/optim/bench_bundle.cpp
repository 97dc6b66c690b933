// Google Benchmark: one local BA (robust pass, outliers removed, refinement) on a window of the
// median shape of fr1/rpy's local BAs (11 free + 6 fixed keyframes, about 1,900 points and 5,900
// observations), our dense-Schur LM against Ceres' DENSE_SCHUR, with and without the
// rolling-shutter readout as an unknown.
#include <benchmark/benchmark.h>

#include "slam/optim/bundle_adjustment.hpp"
#include "tests/slam/optim/bundle_window.hpp"

namespace {

using coloc::slam::optim::BundleOptions;
using coloc::slam::optim::BundleProblem;

void local_ba(benchmark::State& state) {
  coloc::slam::optim::Window w = coloc::slam::optim::make_window(
      {.poses = 17, .fixed = 6, .points = 1935, .seen = 0.18, .seed = 5});
  w.problem.readout.estimate = state.range(1) == 1;
  BundleOptions options;
  options.own_dense_solver = state.range(0) == 1;
  for (auto _ : state) {
    state.PauseTiming();
    BundleProblem problem = w.problem;
    state.ResumeTiming();
    benchmark::DoNotOptimize(bundle_adjust(problem, coloc::slam::optim::kTestK, options));
  }
  state.counters["observations"] = static_cast<double>(w.problem.observations.size());
}
BENCHMARK(local_ba)
    ->ArgsProduct({{1, 0}, {0, 1}})
    ->ArgNames({"ours", "readout"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
