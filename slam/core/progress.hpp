#pragma once
// Progress reporting for long work (vocabulary training, BA, E57 reading), always on stderr
// (never stdout, which belongs to results and --json). On a terminal it redraws one bar line at
// most ten times a second; when stderr is a file or pipe it writes a plain line every 10 %.
// Not thread-safe: one owner advances it.

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace coloc {

class Progress {
 public:
  // total == 0 means unknown: the count is shown without a percentage. quiet == true shows
  // nothing (for --json runs and tests).
  Progress(std::string label, std::uint64_t total, bool quiet = false, std::FILE* out = stderr);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::uint64_t n = 1);
  void set(std::uint64_t done);
  // Draws the final state and a newline; further calls do nothing.
  void finish();

  std::uint64_t done() const { return done_; }

 private:
  void draw(bool force);

  std::string label_;
  std::uint64_t total_;
  std::uint64_t done_ = 0;
  bool quiet_;
  bool tty_;
  bool finished_ = false;
  int last_decile_ = -1;
  std::FILE* out_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace coloc
