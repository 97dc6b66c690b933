// OSC codec and transport. Transport tests use real UDP on loopback, with liblo-tools' oscsend
// and oscdump as independent peers; every wait is bounded.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "fusion/osc.hpp"
#include "fusion/osc_endpoint.hpp"
#include "fusion/osc_node.hpp"
#include "slam/core/error.hpp"
#include "tests/testing/data.hpp"

namespace coloc::fusion {
namespace {

using testing::ChildProcess;

PoseMessage sample_pose() {
  PoseMessage p;
  p.time = 1234.5678;
  p.sequence = 42;
  p.state = 1;
  p.position = {0.5, -1.25, 1.75};
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  return p;
}

void expect_same_pose(const PoseMessage& a, const PoseMessage& b) {
  EXPECT_DOUBLE_EQ(a.time, b.time);
  EXPECT_EQ(a.sequence, b.sequence);
  EXPECT_EQ(a.state, b.state);
  EXPECT_LT((a.position - b.position).norm(), 1e-6);  // float32 on the wire
  EXPECT_LT(a.orientation.angularDistance(b.orientation), 1e-6);
}

// A wait for something that is bound to happen (a datagram on loopback, another thread's work):
// only a stuck run reaches it, never a slow one (CI runs this on a busy 2-core machine).
constexpr int kArrivalMs = 60000;

// Bounded wait for a condition another thread makes true (a test helper, not library code).
template <typename Condition>
bool wait_for(Condition condition, int timeout_ms = kArrivalMs) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return condition();
}

int free_port() {
  return OscEndpoint().port();
}

std::vector<std::string> pose_args(const std::string& address, const PoseMessage& p) {
  const auto f = [](double v) {
    std::ostringstream s;
    s.precision(9);
    s << v;
    return s.str();
  };
  const Eigen::Quaterniond& q = p.orientation;
  return {address,
          std::string(kPoseTypes),
          f(p.time),
          std::to_string(p.sequence),
          std::to_string(p.state),
          f(p.position.x()),
          f(p.position.y()),
          f(p.position.z()),
          f(q.x()),
          f(q.y()),
          f(q.z()),
          f(q.w())};
}

TEST(OscCodec, PoseMessageRoundTrip) {
  const PoseMessage p = sample_pose();
  for (const bool bundle : {false, true}) {
    const auto bytes = encode_pose(kXrPoseAddress, p, bundle);
    const OscDecodeResult r = decode_packet(bytes.data(), bytes.size());
    ASSERT_EQ(r.error, OscError::kNone) << r.detail;
    ASSERT_EQ(r.messages.size(), 1u);
    EXPECT_EQ(r.messages[0].address, kXrPoseAddress);
    expect_same_pose(r.messages[0].pose, p);
  }
  EXPECT_EQ(encode_pose(kPoseAddress, p).size(), 68u);
}

// No non-finite number goes on the wire: a NaN pose is sent as lost (state 0, identity), with
// its sequence, and the endpoint counts it.
TEST(OscCodec, NonFinitePosesGoOutAsLostAndAreCounted) {
  for (int field = 0; field < 3; ++field) {
    PoseMessage p = sample_pose();
    (field == 0   ? p.position.y()
     : field == 1 ? p.orientation.x()
                  : p.time) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(finite_message(p));
    const auto bytes = encode_pose(kPoseAddress, p);
    const OscDecodeResult r = decode_packet(bytes.data(), bytes.size());
    ASSERT_EQ(r.error, OscError::kNone) << r.detail;  // finite, so the decoder takes it
    ASSERT_EQ(r.messages.size(), 1u);
    EXPECT_EQ(r.messages[0].pose.state, 0);
    EXPECT_EQ(r.messages[0].pose.sequence, p.sequence);
    EXPECT_EQ(r.messages[0].pose.position, Eigen::Vector3d::Zero());
  }
  OscEndpoint receiver;
  OscEndpoint sender;
  sender.add_target("osc.udp://127.0.0.1:" + std::to_string(receiver.port()));
  PoseMessage p = sample_pose();
  p.position.x() = std::numeric_limits<double>::infinity();
  ASSERT_EQ(sender.publish(kPoseAddress, p), 1u);
  EXPECT_EQ(sender.stats().non_finite, 1u);
  const auto got = receiver.receive(kArrivalMs);
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->messages.at(0).pose.state, 0);
  EXPECT_TRUE(got->messages.at(0).pose.position.allFinite());
}

