#include "fusion/stream_guard.hpp"

#include <algorithm>
#include <string>

#include "slam/core/error.hpp"

namespace coloc::fusion {

void StreamGuardOptions::check() const {
  const auto require = [](bool ok, const char* field, const char* what) {
    if (!ok) throw Error(what, ErrorContext{.field = std::string("StreamGuardOptions.") + field});
  };
  require(max_time_lead > 0.0, "max_time_lead", "must be positive (seconds)");
  require(max_sequence_gap >= 1, "max_sequence_gap", "must be at least 1");
  require(resync_after >= 1, "resync_after", "must be at least 1");
}

StreamGuard::StreamGuard(StreamGuardOptions options) : options_(options) {
  options_.check();
}

bool StreamGuard::follows(const Mark& from, const Mark& next) const {
  const std::int64_t step = std::int64_t{next.sequence} - from.sequence;
  if (step < 1 || step > options_.max_sequence_gap) return false;
  if (!(next.time > from.time)) return false;
  const double elapsed = std::max(0.0, next.received - from.received);
  return next.time - from.time <= elapsed + options_.max_time_lead;
}

StreamVerdict StreamGuard::check(std::int32_t sequence, double time, double received) {
  const Mark next{sequence, time, received};
  if (!last_ || follows(*last_, next)) {
    last_ = next;
    candidate_.reset();
    candidate_run_ = 0;
    return StreamVerdict::kAccepted;
  }
  // Rejected. Does it continue the run of rejected messages that agree with each other?
  if (candidate_ && follows(*candidate_, next)) {
    ++candidate_run_;
  } else {
    candidate_run_ = 1;
  }
  candidate_ = next;
  if (candidate_run_ >= options_.resync_after) {
    last_ = next;
    candidate_.reset();
    candidate_run_ = 0;
    return StreamVerdict::kResynced;
  }
  const std::int64_t behind = std::int64_t{last_->sequence} - sequence;
  const bool stale = behind >= 0 && behind <= options_.max_sequence_gap && !(time > last_->time);
  return stale ? StreamVerdict::kStale : StreamVerdict::kImplausible;
}

}  // namespace coloc::fusion
