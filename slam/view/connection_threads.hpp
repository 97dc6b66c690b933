#pragma once
// httplib's task queue for the viewer: one thread per connection, at most `limit` at once.
// httplib's own ThreadPool serves connections by a fixed number of threads in arrival order, and
// a connection that sends nothing holds its thread for the whole idle timeout: 200 idle
// connections kept a page load waiting for minutes (issue 37). Here every connection starts at
// once on its own thread, so idle or slow clients cost a sleeping thread each and starve
// nobody; beyond `limit` (a flood) connections wait for a thread as before. Internal to
// slam/view.
#include <httplib.h>

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <system_error>
#include <thread>

namespace coloc::slam::view::detail {

class ConnectionThreads final : public httplib::TaskQueue {
 public:
  explicit ConnectionThreads(std::size_t limit) : limit_(limit == 0 ? 1 : limit) {}
  ~ConnectionThreads() override { shutdown(); }

  void enqueue(std::function<void()> task) override {
    {
      const std::lock_guard lock(mutex_);
      if (running_ >= limit_) {
        waiting_.push_back(std::move(task));
        return;
      }
      ++running_;
    }
    auto shared = std::make_shared<std::function<void()>>(std::move(task));
    try {
      // Detached: shutdown() waits for the count, so no thread outlives this queue's use.
      std::thread([this, shared] { run(std::move(*shared)); }).detach();
    } catch (const std::system_error&) {
      // No thread to be had (a resource limit): the accepting thread serves it itself.
      run(std::move(*shared));
    }
  }

  // Waits until every connection (and every waiting one) was served: httplib calls it when
  // the server stops, after it stopped accepting.
  void shutdown() override {
    std::unique_lock lock(mutex_);
    idle_.wait(lock, [this] { return running_ == 0; });
  }

 private:
  void run(std::function<void()> task) {
    for (;;) {
      task();
      const std::lock_guard lock(mutex_);
      if (waiting_.empty()) {
        --running_;
        idle_.notify_all();
        return;
      }
      task = std::move(waiting_.front());
      waiting_.pop_front();
    }
  }

  const std::size_t limit_;
  std::mutex mutex_;
  std::condition_variable idle_;
  std::deque<std::function<void()>> waiting_;
  std::size_t running_ = 0;
};

}  // namespace coloc::slam::view::detail
