#pragma once
// StreamGuard: decides, per incoming OSC pose stream, which messages are plausible enough to
// reach the fuser, so that no single message from any peer can freeze a stream.
//
// A message is "in line" with the last accepted one when
//   - its sequence number is 1..max_sequence_gap ahead (datagrams may be lost, not invented), and
//   - its time is later, but not by more than the receiver's clock advanced between the two
//     arrivals plus max_time_lead (a sender's clock cannot run far ahead of ours; the lead
//     absorbs network jitter and senders that replay faster than real time).
// In-line messages are accepted. A message both older in sequence (within max_sequence_gap) and
// not later in time is stale (a duplicate or reordered datagram). Anything else is implausible:
// a time far in the future, a sequence number that jumped, a clock that went back.
//
// Neither is fed to the fuser, so one absurd message cannot move the stream's reference. But a
// stream can legitimately move (a restarted sender, a stepped clock, a replay that loops, or a
// first message that was itself the absurd one): when resync_after rejected messages in a row
// are in line with each other, the guard re-anchors on them (kResynced), and the caller forgets
// the stream's time history. A hostile peer can thus disturb a stream only while it keeps
// sending, and the real sender takes it back after resync_after messages.
//
// Times: `time` is the message's time (s, sender's clock); `received` is the receiver's
// steady clock (s) at arrival. Not thread-safe (owned by a node under its lock).

#include <cstdint>
#include <optional>

namespace coloc::fusion {

struct StreamGuardOptions {
  double max_time_lead = 1.0;            // s, see above
  std::int64_t max_sequence_gap = 1000;  // messages that may be lost in a row
  int resync_after = 5;                  // consistent rejected messages that re-anchor

  void check() const;  // throws coloc::Error naming the field
};

enum class StreamVerdict : std::uint8_t {
  kAccepted,     // in line with the stream
  kResynced,     // accepted as the new anchor of the stream (its history is to be forgotten)
  kStale,        // an older message (duplicate, reordered): dropped
  kImplausible,  // out of line (time or sequence jump): dropped
};

class StreamGuard {
 public:
  explicit StreamGuard(StreamGuardOptions options = {});

  StreamVerdict check(std::int32_t sequence, double time, double received);

 private:
  struct Mark {
    std::int32_t sequence = 0;
    double time = 0.0;
    double received = 0.0;
  };
  bool follows(const Mark& from, const Mark& next) const;

  StreamGuardOptions options_;
  std::optional<Mark> last_;       // last accepted message
  std::optional<Mark> candidate_;  // last of the current run of rejected, consistent messages
  int candidate_run_ = 0;
};

}  // namespace coloc::fusion
