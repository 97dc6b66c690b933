#pragma once
// Depth and colour frames paired by timestamp. The streams run free (D4xx depth and colour are
// not hardware-synchronized), so each colour frame takes the depth frame nearest in time,
// within max_dt; a frame that finds no partner is dropped and counted. A colour frame is paired
// once a depth frame at or after its time has arrived (so no closer one can still come).
// Single-threaded; `T` is the payload carried along (frames, indices in tests).
#include <cmath>
#include <deque>
#include <optional>
#include <utility>

namespace coloc::capture {

struct PairingCounters {
  std::size_t pairs = 0;
  std::size_t unpaired_depth = 0;
  std::size_t unpaired_color = 0;
};

template <typename T>
class FramePairer {
 public:
  explicit FramePairer(double max_dt) : max_dt_(max_dt) {}

  void add_depth(double t, T payload) { depth_.emplace_back(t, std::move(payload)); }
  void add_color(double t, T payload) { color_.emplace_back(t, std::move(payload)); }

  // The next pair (depth, colour) with the colour frame's time, if one is decided. `final`:
  // the streams ended, so no closer depth frame can come.
  struct Pair {
    double t_depth, t_color;
    T depth, color;
  };
  std::optional<Pair> next(bool final = false) {
    while (!color_.empty() && !depth_.empty()) {
      const double tc = color_.front().first;
      // Depth frames before the colour frame that a later depth frame is closer to are useless.
      while (depth_.size() >= 2 &&
             std::abs(depth_[1].first - tc) <= std::abs(depth_.front().first - tc)) {
        depth_.pop_front();
        ++counters_.unpaired_depth;
      }
      const double td = depth_.front().first;
      if (std::abs(td - tc) <= max_dt_) {
        if (td < tc && depth_.size() < 2 && !final) return std::nullopt;  // a closer one may come
        Pair p{td, tc, std::move(depth_.front().second), std::move(color_.front().second)};
        depth_.pop_front();
        color_.pop_front();
        ++counters_.pairs;
        return p;
      }
      if (td < tc) {
        if (depth_.size() < 2 && !final) return std::nullopt;
        depth_.pop_front();
        ++counters_.unpaired_depth;
      } else {
        color_.pop_front();  // no depth near this colour frame
        ++counters_.unpaired_color;
      }
    }
    return std::nullopt;
  }

  // The stream whose newest frame is older: the one to read next.
  bool wants_depth() const {
    if (depth_.empty()) return true;
    if (color_.empty()) return false;
    return depth_.back().first <= color_.back().first;
  }

  const PairingCounters& counters() const { return counters_; }

 private:
  double max_dt_;
  std::deque<std::pair<double, T>> depth_, color_;
  PairingCounters counters_;
};

}  // namespace coloc::capture
