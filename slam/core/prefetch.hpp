#pragma once
// A producer run on a thread of its own, up to `capacity` items ahead of its consumer, joined to
// it by a BoundedQueue: the stage behind dataset::read_ahead (decoding) and
// pipeline::ExtractAhead (feature extraction). Items come out in order; an exception of the
// producer comes out of next() where its item would have been, and the end after it.
#include <cstddef>
#include <exception>
#include <functional>
#include <optional>
#include <thread>
#include <utility>

#include "slam/core/bounded_queue.hpp"

namespace coloc {

template <typename T>
class Prefetch {
 public:
  // `produce` returns the next item, nothing at the end; it runs on the prefetch thread only.
  Prefetch(std::function<std::optional<T>()> produce, std::size_t capacity)
      : produce_(std::move(produce)), queue_(capacity), worker_([this] { run(); }) {}
  // Waits for a call of `produce` in progress (which a live camera could hold until its next
  // frame); a worker blocked on a full queue gives up at once.
  ~Prefetch() {
    queue_.close();
    worker_.join();
  }
  Prefetch(const Prefetch&) = delete;
  Prefetch& operator=(const Prefetch&) = delete;

  // The next item; nothing at the end (and after the producer's exception).
  std::optional<T> next() {
    auto item = queue_.pop();
    if (!item) return std::nullopt;
    if (item->error) std::rethrow_exception(item->error);
    return std::move(item->value);
  }

 private:
  struct Item {
    std::optional<T> value;
    std::exception_ptr error;
  };

  void run() {
    try {
      while (auto value = produce_())
        if (!queue_.push(Item{std::move(value), nullptr})) return;  // the consumer left
    } catch (...) {
      queue_.push(Item{std::nullopt, std::current_exception()});
    }
    queue_.close();
  }

  std::function<std::optional<T>()> produce_;
  BoundedQueue<Item> queue_;
  std::thread worker_;  // last: it starts once the members it uses exist
};

}  // namespace coloc
