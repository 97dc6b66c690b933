// The session's OSC messages: tagged and untagged poses, controllers, requests, bundles, and
// malformed input as counted error values.

#include <gtest/gtest.h>

#include <random>

#include "fusion/session/wire.hpp"

namespace coloc::fusion::session {
namespace {

PoseMessage sample() {
  PoseMessage p;
  p.time = 1234.5;
  p.sequence = 9;
  p.state = 1;
  p.position = {0.5, -1.25, 1.75};
  p.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  return p;
}

WireResult decode(const std::vector<std::uint8_t>& bytes) {
  return decode_session_packet(bytes.data(), bytes.size());
}

TEST(SessionWire, TaggedAndUntaggedPoses) {
  WireResult r = decode(encode_head(sample(), "vive"));
  ASSERT_EQ(r.error, OscError::kNone) << r.detail;
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_EQ(r.messages[0].kind, MessageKind::kHead);
  EXPECT_EQ(r.messages[0].participant, "vive");
  EXPECT_NEAR((r.messages[0].pose.position - sample().position).norm(), 0.0, 1e-6);
  EXPECT_EQ(r.messages[0].pose.sequence, 9);

  // The plain fusion message is valid as it is (no id: the receiving port decides).
  r = decode(encode_pose(kXrPoseAddress, sample()));
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_TRUE(r.messages[0].participant.empty());

  r = decode(encode_controller(sample(), 1, "quest"));
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_EQ(r.messages[0].kind, MessageKind::kController);
  EXPECT_EQ(r.messages[0].controller, 1);
  EXPECT_EQ(r.messages[0].participant, "quest");

  r = decode(encode_global(sample(), "quest"));
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_EQ(r.messages[0].kind, MessageKind::kGlobal);

  r = decode(encode_get("quest", 9003));
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_EQ(r.messages[0].kind, MessageKind::kGetPose);
  EXPECT_EQ(r.messages[0].participant, "quest");
  EXPECT_EQ(r.messages[0].reply_port, 9003);
  r = decode(encode_get("", 0));
  ASSERT_EQ(r.messages.size(), 1u);
  EXPECT_TRUE(r.messages[0].participant.empty());
}

TEST(SessionWire, BundlesCarrySeveralMessages) {
  // A bundle as the fusion encoder frames it, holding a tagged head pose.
  std::vector<std::uint8_t> bundle = encode_pose(kXrPoseAddress, sample(), true);
  const std::vector<std::uint8_t> tagged = encode_head(sample(), "vive");
  // Append a second element (size + bytes).
  for (int shift = 24; shift >= 0; shift -= 8)
    bundle.push_back(static_cast<std::uint8_t>(tagged.size() >> shift));
  bundle.insert(bundle.end(), tagged.begin(), tagged.end());
  const WireResult r = decode(bundle);
  ASSERT_EQ(r.error, OscError::kNone) << r.detail;
  ASSERT_EQ(r.messages.size(), 2u);
  EXPECT_EQ(r.messages[1].participant, "vive");
}

TEST(SessionWire, BadInputIsAnErrorValue) {
  WireStats stats;
  const auto feed = [&](const std::vector<std::uint8_t>& bytes) {
    const WireResult r = decode(bytes);
    count(stats, r);
    return r.error;
  };
  EXPECT_EQ(feed({1, 2, 3}), OscError::kMalformed);
  // A blob tag with no blob behind it: liblo would read past the datagram (issue 17).
  EXPECT_EQ(feed({'/', 'x', 0, 0, ',', 'b', 0, 0}), OscError::kMalformed);
  EXPECT_EQ(feed(std::vector<std::uint8_t>(2000, 0)), OscError::kOversized);
  EXPECT_EQ(feed(encode_pose("/coloc/somewhere", sample())), OscError::kUnknownAddress);
  std::vector<std::uint8_t> wrong = encode_get("x", 0);  // /coloc/get_pose "s": valid
  EXPECT_EQ(feed(wrong), OscError::kNone);
  PoseMessage bad = sample();
  bad.orientation.coeffs() *= 2.0;  // not unit
  EXPECT_EQ(feed(encode_head(bad, "vive")), OscError::kInvalidValue);
  bad = sample();
  bad.time = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(feed(encode_head(bad, "vive")), OscError::kInvalidValue);
  EXPECT_EQ(stats.packets, 7u);
  EXPECT_EQ(stats.malformed, 2u);
  EXPECT_EQ(stats.oversized, 1u);
  EXPECT_EQ(stats.unknown_address, 1u);
  EXPECT_EQ(stats.invalid_values, 2u);
  EXPECT_FALSE(stats.last_error.empty());

  // Random bytes and every truncation of a valid message: never a crash.
  std::mt19937 rng(3);
  const std::vector<std::uint8_t> good = encode_controller(sample(), 0, "vive");
  for (std::size_t n = 0; n < good.size(); ++n) {
    std::vector<std::uint8_t> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(n));
    EXPECT_NE(decode(cut).error, OscError::kNone);
  }
  for (int i = 0; i < 2000; ++i) {
    std::vector<std::uint8_t> noise = good;
    noise[rng() % noise.size()] = static_cast<std::uint8_t>(rng());
    decode(noise);
  }
}

}  // namespace
}  // namespace coloc::fusion::session
