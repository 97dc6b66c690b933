#include "slam/view/server.hpp"

#include <httplib.h>
#include <pthread.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstring>
#include <deque>
#include <list>
#include <mutex>
#include <thread>

#include "slam/core/error.hpp"
#include "slam/view/connection_threads.hpp"

namespace coloc::slam::view {

void ViewServerOptions::check() const {
  if (bind.empty())
    throw Error("must name an address (127.0.0.1: this machine only)", {.field = "bind"});
  if (port < 0 || port > 65535) throw Error("must be 0..65535", {.field = "port"});
  if (web_root.empty() || !std::filesystem::is_regular_file(web_root / "index.html"))
    throw Error("the viewer's page is not built here (no index.html)",
                {.file = web_root.string(), .field = "web_root"});
  if (!report_dir.empty() && !std::filesystem::is_directory(report_dir))
    throw Error("not a folder", {.file = report_dir.string(), .field = "report_dir"});
  if (client_queue == 0) throw Error("must be at least 1", {.field = "client_queue"});
  if (max_clients == 0) throw Error("must be at least 1", {.field = "max_clients"});
  if (!(keepalive_s > 0.0)) throw Error("must be positive (seconds)", {.field = "keepalive_s"});
  if (max_connections < max_clients + 4)
    throw Error("must leave room for max_clients event streams and 4 more connections",
                {.field = "max_connections"});
  if (idle_timeout_s < 1) throw Error("must be at least 1 (seconds)", {.field = "idle_timeout_s"});
}

namespace {

// One open page's event stream.
struct Subscriber {
  std::deque<std::string> events;  // formatted SSE records
};

}  // namespace

struct ViewServer::Impl {
  ViewServerOptions options;
  httplib::Server http;
  std::thread thread;
  int port = 0;

  mutable std::mutex mutex;                // everything below
  std::condition_variable wake;            // new events, closing
  mutable std::condition_variable joined;  // a page opened its event stream
  bool closing = false;
  std::list<Subscriber> subscribers;
  ViewServerStats stats;
  std::string info = "{}", scene = "{}", scan, registration = "null", live_image;
  KeyframeSource keyframe_json, keyframe_image;