TEST(OscCodec, GetPoseWithAndWithoutReplyPort) {
  auto bytes = encode_get_pose();
  OscDecodeResult r = decode_packet(bytes.data(), bytes.size());
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_EQ(r.messages[0].reply_port, 0);
  bytes = encode_get_pose(9123);
  r = decode_packet(bytes.data(), bytes.size());
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_EQ(r.messages[0].reply_port, 9123);
}

TEST(OscCodec, DecodesWhatOscsendWrites) {
  if (!testing::have_tool("oscsend")) GTEST_SKIP() << "oscsend (liblo-tools) not installed";
  const auto dir = coloc::testing::temp_dir("fusion_oscsend_file");
  const std::string file = (dir / "pose.osc").string();
  const PoseMessage p = sample_pose();
  std::vector<std::string> argv = {"oscsend", "file://" + file};
  for (const auto& a : pose_args(std::string(kPoseAddress), p))
    argv.push_back(a);
  ASSERT_EQ(testing::run(argv), 0);
  std::ifstream in(file, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  const OscDecodeResult r = decode_packet(bytes.data(), bytes.size());
  ASSERT_EQ(r.error, OscError::kNone) << r.detail;
  ASSERT_EQ(r.messages.size(), 1u);
  expect_same_pose(r.messages[0].pose, p);
  EXPECT_EQ(bytes, encode_pose(kPoseAddress, p));  // byte-identical to our encoder
}

TEST(OscCodec, MalformedPacketsAreErrorsNotCrashes) {
  const auto good = encode_pose(kPoseAddress, sample_pose());
  const auto decode = [](const std::vector<std::uint8_t>& b) {
    return decode_packet(b.data(), b.size()).error;
  };
  EXPECT_EQ(decode({}), OscError::kMalformed);
  EXPECT_EQ(decode({'/', 'a', 0}), OscError::kMalformed);                     // not 4-aligned
  EXPECT_EQ(decode(std::vector<std::uint8_t>(good.begin(), good.end() - 4)),  // truncated
            OscError::kMalformed);
  EXPECT_EQ(decode(std::vector<std::uint8_t>(2000, 0)), OscError::kOversized);
  std::vector<std::uint8_t> no_slash = good;
  no_slash[0] = 'x';
  EXPECT_EQ(decode(no_slash), OscError::kMalformed);

  PoseMessage p = sample_pose();
  auto unknown = encode_pose("/coloc/unknown", p);
  EXPECT_EQ(decode(unknown), OscError::kUnknownAddress);

  // A NaN from another sender (encode_pose itself never sends one): x's float, after the
  // address (12 bytes), the type tags (12) and time, sequence and state (16), made a NaN.
  std::vector<std::uint8_t> nan_x = encode_pose(kPoseAddress, p);
  ASSERT_GE(nan_x.size(), 44u);
  const std::uint8_t quiet_nan[4] = {0x7f, 0xc0, 0x00, 0x00};  // big-endian float32
  std::copy(std::begin(quiet_nan), std::end(quiet_nan), nan_x.begin() + 40);
  EXPECT_EQ(decode(nan_x), OscError::kInvalidValue);
  p.orientation.coeffs() *= 2.0;  // not a unit quaternion
  EXPECT_EQ(decode(encode_pose(kPoseAddress, p)), OscError::kInvalidValue);

  // Right address, wrong type tags: "hiifffffff" (an int64 where the time should be).
  std::vector<std::uint8_t> wrong = good;
  const auto tags = std::search(wrong.begin(), wrong.end(), kPoseTypes.begin(), kPoseTypes.end());
  ASSERT_NE(tags, wrong.end());
  *tags = 'h';
  EXPECT_EQ(decode(wrong), OscError::kWrongTypes);

  // A bundle whose element size overruns the packet.
  auto bundle = encode_pose(kPoseAddress, sample_pose(), true);
  bundle[19] = 0xFF;
  EXPECT_EQ(decode(bundle), OscError::kMalformed);
}

TEST(OscCodec, RandomMutationsNeverCrash) {
  std::mt19937 rng(1234);
  const auto good = encode_pose(kPoseAddress, sample_pose(), true);
  int decoded = 0;
  for (int i = 0; i < 20000; ++i) {
    std::vector<std::uint8_t> b = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < flips; ++k)
      b[rng() % b.size()] = static_cast<std::uint8_t>(rng());
    if (rng() % 4 == 0) b.resize(rng() % (b.size() + 1));
    const OscDecodeResult r = decode_packet(b.data(), b.size());
    if (r.error == OscError::kNone) {
      ++decoded;
      for (const OscMessage& m : r.messages)
        EXPECT_NEAR(m.pose.orientation.norm(), 1.0, 1e-9);
    } else {
      EXPECT_FALSE(r.detail.empty());
    }
  }
  EXPECT_GT(decoded, 0);  // flips in float payloads still decode
}

