#include "slam/core/progress.hpp"

#include <unistd.h>

#include <algorithm>

namespace coloc {

Progress::Progress(std::string label, std::uint64_t total, bool quiet, std::FILE* out)
    : label_(std::move(label)),
      total_(total),
      quiet_(quiet),
      tty_(out != nullptr && isatty(fileno(out)) != 0),
      out_(out),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() {
  finish();
}

void Progress::advance(std::uint64_t n) {
  set(done_ + n);
}

void Progress::set(std::uint64_t done) {
  done_ = done;
  draw(false);
}

void Progress::finish() {
  if (finished_) return;
  draw(true);
  finished_ = true;
  if (!quiet_ && tty_) std::fputc('\n', out_);
}

void Progress::draw(bool force) {
  if (quiet_ || finished_ || out_ == nullptr) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double fraction =
      total_ > 0 ? std::min(1.0, static_cast<double>(done_) / static_cast<double>(total_)) : 0.0;
  if (tty_) {
    if (!force && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '.');
    if (total_ > 0) {
      std::fprintf(out_, "\r%s [%s] %3.0f%% %llu/%llu %.1fs", label_.c_str(), bar.c_str(),
                   100.0 * fraction, static_cast<unsigned long long>(done_),
                   static_cast<unsigned long long>(total_), elapsed);
    } else {
      std::fprintf(out_, "\r%s %llu %.1fs", label_.c_str(), static_cast<unsigned long long>(done_),
                   elapsed);
    }
    std::fflush(out_);
    return;
  }
  // Not a terminal: one line per decile (and the final one), so logs stay short.
  const int decile = total_ > 0 ? static_cast<int>(fraction * 10.0) : -1;
  if (total_ > 0 ? decile == last_decile_ : !force) return;
  last_decile_ = decile;
  if (total_ > 0) {
    std::fprintf(out_, "%s: %3.0f%% (%llu/%llu) %.1fs\n", label_.c_str(), 100.0 * fraction,
                 static_cast<unsigned long long>(done_), static_cast<unsigned long long>(total_),
                 elapsed);
  } else {
    std::fprintf(out_, "%s: %llu done %.1fs\n", label_.c_str(),
                 static_cast<unsigned long long>(done_), elapsed);
  }
}

}  // namespace coloc
