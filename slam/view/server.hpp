#pragma once
// The viewer's HTTP server (cpp-httplib): the page (the built web folder: index.html, app.js and
// three.js, served as files, nothing fetched from elsewhere), the map scene, keyframe panels,
// the scan's points, the registration report, and a server-sent-event stream (GET /api/events)
// that pushes live frames and map changes to every open page.
//
// Endpoints: /api/info, /api/map (scene JSON), /api/keyframe/ID (JSON),
// /api/keyframe/ID/image.jpg, /api/scan.bin (u32 count, f32 xyz x count, u8 rgb x count,
// little-endian), /api/registration, /api/live/image.jpg (the latest live frame),
// /api/events (text/event-stream: `map` {version} and `frame` events), /report/... (files of a
// registration report folder).
//
// Streaming never holds up the producer: publish() appends to each page's queue of at most
// `client_queue` events (the oldest is dropped and counted when a page reads too slowly) and
// returns; a page that disconnects mid-stream is removed and counted.
//
// Threads: the server runs its own listening thread and a pool of connection threads; every
// public method is thread-safe. Errors: the constructor throws coloc::Error naming the address
// when it cannot listen (port in use, address not local).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace coloc::slam::view {

struct ViewServerOptions {
  std::string bind = "127.0.0.1";    // loopback unless the user asks otherwise
  int port = 8080;                   // 0: any free port
  std::filesystem::path web_root;    // the built page (must hold index.html)
  std::filesystem::path report_dir;  // a registration report folder (optional), at /report/
  std::size_t client_queue = 16;     // events queued per page before the oldest is dropped
  std::size_t max_clients = 8;       // event streams at once (each holds a connection thread)
  double keepalive_s = 1.0;          // a comment line when idle: finds closed pages
  // Connections served at once, a thread each (page loads, images, event streams); idle ones
  // are closed after idle_timeout_s without a request, so they cannot starve the others.
  std::size_t max_connections = 256;
  int idle_timeout_s = 2;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct ViewServerStats {
  std::uint64_t clients_connected = 0;  // event streams opened so far
  std::uint64_t clients_now = 0;
  std::uint64_t disconnected = 0;  // streams that ended (page closed, network gone)
  std::uint64_t refused = 0;       // streams refused (max_clients)
  std::uint64_t events_published = 0, events_sent = 0, events_dropped = 0;
  std::uint64_t requests = 0;
};

// JSON of a keyframe panel / JPEG bytes of a keyframe image; nullopt = 404.
using KeyframeSource = std::function<std::optional<std::string>(std::uint64_t id)>;

class ViewServer {
 public:
  explicit ViewServer(ViewServerOptions options);
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  int port() const;
  std::string url() const;  // http://BIND:PORT/

  // /api/info: what the page shows in its header (mode, file names, frame).
  void set_info(std::string json);
  // /api/map; announces the new version to every page (a `map` event).
  void set_scene(std::string json, std::uint64_t version);
  void set_keyframe_source(KeyframeSource json);
  void set_keyframe_image_source(KeyframeSource jpeg);
  void set_scan(std::string binary);
  void set_registration(std::string json);
  void set_live_image(std::string jpeg);
  // Sends `data` (one line of JSON) as event `event` to every page's stream.
  void publish(const std::string& event, const std::string& data);

  // Event streams open now (a producer skips work nobody will see).
  std::size_t clients() const;
  // Waits until a page has an event stream open, at most `seconds`; true when one has.
  bool wait_for_client(double seconds) const;
  ViewServerStats stats() const;
  // Ends every stream and stops listening; idempotent (the destructor calls it).
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace coloc::slam::view
