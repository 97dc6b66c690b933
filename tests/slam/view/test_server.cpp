// The viewer's server and live feed over real sockets: a busy port is a clear error, pages get
// the events published to them, a page leaving mid-stream is counted and costs the producer
// nothing, and the feed takes frames only while a page is open and no faster than asked.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "slam/core/error.hpp"
#include "slam/view/client.hpp"
#include "slam/view/live_feed.hpp"
#include "slam/view/server.hpp"

namespace coloc::slam::view {
namespace {

namespace fs = std::filesystem;

// A wait for what is bound to happen (an event on loopback, the server's thread at work): only
// a stuck run reaches it, never a slow one (CI runs the suite on a busy 2-core machine).
constexpr double kArrivalS = 60.0;

// Polls condition() until it holds (true) or kArrivalS passed (false). Never asked again once
// it held: a condition may take what it saw (LiveFeed::wants_frame does).
template <typename Condition>
bool eventually(Condition condition) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kArrivalS);
  for (;;) {
    if (condition()) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// A web root with a page: the server refuses to start without one.
fs::path web_root() {
  const fs::path dir =
      fs::temp_directory_path() / ("coloc_view_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "index.html") << "<!doctype html><title>coloc view</title>";
  return dir;
}

ViewServerOptions options() {
  ViewServerOptions o;
  o.port = 0;
  o.web_root = web_root();
  o.keepalive_s = 0.2;
  return o;
}

TEST(ViewServer, BusyPortIsAClearError) {
  const ViewServer first(options());
  ViewServerOptions o = options();
  o.port = first.port();
  try {
    const ViewServer second(o);
    FAIL() << "two servers on one port";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("in use"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(std::to_string(first.port())), std::string::npos);
  }
}

TEST(ViewServer, OptionsAreChecked) {
  ViewServerOptions o = options();
  o.web_root = "/nonexistent";
  EXPECT_THROW(o.check(), Error);
  o = options();
  o.port = 70000;
  EXPECT_THROW(o.check(), Error);
}

TEST(ViewServer, PagesGetEventsAndLeavingIsCounted) {
  ViewServer server(options());
  server.set_scene(R"({"version":1,"keyframes":[]})", 1);
  EventClient page("127.0.0.1", server.port());
  ASSERT_TRUE(page.wait_until([](const auto& s) { return s.connected; }, kArrivalS));
  EXPECT_EQ(server.clients(), 1u);
  server.publish("frame", R"({"index":4})");
  server.set_scene(R"({"version":2,"keyframes":[1]})", 2);
  ASSERT_TRUE(
      page.wait_until([](const auto& s) { return s.frames == 1 && s.maps == 1; }, kArrivalS));
  EXPECT_EQ(page.stats().last_frame, R"({"index":4})");
  EXPECT_EQ(page.stats().scene, R"({"version":2,"keyframes":[1]})");
  page.disconnect();
  // The server finds out at its next write (a keepalive at the latest).
  EXPECT_TRUE(eventually([&] { return server.clients() == 0; }));
  EXPECT_EQ(server.stats().disconnected, 1u);
  // Publishing to nobody is fine.
  server.publish("frame", "{}");
  EXPECT_EQ(server.stats().clients_connected, 1u);
}

TEST(LiveFeed, TakesFramesOnlyForOpenPagesAndThrottled) {
  ViewServer server(options());
  int snapshots = 0;
  LiveFeed feed(server, {.max_fps = 5.0}, [&] {
    ++snapshots;
    return MapScene{};
  });
  EXPECT_FALSE(feed.wants_frame(0.0));  // nobody is looking
  EventClient page("127.0.0.1", server.port());
  ASSERT_TRUE(page.wait_until([](const auto& s) { return s.connected; }, kArrivalS));
  // The feed notices the page within its 100 ms wake-up and sends it the map.
  ASSERT_TRUE(page.wait_until([](const auto& s) { return s.maps >= 1; }, kArrivalS));
  ASSERT_TRUE(eventually([&] { return feed.wants_frame(1.0); }));
  system::FrameSnapshot s;
  s.index = 41;
  s.timestamp = 1.0;
  s.state = system::ObservedState::kTracking;
  s.world_from_cam = SE3(SO3(), Eigen::Vector3d(1.0, 2.0, 3.0));
  s.keypoints = {{10.0f, 20.0f}, {30.0f, 40.0f}};
  s.tracked = {1, 0};
  s.image = cv::Mat(48, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  feed.on_frame(std::move(s));
  // 5 frames/s: the next frame right away is not taken.
  EXPECT_FALSE(feed.wants_frame(1.01));
  ASSERT_TRUE(page.wait_until([](const auto& st) { return st.frames == 1; }, kArrivalS));
  const auto frame = nlohmann::json::parse(page.stats().last_frame);
  EXPECT_EQ(frame["index"], 41);
  EXPECT_EQ(frame["state"], "tracking");
  EXPECT_DOUBLE_EQ(frame["pose"][5].get<double>(), 2.0);
  EXPECT_EQ(frame["keypoints"].size(), 4u);
  EXPECT_EQ(frame["tracked"], "10");
  EXPECT_GT(page.stats().image_bytes, 100u);  // the page fetched the JPEG
  feed.stop();
  EXPECT_GE(snapshots, 1);
  EXPECT_EQ(feed.stats().frames_taken, 1u);
  EXPECT_EQ(feed.stats().frames_published, 1u);
}

}  // namespace
}  // namespace coloc::slam::view
