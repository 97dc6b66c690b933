#include "registration/twin/image_writer.hpp"

#include <spdlog/spdlog.h>

#include <cstdint>
#include <opencv2/imgcodecs.hpp>
#include <string_view>
#include <vector>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin {

AsyncPngWriter::AsyncPngWriter(std::size_t capacity)
    : capacity_(capacity == 0 ? 1 : capacity), worker_([this] { run(); }) {}

AsyncPngWriter::~AsyncPngWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    spdlog::error("twin: image writer: {}", e.what());
  }
}

void AsyncPngWriter::write(std::filesystem::path path, cv::Mat image) {
  std::unique_lock lock(mutex_);
  not_full_.wait(lock, [this] { return queue_.size() < capacity_ || error_; });
  if (error_) std::rethrow_exception(error_);
  queue_.emplace_back(std::move(path), std::move(image));
  not_empty_.notify_one();
}

void AsyncPngWriter::close() {
  {
    std::lock_guard lock(mutex_);
    if (closing_ && !worker_.joinable()) return;
    closing_ = true;
  }
  not_empty_.notify_all();
  if (worker_.joinable()) worker_.join();
  if (error_) {
    std::exception_ptr e = error_;
    error_ = nullptr;
    std::rethrow_exception(e);
  }
}

void AsyncPngWriter::run() {
  for (;;) {
    std::pair<std::filesystem::path, cv::Mat> job;
    {
      std::unique_lock lock(mutex_);
      not_empty_.wait(lock, [this] { return !queue_.empty() || closing_; });
      if (queue_.empty()) return;  // closing and drained
      job = std::move(queue_.front());
      queue_.pop_front();
      not_full_.notify_one();
    }
    // Encoded in memory and written under a temporary name (no fsync: thousands of frames),
    // so a failed run never leaves a truncated PNG under a final name.
    bool ok = false;
    try {
      std::vector<std::uint8_t> png;
      ok = cv::imencode(job.first.extension().string(), job.second, png,
                        {cv::IMWRITE_PNG_COMPRESSION, 1});
      if (ok) {
        write_file_atomically(
            job.first, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()),
            false);
      }
    } catch (const cv::Exception&) {
      ok = false;
    } catch (const Error&) {
      ok = false;
    }
    if (!ok) {
      std::lock_guard lock(mutex_);
      if (!error_) {
        error_ = std::make_exception_ptr(Error("cannot write image", {.file = job.first.string()}));
      }
      queue_.clear();
      not_full_.notify_all();
      return;
    }
  }
}

}  // namespace coloc::registration::twin
