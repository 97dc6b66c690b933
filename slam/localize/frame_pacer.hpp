#pragma once
// Replays a recorded sequence as a live camera would deliver it: frame i arrives at
// timestamps[i] - timestamps[0] seconds after the start. A live localizer works on the newest
// frame that has arrived; frames that arrived while it was busy are dropped (never queued, so
// the pose never lags) and counted. Pure bookkeeping on a clock the caller reads (testable
// without waiting); the caller sleeps for `wait_s`.
//
// Not thread-safe (one replay loop).
#include <cstddef>
#include <optional>
#include <vector>

namespace coloc::slam::localize {

struct PacedFrame {
  std::size_t index = 0;    // the frame to process now
  double wait_s = 0.0;      // sleep this long first (it has not arrived yet); 0 when it has
  std::size_t dropped = 0;  // frames skipped to get to it (arrived, never processed)
};

class FramePacer {
 public:
  // `timestamps`: seconds, non-decreasing (coloc::Error otherwise, naming the frame).
  explicit FramePacer(std::vector<double> timestamps);

  // `elapsed_s`: wall-clock seconds since the replay started. The next frame: the newest that
  // has arrived and was not processed yet, or else the next one with the time until it arrives;
  // std::nullopt when every frame is processed or dropped.
  std::optional<PacedFrame> next(double elapsed_s);

  std::size_t dropped() const { return dropped_; }
  std::size_t processed() const { return processed_; }

 private:
  std::vector<double> timestamps_;
  std::size_t next_ = 0;  // first frame not yet processed or dropped
  std::size_t dropped_ = 0, processed_ = 0;
};

}  // namespace coloc::slam::localize
