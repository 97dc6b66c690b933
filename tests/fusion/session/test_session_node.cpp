// The session on real UDP: liblo-tools' oscsend as the XR systems, oscdump as the renderer; the
// calibration file watcher (hot reload) and staleness on the node's own clock. Every wait is
// bounded.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include "../child_process.hpp"
#include "fusion/osc_endpoint.hpp"
#include "fusion/session/node.hpp"
#include "session_fixtures.hpp"
#include "tests/testing/data.hpp"

namespace coloc::fusion::session {
namespace {

using coloc::fusion::testing::ChildProcess;
using testing::pose;
using testing::wait_for;

int free_port() {
  return OscEndpoint().port();
}

std::vector<std::string> oscsend(int port, const std::string& address, const std::string& types,
                                 const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"oscsend", "127.0.0.1", std::to_string(port), address, types};
  argv.insert(argv.end(), args.begin(), args.end());
  return argv;
}

// time seq state x y z qx qy qz qw for a head at (x, y, z), no rotation.
std::vector<std::string> head_args(double time, int seq, double x, double y, double z) {
  std::ostringstream t;
  t.precision(12);
  t << time;
  return {t.str(),
          std::to_string(seq),
          "1",
          std::to_string(x),
          std::to_string(y),
          std::to_string(z),
          "0",
          "0",
          "0",
          "1"};
}

struct DumpLine {
  std::string address, types;
  double time = 0;
  int seq = 0, state = -1;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

// Reads oscdump lines until one for `address` (with state `state` if >= 0) arrives, waiting at
// most timeout_ms for each line.
bool read_until(ChildProcess& dump, const std::string& address, int state, DumpLine& got,
                int timeout_ms = testing::kArrivalMs) {
  std::string line;
  while (dump.read_line(line, timeout_ms)) {
    std::istringstream fields(line);
    std::string timetag;
    DumpLine d;
    fields >> timetag >> d.address >> d.types >> d.time >> d.seq >> d.state >> d.position.x() >>
        d.position.y() >> d.position.z();
    if (d.address == address && (state < 0 || d.state == state)) {
      got = d;
      return true;
    }
  }
  return false;
}

struct NodeTest : ::testing::Test {
  void SetUp() override {
    if (!coloc::fusion::testing::have_tool("oscsend") ||
        !coloc::fusion::testing::have_tool("oscdump")) {
      GTEST_SKIP() << "liblo-tools (oscsend, oscdump) not installed";
    }
  }
  std::filesystem::path dir = coloc::testing::temp_dir("session_node");
  // The anchor camera at the world origin; vive's camera at (0, 0, 1) of its space, quest's at
  // (1, 0, 0) of its space: world = vr - (0, 0, 1) for vive, vr - (1, 0, 0) for quest.
  SE3 vive_from_camera = pose(0.0, {0, 0, 1});
  SE3 quest_from_camera = pose(0.0, {1, 0, 0});
};

TEST_F(NodeTest, OscsendInOscdumpOutCountersForBadInput) {
  const int dump_port = free_port();
  const int vive_port = free_port();
  ChildProcess dump({"oscdump", "-L", std::to_string(dump_port)});
  SessionNodeOptions options;
  options.publish = {"osc.udp://127.0.0.1:" + std::to_string(dump_port)};
  SessionNode node(
      Session(testing::two_user_config(dir, SE3(), vive_from_camera, quest_from_camera, vive_port)),
      options);
  node.start();
  const int shared = node.port();

  // Bad input first: none of it may stop the node.
  using coloc::fusion::testing::run;
  ASSERT_EQ(run(oscsend(shared, "/coloc/xr_pose", "s", {"x"})), 0);    // wrong types
  ASSERT_EQ(run(oscsend(shared, "/coloc/elsewhere", "i", {"1"})), 0);  // unknown address
  auto ghost = head_args(1.0, 1, 0, 0, 0);
  ghost.push_back("ghost");
  ASSERT_EQ(run(oscsend(shared, "/coloc/xr_pose", "diifffffffs", ghost)), 0);  // unknown user
  ASSERT_EQ(run(oscsend(shared, "/coloc/xr_pose", "diifffffff", head_args(1, 1, 0, 0, 0))), 0);
  ASSERT_TRUE(wait_for([&] {
    const SessionNodeStats s = node.stats();
    return s.wire.wrong_types == 1 && s.wire.unknown_address == 1 &&
           s.session.unknown_participant == 1 && s.untagged == 1;
  }));

  // vive untagged on its own port, quest tagged on the shared port. oscdump may start late:
  // send until it prints.
  DumpLine got;
  bool seen = false;
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(testing::kArrivalMs);
  for (int i = 0; !seen && std::chrono::steady_clock::now() < deadline; ++i) {
    ASSERT_EQ(run(oscsend(vive_port, "/coloc/xr_pose", "diifffffff",
                          head_args(10.0 + i, 10 + i, 2.0, 0.5, 1.6))),
              0);
    // A short wait per try: a pose sent before oscdump listened is not coming.
    seen = read_until(dump, "/coloc/users/vive/head", 1, got, 500);
  }
  ASSERT_TRUE(seen) << "oscdump printed no vive head pose";
  EXPECT_EQ(got.types, "diifffffff");
  EXPECT_NEAR((got.position - Eigen::Vector3d(2.0, 0.5, 0.6)).norm(), 0.0, 1e-5);

  auto quest = head_args(5.0, 1, 1.0, 2.0, 1.5);
  quest.push_back("quest");
  ASSERT_EQ(run(oscsend(shared, "/coloc/xr_pose", "diifffffffs", quest)), 0);
  ASSERT_TRUE(read_until(dump, "/coloc/users/quest/head", 1, got));
  EXPECT_NEAR((got.position - Eigen::Vector3d(0.0, 2.0, 1.5)).norm(), 0.0, 1e-5);
  EXPECT_DOUBLE_EQ(got.time, 5.0);

  // On demand: quest's poses sent to oscdump's port.
  ASSERT_EQ(run(oscsend(shared, "/coloc/get_pose", "si", {"quest", std::to_string(dump_port)})), 0);
  ASSERT_TRUE(read_until(dump, "/coloc/users/quest/head", -1, got));
  ASSERT_TRUE(wait_for([&] { return node.stats().replies == 1; }));

  // Silence: both go stale after 0.5 s and oscdump hears state 0.
  ASSERT_TRUE(read_until(dump, "/coloc/users/quest/head", 0, got));
  EXPECT_NEAR((got.position - Eigen::Vector3d(0.0, 2.0, 1.5)).norm(), 0.0, 1e-5);
  node.stop();
  const SessionNodeStats s = node.stats();
  EXPECT_GE(s.session.stale_events, 2u);
  EXPECT_EQ(s.send_errors, 0u);
}

TEST_F(NodeTest, NewCalibrationFileReanchorsWhileRunning) {
  SessionNode node(
      Session(testing::two_user_config(dir, SE3(), vive_from_camera, quest_from_camera)),
      SessionNodeOptions{});
  node.start();
  // `coloc handeye solve --output b.yaml` again: the watcher reloads quest, not vive.
  testing::write_calibration(dir / "b.yaml", pose(0.0, {1.1, 0, 0}));
  ASSERT_TRUE(wait_for([&] { return !node.reloads().empty(); }));
  const ReloadReport r = node.reloads().front();
  EXPECT_EQ(r.id, "quest");
  EXPECT_TRUE(r.ok) << r.error;
  EXPECT_EQ(node.snapshot("quest").calibration_version, 1u);
  EXPECT_EQ(node.snapshot("vive").calibration_version, 0u);
  EXPECT_NEAR(node.snapshot("quest").world_from_vr.translation().x(), -1.1, 1e-12);

  // The same on request over OSC.
  ASSERT_EQ(
      coloc::fusion::testing::run(oscsend(node.port(), "/coloc/session/reload", "s", {"vive"})), 0);
  ASSERT_TRUE(wait_for([&] { return node.reloads().size() >= 2; }));
  EXPECT_EQ(node.snapshot("vive").calibration_version, 1u);
}

// Hot reload takes only a rigid calibration: a scaled rotation (which moved a participant by
// 35 cm) is a failed reload naming the key, and the participant keeps its calibration.
TEST_F(NodeTest, NonRigidCalibrationIsNotTakenByHotReload) {
  SessionNode node(
      Session(testing::two_user_config(dir, SE3(), vive_from_camera, quest_from_camera)),
      SessionNodeOptions{});
  node.start();
  {
    std::ofstream out(dir / "b.tmp");
    out << "device_from_marker: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n"
           "vr_from_camera: [1.3,0,0,1, 0,1.3,0,0, 0,0,1.3,0, 0,0,0,1]\n";
  }
  std::filesystem::rename(dir / "b.tmp", dir / "b.yaml");  // as `--output` writes it
  ASSERT_TRUE(wait_for([&] { return !node.reloads().empty(); }));
  const ReloadReport r = node.reloads().front();
  EXPECT_EQ(r.id, "quest");
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("vr_from_camera"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("not orthonormal"), std::string::npos) << r.error;
  EXPECT_EQ(node.snapshot("quest").calibration_version, 0u);
  EXPECT_NEAR(node.snapshot("quest").world_from_vr.translation().x(), -1.0, 1e-12);
}

}  // namespace
}  // namespace coloc::fusion::session