TEST(OscEndpoint, LoopbackAndMalformedCounters) {
  OscEndpoint receiver;
  OscEndpoint sender;
  sender.add_target("osc.udp://127.0.0.1:" + std::to_string(receiver.port()));
  const PoseMessage p = sample_pose();

  // Garbage first: counted and dropped, then the good message still arrives.
  const OscPeer to = parse_osc_url("osc.udp://localhost:" + std::to_string(receiver.port()));
  ASSERT_TRUE(sender.send_to(to, {1, 2, 3}));
  ASSERT_TRUE(sender.send_to(to, std::vector<std::uint8_t>(1500, '/')));
  ASSERT_TRUE(sender.send_to(to, encode_pose("/coloc/nope", p)));
  ASSERT_EQ(sender.publish(kPoseAddress, p), 1u);

  std::optional<OscPacket> got;
  for (int i = 0; i < 4 && !got; ++i)
    got = receiver.receive(kArrivalMs);
  ASSERT_TRUE(got.has_value());
  expect_same_pose(got->messages.at(0).pose, p);
  EXPECT_EQ(got->from.port, sender.port());
  const OscStats s = receiver.stats();
  EXPECT_EQ(s.packets, 4u);
  EXPECT_EQ(s.malformed, 1u);
  EXPECT_EQ(s.oversized, 1u);
  EXPECT_EQ(s.unknown_address, 1u);
  EXPECT_EQ(s.messages, 1u);
  EXPECT_NE(s.last_error.find("/coloc/nope"), std::string::npos);
  EXPECT_FALSE(receiver.receive(10).has_value());  // bounded timeout, nothing pending
}

TEST(OscEndpoint, BadOptionsAndUrlsAreErrors) {
  EXPECT_THROW(parse_osc_url("udp://127.0.0.1:9000"), Error);
  EXPECT_THROW(parse_osc_url("osc.udp://127.0.0.1"), Error);
  EXPECT_THROW(parse_osc_url("osc.udp://127.0.0.1:99999"), Error);
  EXPECT_THROW(parse_osc_url("osc.udp://127.0.0.1:9x"), Error);
  EXPECT_EQ(parse_osc_url("osc.udp://127.0.0.1:9000/").port, 9000);
  OscEndpointOptions bad;
  bad.port = 70000;
  EXPECT_THROW(OscEndpoint{bad}, Error);
  OscEndpoint taken;
  OscEndpointOptions same;
  same.port = taken.port();
  try {
    OscEndpoint second(same);
    FAIL() << "binding a used port must fail";
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "port");
  }
}