  void routes();
  void events(httplib::Response& res);
  // Waits for events of `sub` (or the keepalive interval); false once the server closes.
  bool next_events(std::list<Subscriber>::iterator sub, std::string& out);
};

namespace {

// Serves `body` (a member of Impl, read under its mutex) with `type`, or 404 when empty.
void serve(httplib::Response& res, std::mutex& mutex, const std::string& body, const char* type) {
  std::string copy;
  {
    std::lock_guard lock(mutex);
    copy = body;
  }
  res.set_header("Cache-Control", "no-store");
  if (copy.empty()) {
    res.status = 404;
    return;
  }
  res.set_content(copy, type);
}

std::optional<std::uint64_t> parse_id(const std::string& text) {
  try {
    std::size_t used = 0;
    const unsigned long long v = std::stoull(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

}  // namespace

void ViewServer::Impl::routes() {
  http.set_file_extension_and_mimetype_mapping("js", "text/javascript");
  http.set_mount_point("/", options.web_root.string());
  if (!options.report_dir.empty()) http.set_mount_point("/report", options.report_dir.string());
  http.set_pre_routing_handler([this](const httplib::Request&, httplib::Response&) {
    std::lock_guard lock(mutex);
    ++stats.requests;
    return httplib::Server::HandlerResponse::Unhandled;
  });
  http.Get("/api/info",
           [this](const auto&, auto& res) { serve(res, mutex, info, "application/json"); });
  http.Get("/api/map",
           [this](const auto&, auto& res) { serve(res, mutex, scene, "application/json"); });
  http.Get("/api/scan.bin",
           [this](const auto&, auto& res) { serve(res, mutex, scan, "application/octet-stream"); });
  http.Get("/api/registration",
           [this](const auto&, auto& res) { serve(res, mutex, registration, "application/json"); });
  http.Get("/api/live/image.jpg",
           [this](const auto&, auto& res) { serve(res, mutex, live_image, "image/jpeg"); });
  const auto keyframe = [this](bool image) {
    return [this, image](const httplib::Request& req, httplib::Response& res) {
      KeyframeSource source;
      {
        std::lock_guard lock(mutex);
        source = image ? keyframe_image : keyframe_json;
      }
      const auto id = parse_id(req.matches[1]);
      const auto body = (source && id) ? source(*id) : std::nullopt;
      res.set_header("Cache-Control", "no-store");
      if (!body) {
        res.status = 404;
        return;
      }
      res.set_content(*body, image ? "image/jpeg" : "application/json");
    };
  };
  http.Get(R"(/api/keyframe/(\d+))", keyframe(false));
  http.Get(R"(/api/keyframe/(\d+)/image\.jpg)", keyframe(true));
  http.Get("/api/events", [this](const auto&, auto& res) { events(res); });
  http.set_exception_handler([](const auto&, auto& res, std::exception_ptr e) {
    res.status = 500;
    try {
      std::rethrow_exception(std::move(e));
    } catch (const std::exception& x) {
      res.set_content(x.what(), "text/plain");
    }
  });
}

bool ViewServer::Impl::next_events(std::list<Subscriber>::iterator sub, std::string& out) {
  std::unique_lock lock(mutex);
  wake.wait_for(lock, std::chrono::duration<double>(options.keepalive_s),
                [&] { return closing || !sub->events.empty(); });
  if (closing) return false;
  for (std::string& e : sub->events)
    out += e;
  stats.events_sent += sub->events.size();
  sub->events.clear();
  if (out.empty()) out = ": keepalive\n\n";
  return true;
}

void ViewServer::Impl::events(httplib::Response& res) {
  std::list<Subscriber>::iterator sub;
  {
    std::lock_guard lock(mutex);
    if (closing || subscribers.size() >= options.max_clients) {
      ++stats.refused;
      res.status = 503;
      res.set_content("too many viewer pages open", "text/plain");
      return;
    }
    sub = subscribers.emplace(subscribers.end());
    // The page fetches the scene itself; this first event tells it which version is current.
    sub->events.push_back("event: hello\ndata: {}\n\n");
    ++stats.clients_connected;
    stats.clients_now = subscribers.size();
  }
  joined.notify_all();
  res.set_header("Cache-Control", "no-store");
  res.set_chunked_content_provider(
      "text/event-stream",
      [this, sub](std::size_t, httplib::DataSink& sink) {
        std::string out;
        if (!next_events(sub, out)) {
          sink.done();
          return true;
        }
        // False: the page went away; httplib closes the connection and calls the releaser.
        return sink.write(out.data(), out.size());
      },
      [this, sub](bool) {
        std::lock_guard lock(mutex);
        subscribers.erase(sub);
        ++stats.disconnected;
        stats.clients_now = subscribers.size();
      });
}

ViewServer::ViewServer(ViewServerOptions options) : impl_(std::make_unique<Impl>()) {
  options.check();
  impl_->options = std::move(options);
  Impl& d = *impl_;
  // A thread per connection (bounded): idle clients cannot queue a page load behind them.
  const std::size_t threads = d.options.max_connections;
  d.http.new_task_queue = [threads] { return new detail::ConnectionThreads(threads); };
  d.http.set_keep_alive_timeout(d.options.idle_timeout_s);
  d.http.set_read_timeout(d.options.idle_timeout_s, 0);
  // httplib's default is SO_REUSEPORT, which lets a second viewer share the port (and split
  // the pages between them) instead of failing; SO_REUSEADDR only allows a quick restart.
  d.http.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  d.routes();
  errno = 0;
  if (d.options.port == 0) {
    d.port = d.http.bind_to_any_port(d.options.bind);
  } else {
    d.port = d.http.bind_to_port(d.options.bind, d.options.port) ? d.options.port : -1;
  }
  if (d.port <= 0) {
    const std::string why = errno == EADDRINUSE ? "the port is in use (another viewer?)"
                            : errno != 0        ? std::strerror(errno)
                                                : "the address is not valid here";
    throw Error("cannot listen on " + d.options.bind + ":" + std::to_string(d.options.port) + ": " +
                    why + "; choose another with --port (0: any free port)",
                {.field = "port"});
  }
  d.thread = std::thread([&d] {
    // A page closing mid-stream makes the next send fail with EPIPE; the connection threads
    // (created by this thread, inheriting its mask) must get the error, not a process-killing
    // SIGPIPE. The mask is this thread's only: the rest of the process is untouched.
    sigset_t pipe;
    sigemptyset(&pipe);
    sigaddset(&pipe, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
    d.http.listen_after_bind();
  });
  // httplib's stop() does nothing until listen has begun (is_running): a server stopped right
  // after construction would otherwise listen forever and its destructor never join.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!d.http.is_running() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  spdlog::debug("viewer listening on {}", url());
}

ViewServer::~ViewServer() {
  stop();
}

void ViewServer::stop() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->closing = true;
  }
  impl_->wake.notify_all();
  impl_->http.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

int ViewServer::port() const {
  return impl_->port;
}

std::string ViewServer::url() const {
  return "http://" + impl_->options.bind + ":" + std::to_string(impl_->port) + "/";
}

void ViewServer::set_info(std::string json) {
  std::lock_guard lock(impl_->mutex);
  impl_->info = std::move(json);
}

void ViewServer::set_scene(std::string json, std::uint64_t version) {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->scene = std::move(json);
  }
  publish("map", "{\"version\":" + std::to_string(version) + "}");
}

void ViewServer::set_keyframe_source(KeyframeSource json) {
  std::lock_guard lock(impl_->mutex);
  impl_->keyframe_json = std::move(json);
}

void ViewServer::set_keyframe_image_source(KeyframeSource jpeg) {
  std::lock_guard lock(impl_->mutex);
  impl_->keyframe_image = std::move(jpeg);
}

void ViewServer::set_scan(std::string binary) {
  std::lock_guard lock(impl_->mutex);
  impl_->scan = std::move(binary);
}

void ViewServer::set_registration(std::string json) {
  std::lock_guard lock(impl_->mutex);
  impl_->registration = std::move(json);
}

void ViewServer::set_live_image(std::string jpeg) {
  std::lock_guard lock(impl_->mutex);
  impl_->live_image = std::move(jpeg);
}

void ViewServer::publish(const std::string& event, const std::string& data) {
  const std::string record = "event: " + event + "\ndata: " + data + "\n\n";
  {
    std::lock_guard lock(impl_->mutex);
    ++impl_->stats.events_published;
    for (Subscriber& s : impl_->subscribers) {
      if (s.events.size() >= impl_->options.client_queue) {
        s.events.pop_front();
        ++impl_->stats.events_dropped;
      }
      s.events.push_back(record);
    }
  }
  impl_->wake.notify_all();
}

std::size_t ViewServer::clients() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->subscribers.size();
}

bool ViewServer::wait_for_client(double seconds) const {
  std::unique_lock lock(impl_->mutex);
  return impl_->joined.wait_for(lock, std::chrono::duration<double>(seconds),
                                [&] { return !impl_->subscribers.empty(); });
}

ViewServerStats ViewServer::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

}  // namespace coloc::slam::view
