// Speed of the hand-eye solvers for 10 registrations (DESIGN.md section 5: < 1 ms).
// Run: build-<dir>/tests/registration/handeye/bench_handeye

#include <benchmark/benchmark.h>

#include "registration/handeye/handeye.hpp"
#include "registration/handeye/opencv/compare.hpp"
#include "registration/handeye/simulate.hpp"

namespace coloc::registration::handeye {
namespace {

Simulation session(int registrations, double outliers = 0.0) {
  SimulationOptions o;
  o.seed = 42;
  o.num_registrations = registrations;
  o.outlier_fraction = outliers;
  return simulate(o);
}

void BM_LinearOnly(benchmark::State& state) {
  const Simulation sim = session(static_cast<int>(state.range(0)));
  Options options;
  options.refine = false;
  options.estimate_covariance = false;
  for (auto _ : state)
    benchmark::DoNotOptimize(solve(sim.registrations, options));
}
BENCHMARK(BM_LinearOnly)->Arg(10)->Arg(30)->Unit(benchmark::kMicrosecond);

void BM_Default(benchmark::State& state) {  // linear + refinement + noise estimation + covariance
  const Simulation sim = session(static_cast<int>(state.range(0)));
  for (auto _ : state)
    benchmark::DoNotOptimize(solve(sim.registrations));
}
BENCHMARK(BM_Default)->Arg(10)->Arg(30)->Unit(benchmark::kMicrosecond);

void BM_RefineNoCovariance(benchmark::State& state) {
  const Simulation sim = session(10);
  Options options;
  options.estimate_covariance = false;
  for (auto _ : state)
    benchmark::DoNotOptimize(solve(sim.registrations, options));
}
BENCHMARK(BM_RefineNoCovariance)->Unit(benchmark::kMicrosecond);

void BM_Robust(benchmark::State& state) {
  const Simulation sim = session(static_cast<int>(state.range(0)), 0.1);
  Options options;
  options.robust = true;
  for (auto _ : state)
    benchmark::DoNotOptimize(solve(sim.registrations, options));
}
BENCHMARK(BM_Robust)->Arg(10)->Arg(30)->Unit(benchmark::kMicrosecond);

void BM_OpencvPark(benchmark::State& state) {
  const Simulation sim = session(10);
  for (auto _ : state) {
    benchmark::DoNotOptimize(opencv_hand_eye(sim.registrations, cv::CALIB_HAND_EYE_PARK));
  }
}
BENCHMARK(BM_OpencvPark)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace coloc::registration::handeye