TEST(OscEndpoint, SubnetBroadcastNeedsAndUsesSoBroadcast) {
  OscEndpointOptions any;
  any.bind_address = "0.0.0.0";  // a broadcast is delivered to sockets bound to any address
  OscEndpoint receiver(any);
  const std::string url = "osc.udp://127.255.255.255:" + std::to_string(receiver.port());

  OscEndpoint plain;
  plain.add_target(url);
  EXPECT_EQ(plain.publish(kPoseAddress, sample_pose()), 0u);  // EACCES without SO_BROADCAST
  EXPECT_EQ(plain.stats().send_errors, 1u);

  OscEndpointOptions options;
  options.broadcast = true;
  OscEndpoint broadcaster(options);
  broadcaster.add_target(url);
  ASSERT_EQ(broadcaster.publish(kPoseAddress, sample_pose()), 1u);
  const auto got = receiver.receive(kArrivalMs);
  ASSERT_TRUE(got.has_value());
  expect_same_pose(got->messages.at(0).pose, sample_pose());
}

TEST(OscNodes, OscsendDrivesTheFusionNodeAndOscdumpReceivesFusedPoses) {
  if (!testing::have_tool("oscsend") || !testing::have_tool("oscdump")) {
    GTEST_SKIP() << "liblo-tools not installed";
  }
  const int dump_port = free_port();
  ChildProcess dump({"oscdump", "-L", std::to_string(dump_port)});

  FusionNodeOptions options;
  options.publish = {"osc.udp://127.0.0.1:" + std::to_string(dump_port)};
  FusionNode node(options);
  node.start();
  const std::string port = std::to_string(node.port());

  // Headset pose, then a global pose at the same instant 1 m further along x: D = +1 m in x.
  PoseMessage xr = sample_pose();
  xr.time = 10.0;
  xr.sequence = 1;
  PoseMessage global = xr;
  global.position.x() += 1.0;
  std::vector<std::string> argv = {"oscsend", "127.0.0.1", port};
  for (const auto& a : pose_args(std::string(kXrPoseAddress), xr))
    argv.push_back(a);
  ASSERT_EQ(testing::run(argv), 0);
  ASSERT_TRUE(wait_for([&] { return node.stats().fuser.xr_poses == 1; }));
  argv = {"oscsend", "127.0.0.1", port};
  for (const auto& a : pose_args(std::string(kPoseAddress), global))
    argv.push_back(a);
  ASSERT_EQ(testing::run(argv), 0);
  ASSERT_TRUE(wait_for([&] { return node.stats().fuser.initialized == 1; }));

  // Garbage from oscsend: right address, wrong types. Counted, the node keeps running.
  ASSERT_EQ(testing::run({"oscsend", "127.0.0.1", port, std::string(kXrPoseAddress), "s", "x"}), 0);
  ASSERT_TRUE(wait_for([&] { return node.stats().osc.wrong_types == 1; }));

  // Next headset poses come out fused, to oscdump (the first ones, sent before the global pose,
  // came out unfused with state 0). oscdump may start listening late: keep sending.
  // oscdump prints "<timetag> /coloc/fused_pose diifffffff <t> <seq> <state> <x> <y> <z> ...".
  std::string address, types;
  double t = 0, x = 0, y = 0, z = 0;
  int seq = 0, state = -1;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kArrivalMs);
  while (state != 1 && std::chrono::steady_clock::now() < deadline) {
    xr.time += 0.011;
    ++xr.sequence;
    node.handle({{}, {OscMessage{std::string(kXrPoseAddress), xr, 0}}});
    std::string line;
    while (state != 1 && dump.read_line(line, 30)) {
      std::istringstream fields(line);
      std::string timetag;
      fields >> timetag >> address >> types >> t >> seq >> state >> x >> y >> z;
    }
  }
  ASSERT_EQ(state, 1) << "oscdump printed no fused pose in tracking state";
  EXPECT_EQ(address, kFusedPoseAddress);
  EXPECT_EQ(types, kPoseTypes);
  EXPECT_NEAR(x, xr.position.x() + 1.0, 1e-4);
  EXPECT_NEAR(y, xr.position.y(), 1e-4);
  EXPECT_NEAR(z, xr.position.z(), 1e-4);

  // Out-of-order sequence numbers are dropped and counted.
  node.handle({{}, {OscMessage{std::string(kXrPoseAddress), xr, 0}}});
  EXPECT_EQ(node.stats().out_of_order, 1u);
  node.stop();
  EXPECT_FALSE(node.running());
}

