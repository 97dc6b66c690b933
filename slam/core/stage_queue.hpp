#pragma once
// A pipeline stage's input: a BoundedQueue plus the count of items pushed and not yet finished
// (still queued, or in the consumer's hands). That count is what "idle" means to the producer:
// tracking asking local mapping, local mapping asking loop closing. Thread-safe.
#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <optional>

#include "slam/core/bounded_queue.hpp"

namespace coloc {

template <typename T>
class StageQueue {
 public:
  explicit StageQueue(std::size_t capacity) : queue_(capacity) {}

  // Blocks while full; false once closed (the item is dropped and not counted).
  bool push(T item) {
    {
      std::lock_guard lock(mutex_);
      ++pending_;
    }
    if (queue_.push(std::move(item))) return true;
    finished();
    return false;
  }

  // As BoundedQueue::pop(); the consumer calls finished() when done with the item.
  std::optional<T> pop() { return queue_.pop(); }

  void finished() {
    std::lock_guard lock(mutex_);
    --pending_;
    idle_cv_.notify_all();
  }

  bool idle() const {
    std::lock_guard lock(mutex_);
    return pending_ == 0;
  }

  // Blocks until every pushed item is finished, or the queue is closed.
  void wait_idle() {
    std::unique_lock lock(mutex_);
    idle_cv_.wait(lock, [&] { return pending_ == 0 || closed_; });
  }

  // Refuses further pushes and wakes every waiter; the consumer drains what is left.
  void close() {
    queue_.close();
    std::lock_guard lock(mutex_);
    closed_ = true;
    idle_cv_.notify_all();
  }

  std::size_t size() const { return queue_.size(); }

 private:
  BoundedQueue<T> queue_;
  mutable std::mutex mutex_;  // guards pending_ and closed_
  std::condition_variable idle_cv_;
  int pending_ = 0;
  bool closed_ = false;
};

}  // namespace coloc
