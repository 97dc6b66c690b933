#pragma once
// Private to coloc_twin: PNG encoding on a worker thread, so frames are encoded while the next
// one renders. Jobs pass through a bounded queue (capacity frames in flight); close() drains the
// queue, joins the worker and rethrows the first write error. Owned and driven by one thread.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <opencv2/core.hpp>
#include <thread>
#include <utility>

namespace coloc::registration::twin {

class AsyncPngWriter {
 public:
  explicit AsyncPngWriter(std::size_t capacity = 8);
  ~AsyncPngWriter();  // closes; errors are then only logged
  AsyncPngWriter(const AsyncPngWriter&) = delete;
  AsyncPngWriter& operator=(const AsyncPngWriter&) = delete;

  // Queues `image` (taken by value: the caller may reuse its own Mat) for writing to `path`;
  // blocks while the queue is full. Throws the worker's error if one happened.
  void write(std::filesystem::path path, cv::Mat image);
  // Waits for every queued image, stops the worker; throws coloc::Error on a failed write.
  void close();

 private:
  void run();

  std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable not_full_;
  std::condition_variable not_empty_;
  std::deque<std::pair<std::filesystem::path, cv::Mat>> queue_;
  bool closing_ = false;
  std::exception_ptr error_;
  std::thread worker_;
};

}  // namespace coloc::registration::twin
