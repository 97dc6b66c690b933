#include "slam/view/client.hpp"

#include <httplib.h>

#include <chrono>

namespace coloc::slam::view {

struct EventClient::Impl {
  std::string host;
  int port = 0;
  bool fetch = true;
  httplib::Client stream, requests;
  std::thread thread;
  std::atomic<bool> stopping{false};
  mutable std::mutex mutex;
  mutable std::condition_variable changed;
  EventClientStats stats;
  std::string pending;  // bytes of the stream not yet split into events

  Impl(std::string h, int p, bool f)
      : host(std::move(h)), port(p), fetch(f), stream(host, port), requests(host, port) {}
  void on_event(const std::string& name, const std::string& data);
  bool receive(const char* data, std::size_t size);
};

void EventClient::Impl::on_event(const std::string& name, const std::string& data) {
  std::string body;
  if (fetch && name == "map") {
    if (auto r = requests.Get("/api/map"); r && r->status == 200) body = r->body;
  }
  std::uint64_t image_bytes = 0;
  if (fetch && name == "frame") {
    if (auto r = requests.Get("/api/live/image.jpg"); r && r->status == 200)
      image_bytes = r->body.size();
  }
  {
    std::lock_guard lock(mutex);
    if (name == "hello") stats.connected = true;
    if (name == "map") {
      ++stats.maps;
      stats.map_bytes += body.size();
      if (!body.empty()) stats.scene = std::move(body);
    }
    if (name == "frame") {
      ++stats.frames;
      stats.image_bytes += image_bytes;
      stats.last_frame = data;
    }
  }
  changed.notify_all();
}

// Splits the stream into server-sent events ("event: NAME\ndata: JSON\n\n"); comments are
// keepalives. False ends the stream (disconnect()).
bool EventClient::Impl::receive(const char* data, std::size_t size) {
  if (stopping) return false;
  pending.append(data, size);
  std::size_t end = 0;
  while ((end = pending.find("\n\n")) != std::string::npos) {
    const std::string record = pending.substr(0, end);
    pending.erase(0, end + 2);
    std::string name, payload;
    std::size_t start = 0;
    while (start < record.size()) {
      std::size_t stop = record.find('\n', start);
      if (stop == std::string::npos) stop = record.size();
      const std::string line = record.substr(start, stop - start);
      if (line.rfind("event: ", 0) == 0) name = line.substr(7);
      if (line.rfind("data: ", 0) == 0) payload = line.substr(6);
      start = stop + 1;
    }
    if (!name.empty()) on_event(name, payload);
  }
  return !stopping;
}

EventClient::EventClient(std::string host, int port, bool fetch)
    : impl_(std::make_unique<Impl>(std::move(host), port, fetch)) {
  Impl& d = *impl_;
  d.stream.set_read_timeout(5, 0);
  d.thread = std::thread([&d] {
    d.stream.Get("/api/events",
                 [&d](const char* data, std::size_t size) { return d.receive(data, size); });
    std::lock_guard lock(d.mutex);
    d.stats.connected = false;
    d.changed.notify_all();
  });
}

EventClient::~EventClient() {
  disconnect();
}

void EventClient::disconnect() {
  impl_->stopping = true;
  impl_->stream.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

EventClientStats EventClient::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

bool EventClient::wait_until(const std::function<bool(const EventClientStats&)>& done,
                             double seconds) const {
  std::unique_lock lock(impl_->mutex);
  return impl_->changed.wait_for(lock, std::chrono::duration<double>(seconds),
                                 [&] { return done(impl_->stats); });
}

}  // namespace coloc::slam::view
