#pragma once
// One capture thread per V4L2 node: it dequeues a buffer, copies its bytes, hands the buffer
// back to the driver at once (so the driver never runs out and drops), and offers the copy to a
// bounded queue. A full queue (the consumer is behind) drops the new frame and counts it; the
// driver's own drops show as gaps in the buffer sequence numbers and are counted too. Nothing
// is dropped silently. A lost device (ENODEV) or the end of a replay ends the stream: the queue
// is closed, the consumer drains what was captured, and error() says why. A node paced by its
// reader (an unpaced replay) is never dropped from: the stream waits for room in the queue.
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "slam/capture/device.hpp"
#include "slam/core/bounded_queue.hpp"

namespace coloc::capture {

struct RawFrame {
  std::vector<std::uint8_t> bytes;
  std::uint32_t sequence = 0;
  std::int64_t kernel_ns = 0;
};

struct StreamCounters {
  std::size_t frames = 0;        // handed to the queue
  std::size_t kernel_drops = 0;  // sequence gaps
  std::size_t queue_drops = 0;   // dropped because the consumer was behind
};

class NodeStream {
 public:
  // Takes a configured node; starts streaming and the thread.
  NodeStream(std::unique_ptr<VideoNode> node, unsigned buffers, std::size_t queue_capacity);
  ~NodeStream();  // stop()
  NodeStream(const NodeStream&) = delete;
  NodeStream& operator=(const NodeStream&) = delete;

  // Blocks for the next frame; nothing once the stream ended (stop(), unplug, end of replay)
  // and every captured frame was taken.
  std::optional<RawFrame> pop() { return queue_.pop(); }
  // As pop(), waiting at most timeout_ms (nothing also on timeout).
  std::optional<RawFrame> pop_for(int timeout_ms) {
    return queue_.pop_for(std::chrono::milliseconds(timeout_ms));
  }
  // Thread-safe: a second caller waits until the first has stopped the stream.
  void stop();
  StreamCounters counters() const;
  // Why the stream ended by itself (the DeviceError's message and errno), if it did.
  std::optional<std::pair<std::string, int>> error() const;
  const std::filesystem::path& path() const { return node_->path(); }
  // VideoNode::paced_by_reader: every frame comes, so waiting for the next one is never vain.
  bool paced_by_reader() const { return node_->paced_by_reader(); }

 private:
  void run();
  // Counts the driver's drops: the gap between `sequence` and the last one seen.
  void count(std::uint32_t sequence, std::optional<std::uint32_t>& last_sequence);
  void count_locked(std::uint32_t sequence, std::optional<std::uint32_t>& last_sequence);

  std::unique_ptr<VideoNode> node_;
  BoundedQueue<RawFrame> queue_;
  std::atomic<bool> stop_{false};
  std::mutex stop_mutex_;     // one stop() joins the thread; another waits for it
  mutable std::mutex mutex_;  // guards counters_ and error_
  StreamCounters counters_;
  std::optional<std::pair<std::string, int>> error_;
  std::thread thread_;
};

}  // namespace coloc::capture
