// kill -9 during saves: a child process saves two different maps in turn over one file; the
// parent kills it at random moments and loads the file each time. The previous map (or the one
// just completed) must load, identical to one of the two, every time.
//
// CI runs a few trials; the full drill: COLOC_MAPDB_KILL_TRIALS=100 ctest -R MapDbKill
// (or run the test binary with that variable).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <random>
#include <thread>

#include "slam/core/error.hpp"
#include "tests/slam/mapdb/map_compare.hpp"
#include "tests/slam/mapdb/mapdb_test_support.hpp"
#include "tests/testing/data.hpp"

namespace coloc::slam::mapdb {
namespace {

namespace fs = std::filesystem;

int trials() {
  const char* env = std::getenv("COLOC_MAPDB_KILL_TRIALS");
  return env ? std::max(1, std::atoi(env)) : 6;
}

// Saves a and b alternately over `path` until killed (never returns).
[[noreturn]] void save_forever(const map::Map& a, const map::Map& b, const fs::path& path) {
  const MapMetadata metadata = test::test_metadata();
  for (std::uint64_t i = 0;; ++i) {
    try {
      save_map(i % 2 ? b : a, metadata, path);
    } catch (...) {
      ::_exit(3);
    }
  }
}

TEST(MapDbKill, PreviousMapLoadsAfterKillNineAtAnyMoment) {
  const map::Map a = test::small_map(21, 60);
  const map::Map b = test::small_map(22, 50);
  const fs::path dir = testing::temp_dir("mapdb_kill");
  const fs::path path = dir / "map.db";
  save_map(a, test::test_metadata(), path);
  // One save's duration sets the range of kill moments: from the first instant to a few saves.
  const auto t0 = std::chrono::steady_clock::now();
  save_map(a, test::test_metadata(), path);
  const auto save_us =
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0)
          .count();
  std::mt19937_64 rng(2024);
  int loaded_a = 0, loaded_b = 0;
  const int n = trials();
  for (int trial = 0; trial < n; ++trial) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) save_forever(a, b, path);
    const auto delay = static_cast<long>(rng() % static_cast<std::uint64_t>(3 * save_us + 1));
    std::this_thread::sleep_for(std::chrono::microseconds(delay));
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the saving child failed on its own, status " << status;
    try {
      const LoadedMap m = load_map(path, test_support::vocabulary());
      const bool is_a = m.map.keyframe_count() == a.keyframe_count();
      EXPECT_EQ(test::map_difference(is_a ? a : b, m.map), "") << "trial " << trial;
      (is_a ? loaded_a : loaded_b)++;
    } catch (const Error& e) {
      ADD_FAILURE() << "trial " << trial << " (kill after " << delay << " us): " << e.what();
    }
  }
  std::printf("kill -9 drill: %d trials, %d loaded (%d as map a, %d as map b), one save %ld us\n",
              n, loaded_a + loaded_b, loaded_a, loaded_b, static_cast<long>(save_us));
  EXPECT_EQ(loaded_a + loaded_b, n);
  // The killed saves left their temporaries; the next save clears those of dead processes.
  save_map(a, test::test_metadata(), path);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << entry.path();
}

}  // namespace
}  // namespace coloc::slam::mapdb
