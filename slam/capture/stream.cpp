#include "slam/capture/stream.hpp"

namespace coloc::capture {

NodeStream::NodeStream(std::unique_ptr<VideoNode> node, unsigned buffers,
                       std::size_t queue_capacity)
    : node_(std::move(node)), queue_(queue_capacity) {
  node_->start(buffers);
  thread_ = std::thread([this] { run(); });
}

NodeStream::~NodeStream() {
  stop();
}

void NodeStream::stop() {
  std::lock_guard lock(stop_mutex_);
  stop_ = true;
  queue_.close();  // wakes a push waiting for room (paced_by_reader); pop() drains what is left
  if (thread_.joinable()) thread_.join();
  node_->stop();
}

StreamCounters NodeStream::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

std::optional<std::pair<std::string, int>> NodeStream::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

void NodeStream::count(std::uint32_t sequence, std::optional<std::uint32_t>& last_sequence) {
  std::lock_guard lock(mutex_);
  count_locked(sequence, last_sequence);
}

void NodeStream::count_locked(std::uint32_t sequence, std::optional<std::uint32_t>& last_sequence) {
  if (last_sequence && sequence > *last_sequence + 1)
    counters_.kernel_drops += sequence - *last_sequence - 1;
  last_sequence = sequence;
}

void NodeStream::run() {
  const bool lossless = node_->paced_by_reader();
  std::optional<std::uint32_t> last_sequence;
  try {
    while (!stop_) {
      // A bounded wait, so stop() is seen within 100 ms even when no frame comes.
      std::optional<Buffer> b = node_->dequeue(100);
      if (!b) continue;
      RawFrame f{{b->bytes.begin(), b->bytes.end()}, b->sequence, b->timestamp_ns};
      node_->requeue(b->index);
      if (lossless) {
        // Waits for room without mutex_, so the consumer can read the counters meanwhile.
        count(f.sequence, last_sequence);
        if (!queue_.push(std::move(f))) break;  // closed by stop()
        std::lock_guard lock(mutex_);
        ++counters_.frames;
        continue;
      }
      std::lock_guard lock(mutex_);
      count_locked(f.sequence, last_sequence);
      // Only this thread pushes, so a queue seen with room still has room at the push.
      if (queue_.size() >= queue_.capacity()) {
        ++counters_.queue_drops;
        continue;
      }
      ++counters_.frames;
      queue_.push(std::move(f));
    }
  } catch (const DeviceError& e) {
    std::lock_guard lock(mutex_);
    error_ = {e.what(), e.error_number()};
  } catch (const std::exception& e) {
    std::lock_guard lock(mutex_);
    error_ = {e.what(), 0};
  }
  queue_.close();  // the consumer drains what was captured, then sees the end
}

}  // namespace coloc::capture
