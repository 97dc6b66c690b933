// Localization speed by stage on the test map (localize_fixture.hpp: a twin room walk, 640x480,
// mapped and saved): a whole localize() call per tracked frame with its stages as counters
// (extraction, initial pose, local map; milliseconds per frame), and a cold-start
// relocalization (fresh tracker, a frame anywhere in the map). Frames are decoded beforehand.
//
//   build/tests/slam/localize/bench_localize [--benchmark_repetitions=3]
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "slam/localize/localizer.hpp"
#include "tests/slam/localize/localize_fixture.hpp"

namespace coloc::slam::localize {
namespace {

struct BenchData {
  std::unique_ptr<LocalizationMap> map;
  settings::Settings settings;
  std::vector<dataset::Frame> frames;
};

const BenchData& data() {
  static const BenchData d = [] {
    BenchData out;
    const auto& f = test::fixture();
    out.map = load_localization_map(f.map, test_support::vocabulary());
    out.settings = settings::load_settings(f.sequence / "camera.yaml");
    dataset::SequenceOptions so;
    so.depth_scale = out.settings.depth->depth_map_factor;
    const auto sequence = dataset::open_sequence(f.sequence, so);
    for (std::size_t i = 0; i < sequence->size(); ++i)
      out.frames.push_back(sequence->frame(i));
    return out;
  }();
  return d;
}

void BM_LocalizeTrackedFrame(benchmark::State& state) {
  const BenchData& d = data();
  Localizer l(*d.map, test_support::vocabulary(), d.settings, options_from_settings(d.settings));
  std::size_t i = 0;
  double extract = 0, pose = 0, local_map = 0;
  std::int64_t lost = 0;
  for (auto _ : state) {
    if (i == d.frames.size()) {  // the walk again: relocalize its first frame untimed
      state.PauseTiming();
      l.reset();
      l.localize(d.frames[0].color, d.frames[0].depth, d.frames[0].timestamp);
      i = 1;
      state.ResumeTiming();
    }
    const auto& f = d.frames[i++];
    const LocalizationResult r = l.localize(f.color, f.depth, f.timestamp);
    extract += r.extract_ms;
    pose += r.pose_ms;
    local_map += r.local_map_ms;
    lost += r.state == LocalizationState::kLost ? 1 : 0;
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["extract_ms"] = extract / n;
  state.counters["pose_ms"] = pose / n;
  state.counters["local_map_ms"] = local_map / n;
  state.counters["lost"] = static_cast<double>(lost);
}
BENCHMARK(BM_LocalizeTrackedFrame)->Unit(benchmark::kMillisecond)->MinTime(3.0);

void BM_ColdStartRelocalization(benchmark::State& state) {
  const BenchData& d = data();
  Localizer l(*d.map, test_support::vocabulary(), d.settings, options_from_settings(d.settings));
  std::mt19937_64 rng(1);
  std::uniform_int_distribution<std::size_t> pick(0, d.frames.size() - 1);
  std::int64_t ok = 0;
  for (auto _ : state) {
    state.PauseTiming();
    l.reset();
    const auto& f = d.frames[pick(rng)];
    state.ResumeTiming();
    ok += l.localize(f.color, f.depth, f.timestamp).state != LocalizationState::kLost ? 1 : 0;
  }
  state.counters["success_rate"] =
      static_cast<double>(ok) / static_cast<double>(std::max<std::int64_t>(state.iterations(), 1));
}
BENCHMARK(BM_ColdStartRelocalization)->Unit(benchmark::kMillisecond)->Iterations(50);

}  // namespace
}  // namespace coloc::slam::localize
