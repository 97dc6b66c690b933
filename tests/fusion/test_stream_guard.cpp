// Issue 17: no single OSC message can freeze a stream (StreamGuard and the fusion node), and no
// datagram reaches liblo before its layout is known to be complete (check_osc_message).

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "fusion/osc.hpp"
#include "fusion/osc_node.hpp"
#include "fusion/osc_wire.hpp"
#include "fusion/stream_guard.hpp"
#include "slam/core/error.hpp"

namespace coloc::fusion {
namespace {

std::vector<std::uint8_t> bytes(std::string_view s) {
  return {s.begin(), s.end()};
}

std::string check(const std::vector<std::uint8_t>& b) {
  return check_osc_message(b.data(), b.size());
}

TEST(OscWire, BlobTagWithoutBlobIsMalformedBeforeLiblo) {
  // The datagram that made liblo read past its buffer (valgrind, lo_validate_blob).
  const auto packet = bytes(std::string_view("/x\0\0,b\0\0", 8));
  EXPECT_NE(check(packet).find("cut off"), std::string::npos) << check(packet);
  const OscDecodeResult r = decode_packet(packet.data(), packet.size());
  EXPECT_EQ(r.error, OscError::kMalformed);
  EXPECT_NE(r.detail.find("byte 8"), std::string::npos) << r.detail;
}

TEST(OscWire, EveryArgumentTypeIsMeasuredAgainstTheDatagram) {
  // A complete message with every type liblo knows; each of its truncations must be refused.
  std::vector<std::uint8_t> m = bytes(std::string_view("/all\0\0\0\0,ifhdsbTFNI[]\0\0\0\0", 24));
  const auto add = [&m](std::initializer_list<std::uint8_t> b) { m.insert(m.end(), b); };
  add({0, 0, 0, 1});                          // i
  add({0x3f, 0x80, 0, 0});                    // f
  add({0, 0, 0, 0, 0, 0, 0, 2});              // h
  add({0x3f, 0xf0, 0, 0, 0, 0, 0, 0});        // d
  add({'a', 'b', 'c', 0});                    // s
  add({0, 0, 0, 5, 1, 2, 3, 4, 5, 0, 0, 0});  // b: 5 bytes + 3 padding
  EXPECT_EQ(check(m), "");
  for (std::size_t n = 0; n < m.size(); ++n) {
    const std::vector<std::uint8_t> cut(m.begin(), m.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_NE(check(cut), "") << "truncated to " << n << " bytes";
  }
  std::vector<std::uint8_t> extra = m;
  extra.insert(extra.end(), {0, 0, 0, 0});
  EXPECT_NE(check(extra).find("after the arguments"), std::string::npos);

  // A blob whose size field claims more than the datagram holds, and a huge one.
  std::vector<std::uint8_t> blob = bytes(std::string_view("/b\0\0,b\0\0\0\0\0\x10\1\2\3\4", 16));
  EXPECT_NE(check(blob).find("overruns"), std::string::npos);
  blob[8] = 0xFF;
  EXPECT_NE(check(blob).find("overruns"), std::string::npos);
  // Unterminated address / type tags, unknown tags.
  EXPECT_NE(check(bytes("/abc")), "");
  EXPECT_NE(check(bytes(std::string_view("/a\0\0,iii", 8))), "");
  EXPECT_NE(check(bytes(std::string_view("/a\0\0,q\0\0", 8))).find("unknown type tag"),
            std::string::npos);
  EXPECT_NE(check(bytes(std::string_view("/a\0\0", 4))).find("type tag string missing"),
            std::string::npos);
}

TEST(OscWire, EncodedMessagesPass) {
  PoseMessage p;
  p.time = 12.5;
  EXPECT_EQ(check(encode_pose(kPoseAddress, p)), "");
  EXPECT_EQ(check(encode_get_pose()), "");
  EXPECT_EQ(check(encode_get_pose(9000)), "");
}

TEST(StreamGuard, OneFarFutureMessageIsDroppedAndTheStreamGoesOn) {
  StreamGuard guard;
  double t = 100.0, now = 5000.0;
  std::int32_t seq = 1;
  ASSERT_EQ(guard.check(seq++, t, now), StreamVerdict::kAccepted);
  EXPECT_EQ(guard.check(seq++, 1e12, now + 0.011), StreamVerdict::kImplausible);
  for (int i = 0; i < 100; ++i) {
    t += 0.011;
    now += 0.011;
    EXPECT_EQ(guard.check(seq++, t, now), StreamVerdict::kAccepted) << i;
  }
}

TEST(StreamGuard, TimeMayLeadTheReceiverOnlyByTheTolerance) {
  StreamGuard guard({.max_time_lead = 0.5});
  ASSERT_EQ(guard.check(1, 10.0, 0.0), StreamVerdict::kAccepted);
  // 10 s later on the receiver's clock, a message 10.3 s later is fine; 11 s later is not.
  EXPECT_EQ(guard.check(2, 21.0, 10.0), StreamVerdict::kImplausible);
  EXPECT_EQ(guard.check(3, 20.3, 10.0), StreamVerdict::kAccepted);
  // Replays faster than real time: 33 ms of sender time per 5 ms of ours.
  double t = 20.3, now = 10.0;
  for (std::int32_t seq = 4; seq < 200; ++seq)
    EXPECT_EQ(guard.check(seq, t += 0.033, now += 0.005), StreamVerdict::kAccepted);
}

TEST(StreamGuard, DuplicatesAreStaleAndSequenceJumpsImplausible) {
  StreamGuard guard;
  ASSERT_EQ(guard.check(10, 1.0, 0.0), StreamVerdict::kAccepted);
  EXPECT_EQ(guard.check(10, 1.0, 0.0), StreamVerdict::kStale);
  EXPECT_EQ(guard.check(9, 0.99, 0.0), StreamVerdict::kStale);
  EXPECT_EQ(guard.check(5000, 1.01, 0.01), StreamVerdict::kImplausible);
  EXPECT_EQ(guard.check(11, 1.02, 0.02), StreamVerdict::kAccepted);
}

TEST(StreamGuard, AnAbsurdFirstMessageIsOutvotedByTheRealStream) {
  StreamGuardOptions options;
  StreamGuard guard(options);
  ASSERT_EQ(guard.check(7, 4e9, 0.0), StreamVerdict::kAccepted);  // nothing to compare with
  double t = 50.0;
  std::int32_t seq = 8;
  for (int i = 1; i < options.resync_after; ++i)
    EXPECT_EQ(guard.check(seq++, t += 0.011, 0.0), StreamVerdict::kImplausible);
  EXPECT_EQ(guard.check(seq++, t += 0.011, 0.0), StreamVerdict::kResynced);
  EXPECT_EQ(guard.check(seq++, t += 0.011, 0.0), StreamVerdict::kAccepted);
}

TEST(StreamGuard, RestartedSenderIsTakenBackAfterAFewMessages) {
  StreamGuard guard({.resync_after = 3});
  for (std::int32_t seq = 5000; seq < 5100; ++seq)
    ASSERT_NE(guard.check(seq, 1000.0 + seq * 0.01, 0.0), StreamVerdict::kImplausible);
  // The sender restarts: sequence and clock from zero.
  EXPECT_EQ(guard.check(0, 0.5, 1.0), StreamVerdict::kImplausible);
  EXPECT_EQ(guard.check(1, 0.51, 1.01), StreamVerdict::kImplausible);
  EXPECT_EQ(guard.check(2, 0.52, 1.02), StreamVerdict::kResynced);
  EXPECT_EQ(guard.check(3, 0.53, 1.03), StreamVerdict::kAccepted);
}

TEST(StreamGuard, OptionsAreChecked) {
  EXPECT_THROW(StreamGuard({.max_time_lead = 0.0}), Error);
  EXPECT_THROW(StreamGuard({.max_sequence_gap = 0}), Error);
  try {
    StreamGuard({.resync_after = 0});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.context().field, "StreamGuardOptions.resync_after");
  }
}

OscPacket xr_packet(double time, std::int32_t sequence, double received, double x = 0.0) {
  PoseMessage p;
  p.time = time;
  p.sequence = sequence;
  p.position.x() = x;
  return {{}, {OscMessage{std::string(kXrPoseAddress), p, 0}}, received};
}

OscPacket global_packet(double time, std::int32_t sequence, double received, double x) {
  PoseMessage p;
  p.time = time;
  p.sequence = sequence;
  p.position.x() = x;
  return {{}, {OscMessage{std::string(kPoseAddress), p, 0}}, received};
}

TEST(FusionNodeStreams, AFarFutureHeadsetPoseDoesNotFreezeTheFusedStream) {
  FusionNode node({});
  double t = 10.0, now = 300.0;
  std::int32_t seq = 1;
  node.handle(xr_packet(t, seq++, now));
  node.handle(global_packet(t, 1, now, 1.0));  // D = +1 m in x
  ASSERT_EQ(node.stats().fuser.initialized, 1u);
  node.handle(xr_packet(1e15, seq++, now + 0.011));  // the hostile message
  for (int i = 0; i < 50; ++i)
    node.handle(xr_packet(t += 0.011, seq++, now += 0.011, 0.001 * i));
  const FusionNodeStats s = node.stats();
  EXPECT_EQ(s.implausible, 1u);
  EXPECT_EQ(s.fuser.xr_poses, 51u);
  EXPECT_EQ(s.fuser.out_of_order, 0u);
  EXPECT_DOUBLE_EQ(node.latest().time, t);
  EXPECT_NEAR(node.latest().world_from_head.translation().x(), 1.0 + 0.049, 1e-9);
}

TEST(FusionNodeStreams, RestartedHeadsetAndLocalizerResumeFusion) {
  FusionNode node({});
  double now = 0.0;
  for (std::int32_t seq = 3000; seq < 3100; ++seq) {
    const double t = 500.0 + seq * 0.01;
    node.handle(xr_packet(t, seq, now += 0.01));
    node.handle(global_packet(t, seq, now, 1.0));
  }
  const std::uint64_t before = node.stats().fuser.xr_poses;
  // Both senders restart with clocks and sequence numbers from zero (within 1000 of nothing).
  const int resync = FusionNodeOptions{}.streams.resync_after;
  for (std::int32_t seq = 0; seq < 20; ++seq) {
    node.handle(xr_packet(seq * 0.01, seq, now += 0.01));
    node.handle(global_packet(seq * 0.01, seq, now, 1.0));
  }
  const FusionNodeStats s = node.stats();
  EXPECT_EQ(s.resyncs, 2u);
  EXPECT_EQ(s.fuser.xr_poses - before, static_cast<std::uint64_t>(20 - resync + 1));
  EXPECT_DOUBLE_EQ(node.latest().time, 0.19);
  EXPECT_EQ(node.latest().state, FusionState::kTracking);
  EXPECT_NEAR(node.latest().world_from_head.translation().x(), 1.0, 1e-6);
}

}  // namespace
}  // namespace coloc::fusion