TEST(OscNodes, PoseServerBroadcastAndOnDemand) {
  OscEndpoint subscriber;
  PoseServerOptions options;
  options.targets = {"osc.udp://127.0.0.1:" + std::to_string(subscriber.port())};
  PoseServer server(options);
  server.start();

  // Before any pose: a request is answered with state 0 (lost).
  OscEndpoint client;
  const OscPeer server_peer = parse_osc_url("osc.udp://127.0.0.1:" + std::to_string(server.port()));
  ASSERT_TRUE(client.send_to(server_peer, encode_get_pose()));
  auto reply = client.receive(kArrivalMs);
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->messages.at(0).pose.state, 0);

  // Broadcast mode: the subscriber gets each published pose.
  const PoseMessage p = sample_pose();
  server.publish(p);
  const auto pushed = subscriber.receive(kArrivalMs);
  ASSERT_TRUE(pushed.has_value());
  EXPECT_EQ(pushed->messages.at(0).address, kPoseAddress);
  expect_same_pose(pushed->messages.at(0).pose, p);

  // On-demand mode: the latest pose, sent back to the requester.
  ASSERT_TRUE(client.send_to(server_peer, encode_get_pose()));
  reply = client.receive(kArrivalMs);
  ASSERT_TRUE(reply.has_value());
  expect_same_pose(reply->messages.at(0).pose, p);
  EXPECT_TRUE(wait_for([&] { return server.requests_answered() == 2; }));

  // oscsend asks, naming a reply port where oscdump listens.
  if (testing::have_tool("oscsend") && testing::have_tool("oscdump")) {
    const int dump_port = free_port();
    ChildProcess dump({"oscdump", "-L", std::to_string(dump_port)});
    std::string line;
    bool seen = false;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kArrivalMs);
    while (!seen && std::chrono::steady_clock::now() < deadline) {
      ASSERT_EQ(testing::run({"oscsend", "127.0.0.1", std::to_string(server.port()),
                              std::string(kGetPoseAddress), "i", std::to_string(dump_port)}),
                0);
      seen = dump.read_line(line, 60) && line.find("/coloc/pose") != std::string::npos;
    }
    ASSERT_TRUE(seen);
    EXPECT_NE(line.find(" 42 1 "), std::string::npos) << line;  // sequence 42, state 1
  }
  server.stop();
}

TEST(OscNodes, BundlesTimetaggedWithTheExposureTimeArriveAsMessages) {
  OscEndpoint subscriber;
  PoseServerOptions options;
  options.bundles = true;
  options.targets = {"osc.udp://127.0.0.1:" + std::to_string(subscriber.port())};
  PoseServer server(options);
  PoseMessage p = sample_pose();
  p.time = 1.7e9 + 0.25;  // Unix seconds: the bundle's NTP timetag says the same instant
  server.publish(p);
  const auto got = subscriber.receive(kArrivalMs);
  ASSERT_TRUE(got.has_value());
  ASSERT_EQ(got->messages.size(), 1u);
  EXPECT_EQ(got->messages[0].address, kPoseAddress);
  expect_same_pose(got->messages[0].pose, p);
  const auto bytes = encode_pose(kPoseAddress, p, true);
  ASSERT_GE(bytes.size(), 16u);
  const std::uint32_t seconds = (std::uint32_t{bytes[8]} << 24) | (std::uint32_t{bytes[9]} << 16) |
                                (std::uint32_t{bytes[10]} << 8) | std::uint32_t{bytes[11]};
  EXPECT_EQ(seconds, 1700000000u + 2208988800u);  // NTP epoch 1900
  EXPECT_EQ(bytes[12], 0x40);                     // fraction 0.25 = 0x40000000
}

}  // namespace
}  // namespace coloc::fusion
