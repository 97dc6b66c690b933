#pragma once
// A page without a browser: opens the event stream (GET /api/events) of a ViewServer and, as
// the page does, fetches the scene when a `map` event announces a new version and the live
// image on each `frame` event. For the tests and `coloc bench view` (the cost of a connected
// viewer on tracking). Runs its own thread; disconnect() drops the stream mid-way as a closed
// browser tab does.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace coloc::slam::view {

struct EventClientStats {
  bool connected = false;                        // the stream's `hello` event arrived
  std::uint64_t frames = 0, maps = 0;            // `frame` and `map` events
  std::uint64_t map_bytes = 0, image_bytes = 0;  // fetched like the page
  std::string last_frame;                        // data of the last `frame` event (JSON)
  std::string scene;                             // the last scene fetched (JSON)
};

class EventClient {
 public:
  // `fetch`: behave like the page (scene on `map`, image on `frame`); else only count events.
  EventClient(std::string host, int port, bool fetch = true);
  ~EventClient();
  EventClient(const EventClient&) = delete;
  EventClient& operator=(const EventClient&) = delete;

  // Closes the stream (idempotent): the server sees the page go away.
  void disconnect();
  EventClientStats stats() const;
  // Waits until `done(stats)` holds or `seconds` passed; true when it holds.
  bool wait_until(const std::function<bool(const EventClientStats&)>& done, double seconds) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::slam::view
