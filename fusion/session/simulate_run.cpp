// simulate_multi_user (simulate.hpp): the trials, the truth comparison and the prediction.

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "fusion/session/session.hpp"
#include "fusion/session/simulate.hpp"
#include "fusion/simulation.hpp"
#include "registration/handeye/simulate.hpp"

namespace coloc::fusion::session {

namespace he = registration::handeye;

namespace {

struct Accumulator {
  std::vector<double> values;
  void add(double v) { values.push_back(v); }
  double rms() const {
    double s = 0.0;
    for (const double v : values)
      s += v * v;
    return values.empty() ? 0.0 : std::sqrt(s / static_cast<double>(values.size()));
  }
  double p95() const {
    if (values.empty()) return 0.0;
    std::vector<double> v = values;
    const auto k = static_cast<std::ptrdiff_t>(0.95 * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + k, v.end());
    return v[static_cast<std::size_t>(k)];
  }
};

SE3 yaw(double angle, const Eigen::Vector3d& t = Eigen::Vector3d::Zero()) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ())), t);
}

Vector6d gaussian(std::mt19937& rng, double position_sigma, double rotation_sigma) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  xi << Eigen::Vector3d(n(rng), n(rng), n(rng)) * position_sigma,
      Eigen::Vector3d(n(rng), n(rng), n(rng)) * rotation_sigma;
  return xi;
}

SE3 noisy(const SE3& pose, std::mt19937& rng, double position_sigma, double rotation_sigma) {
  return pose * SE3::exp(gaussian(rng, position_sigma, rotation_sigma));
}

// The localizer's noise on a global pose (right perturbation; rotation global_sigma / 3 rad).
Vector6d global_noise(const MultiUserOptions& o, std::mt19937& rng) {
  return gaussian(rng, o.global_sigma, o.global_sigma / 3.0);
}

// Headset samples between two global poses of a drift-corrected system; 0: it gets none.
int global_every(const MultiUserOptions& o, const SystemModel& model) {
  if (!(model.global_rate > 0.0)) return 0;
  return std::max(1, static_cast<int>(std::lround(o.rate / model.global_rate)));
}

// The fusers of the session, and the filter the prediction linearizes.
FuserOptions session_fuser(const MultiUserOptions& o) {
  FuserOptions fuser;
  fuser.filter.gating = o.fuser_gating;
  return fuser;
}

SE3 walk_pose(const Trajectory& walk, double t) {
  if (walk.empty()) return simulated_head_pose(t);
  const double t0 = walk.front().timestamp;
  const double span = walk.back().timestamp - t0;
  const double at = span > 0.0 ? t0 + std::fmod(t, span) : t0;
  const auto it = std::lower_bound(walk.begin(), walk.end(), at,
                                   [](const StampedPose& p, double x) { return p.timestamp < x; });
  if (it == walk.begin()) return walk.front().world_from_cam;
  if (it == walk.end()) return walk.back().world_from_cam;
  const double span_ab = it->timestamp - (it - 1)->timestamp;
  const double s = span_ab > 0.0 ? (at - (it - 1)->timestamp) / span_ab : 0.0;
  return interpolate((it - 1)->world_from_cam, it->world_from_cam, s);
}

// Participant k's true head and hands at t: the walk, 9 s apart and 0.4 m aside per
// participant; participant 1's controller 0 is locked to participant 0's (the stability rig).
struct Truth {
  SE3 head;
  SE3 controllers[2];
};

Truth truth_of(const MultiUserOptions& o, int k, double t) {
  Truth truth;
  truth.head = walk_pose(o.walk, t + 9.0 * k) * yaw(0.0, Eigen::Vector3d(0.0, 0.4 * k, 0.0));
  for (int n = 0; n < 2; ++n) {
    const double swing = 0.3 * std::sin(1.7 * t + n);
    truth.controllers[n] =
        truth.head *
        SE3(Eigen::Quaterniond(Eigen::AngleAxisd(swing, Eigen::Vector3d::UnitY())),
            Eigen::Vector3d(0.35, n == 0 ? 0.2 : -0.2, -0.45 + 0.05 * std::sin(2.3 * t)));
  }
  if (k == 1) {
    const SE3 rig(Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX())),
                  Eigen::Vector3d(0.06, 0.01, -0.02));
    truth.controllers[0] = truth_of(o, 0, t).controllers[0] * rig;
  }
  return truth;
}

struct Member {
  SystemModel model;
  std::string id;
  SE3 world_from_vr0;
  Eigen::Vector3d drift_direction = Eigen::Vector3d::UnitX();
  he::CalibrationFile calibration;
  Matrix6d covariance = Matrix6d::Zero();
  double calibration_error = 0.0;
  int controllers = 2;
  bool drifts = false;

  SE3 world_from_vr(double t) const {
    if (!drifts) return world_from_vr0;
    return world_from_vr0 * yaw(model.yaw_drift * t, model.drift_speed * t * drift_direction);
  }
};

// Systems, placements and calibrations of one trial: each calibration is a hand-eye session
// (handeye::simulate, protocol noise) whose camera-frame error is carried into this world.
std::vector<Member> make_members(const MultiUserOptions& o, int trial, const SE3& world_from_camera,
                                 std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const SystemModel models[3] = {vive_model(), quest_model(), tablet_model()};
  std::vector<Member> members;
  for (int k = 0; k < o.participants; ++k) {
    Member m;
    m.model = models[k % 3];
    m.id = std::string(k % 3 == 0 ? "vive" : k % 3 == 1 ? "quest" : "tablet") + std::to_string(k);
    m.controllers = m.model.kind == ParticipantKind::kAr ? 0 : 2;
    m.drifts = o.drift && (m.model.drift_speed > 0.0 || m.model.yaw_drift > 0.0);
    m.world_from_vr0 = yaw(std::numbers::pi * u(rng), Eigen::Vector3d(5 * u(rng), 5 * u(rng), 0));
    const double heading = std::numbers::pi * u(rng);
    m.drift_direction = Eigen::Vector3d(std::cos(heading), std::sin(heading), 0.0);
    he::SimulationOptions so;
    so.num_registrations = o.registrations;
    so.seed = static_cast<std::uint64_t>(o.seed) * 100003u +
              static_cast<std::uint64_t>(trial) * 101u + static_cast<std::uint64_t>(k);
    const he::Simulation sim = he::simulate(so);
    he::Options ho;
    ho.noise = he::noise_model(so);
    const he::Summary s = he::solve(sim.registrations, ho);
    const SE3 error = sim.vr_from_camera.inverse() * s.vr_from_camera;  // estimate = truth * error
    const SE3 vr_from_camera = m.world_from_vr0.inverse() * world_from_camera;
    m.calibration = {s.device_from_marker, vr_from_camera * error, s.sigma};
    m.calibration_error = error.translation().norm();
    m.covariance =
        vr_from_camera_covariance(sim.registrations, s.used, s.device_from_marker, s.vr_from_camera,
                                  s.device_from_marker_covariance.value_or(Matrix6d::Zero()));
    members.push_back(std::move(m));
  }
  return members;
}

Session make_session(const std::vector<Member>& members, const SE3& world_from_camera,
                     const FuserOptions& fuser) {
  SessionConfig config;
  config.anchor.world_from_camera = world_from_camera;
  std::vector<he::CalibrationFile> calibrations;
  for (const Member& m : members) {
    ParticipantConfig p;
    p.id = m.id;
    p.kind = m.model.kind;
    p.system = m.model.name;
    p.calibration = "simulated/" + m.id + ".yaml";  // never read: calibrations are given
    p.controllers = m.controllers;
    p.drift_correction = m.model.global_rate > 0.0;
    config.participants.push_back(p);
    calibrations.push_back(m.calibration);
  }
  return Session(config, calibrations, fuser);
}

// A square root of a covariance (eigen-decomposition: semi-definite input is fine).
Matrix6d square_root(const Matrix6d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (covariance + covariance.transpose()));
  return eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
         eig.eigenvectors().transpose();
}

// A participant's predicted world-frame head error at the prediction times (2 s, 3 s, ...):
// published head = Exp(e) * true head * Exp(tracking noise), one path of e per realization.
using ErrorPaths = std::vector<std::vector<Vector6d>>;  // [realization][time]

constexpr int kRealizations = 50;

std::vector<double> prediction_times(const MultiUserOptions& o) {
  std::vector<double> times;
  for (double t = 2.0; t < o.duration; t += 1.0)
    times.push_back(t);
  return times;
}

// Calibration only: estimated vr_from_camera = truth * Exp(eps), eps ~ the calibration's
// covariance, so every head is seen through camera * Exp(-eps): e = Ad(world_from_camera) (-eps).
ErrorPaths calibration_error_paths(const Member& m, std::size_t times, const SE3& world_from_camera,
                                   std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Matrix6d root = square_root(m.covariance);
  ErrorPaths paths(kRealizations);
  for (std::vector<Vector6d>& path : paths) {
    Vector6d eps;
    for (int i = 0; i < 6; ++i)
      eps[i] = n(rng);
    path.assign(times, world_from_camera.adjoint() * -(root * eps));
  }
  return paths;
}

// Drift-corrected: the fuser's error, linearized. Its filter (drift_filter.hpp) averages the
// measured drifts D_k = global_k * calibrated_k^-1 = Exp(d_k) D(t_k), componentwise with one
// gain K_k for translation and quaternion, which to first order is a weighted mean of the left
// perturbations d_k = Ad(head_k) (global noise - tracking noise). The calibration's error is
// part of D and cancels. Between updates the true D moves by the system's drift; the filter
// lags it. The gains come from the fuser's own P recursion (Q, R of its options).
ErrorPaths fuser_error_paths(const MultiUserOptions& o, const Member& m, int k,
                             const std::vector<double>& times, const FuserOptions& fuser,
                             std::mt19937& rng) {
  const int every = global_every(o, m.model);
  const int steps = static_cast<int>(o.duration * o.rate);
  std::vector<double> at;
  std::vector<Matrix6d> adjoint;
  for (int i = 0; i < steps; i += every) {
    at.push_back(i / o.rate);
    adjoint.push_back(truth_of(o, k, at.back()).head.adjoint());
  }
  const auto moved = [&](double t0, double t1) {  // D(t1) D(t0)^-1, as a left perturbation
    return (m.world_from_vr(t1) * m.world_from_vr(t0).inverse()).log();
  };
  const double q = fuser.filter.process_noise, r = fuser.filter.measurement_noise;
  ErrorPaths paths(kRealizations);
  for (std::vector<Vector6d>& path : paths) {
    path.assign(times.size(), Vector6d::Zero());
    Vector6d e = Vector6d::Zero();
    double p = 0.0;
    std::size_t next = 0;
    for (std::size_t u = 0; u < at.size(); ++u) {
      // A head published at the update's time is placed before the global pose arrives.
      for (; next < times.size() && times[next] <= at[u]; ++next)
        path[next] = u == 0 ? e : Vector6d(e - moved(at[u - 1], times[next]));
      const Vector6d d = adjoint[u] * (global_noise(o, rng) - gaussian(rng, m.model.position_noise,
                                                                       m.model.rotation_noise));
      if (u == 0) {
        e = d;
        p = r;
        continue;
      }
      p += q;
      const double gain = p / (p + r);
      e = (1.0 - gain) * (e - moved(at[u - 1], at[u])) + gain * d;
      p *= 1.0 - gain;
    }
    for (; next < times.size(); ++next)
      path[next] = e - moved(at.back(), times[next]);
  }
  return paths;
}

ErrorPaths error_paths(const MultiUserOptions& o, const Member& m, int k,
                       const SE3& world_from_camera, std::mt19937& rng) {
  const std::vector<double> times = prediction_times(o);
  if (global_every(o, m.model) > 0) return fuser_error_paths(o, m, k, times, session_fuser(o), rng);
  return calibration_error_paths(m, times.size(), world_from_camera, rng);
}

// Mean squared relative-pose error (translation m^2, rotation rad^2) that the two participants'
// error models predict (calibration covariance, or the fuser's filtered global noise and drift
// lag), with both systems' tracking noise, over the walk at 1 Hz.
std::pair<double, double> predict_pair(const MultiUserOptions& o, const Member& a, int ka,
                                       const ErrorPaths& ea, const Member& b, int kb,
                                       const ErrorPaths& eb, std::mt19937& rng) {
  const std::vector<double> times = prediction_times(o);
  double position = 0.0, rotation = 0.0;
  int count = 0;
  for (std::size_t j = 0; j < times.size(); ++j) {
    const SE3 ta = truth_of(o, ka, times[j]).head, tb = truth_of(o, kb, times[j]).head;
    const SE3 truth = ta.inverse() * tb;
    for (std::size_t s = 0; s < ea.size(); ++s) {
      const SE3 ha = SE3::exp(ea[s][j]) * ta, hb = SE3::exp(eb[s][j]) * tb;
      const SE3 rel = noisy(ha, rng, a.model.position_noise, a.model.rotation_noise).inverse() *
                      noisy(hb, rng, b.model.position_noise, b.model.rotation_noise);
      position += std::pow(translation_distance(rel, truth), 2);
      rotation += std::pow(rotation_distance(rel, truth), 2);
      ++count;
    }
  }
  return {position / count, rotation / count};
}

struct Totals {
  std::vector<Accumulator> head_position, head_rotation, controller_position;
  std::vector<Accumulator> pair_position, pair_rotation;
  std::vector<double> pair_predicted_position, pair_predicted_rotation;  // sums of squares
  std::vector<double> calibration_error;
  std::vector<he::TimedPose> locked_a, locked_b;
  std::size_t published = 0;
};

PoseMessage message(double t, int sequence, const SE3& pose) {
  return PoseMessage::from_pose(t, sequence, 1, pose);
}

// Feeds participant k's sample i (head, controllers, global pose) to the session and scores
// what it publishes; returns the published head pose.
SE3 feed(const MultiUserOptions& o, const Member& m, int k, int i, Session& session,
         std::mt19937& rng, Totals& totals, bool record_locked) {
  const double t = i / o.rate;
  const Truth truth = truth_of(o, k, t);
  const SE3 vr_from_world = m.world_from_vr(t).inverse();
  std::vector<Output> out;
  session.push_head(m.id,
                    message(t, i,
                            noisy(vr_from_world * truth.head, rng, m.model.position_noise,
                                  m.model.rotation_noise)),
                    t, out);
  SE3 head = out.back().pose.pose();  // returned: not const, so it moves
  const bool scored = t >= 2.0;
  if (scored) {
    totals.head_position[k].add(translation_distance(head, truth.head));
    totals.head_rotation[k].add(rotation_distance(head, truth.head));
  }
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int n = 0; n < m.controllers; ++n) {
    SE3 reported = noisy(vr_from_world * truth.controllers[n], rng, m.model.position_noise,
                         m.model.rotation_noise);
    if (k == 1 && n == 1 && u(rng) < o.occluded_fraction) {
      // Occluded: the inside-out tracker guesses the controller's position.
      reported.translation() +=
          o.occluded_jump * (0.5 + u(rng)) *
          Eigen::Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5).normalized();
    }
    out.clear();
    session.push_controller(m.id, n, message(t, i, reported), t, out);
    if (scored)
      totals.controller_position[k].add(
          translation_distance(out.back().pose.pose(), truth.controllers[n]));
    if (record_locked && n == 0 && k < 2)
      (k == 0 ? totals.locked_a : totals.locked_b).push_back({t, reported});
  }
  const int every = global_every(o, m.model);
  if (every > 0 && i % every == 0)
    session.push_global(m.id, message(t, i, truth.head * SE3::exp(global_noise(o, rng))), t);
  return head;
}

void run_trial(const MultiUserOptions& o, int trial, Totals& totals) {
  std::mt19937 rng(o.seed * 7919u + static_cast<std::uint32_t>(trial));
  // The anchor camera on a tripod near the walk's start, 1.3 m up, looking along the walk.
  const SE3 world_from_camera =
      walk_pose(o.walk, 0.0) *
      SE3(Eigen::Quaterniond(Eigen::AngleAxisd(-std::numbers::pi / 2, Eigen::Vector3d::UnitY())),
          Eigen::Vector3d(1.0, 0.5, -0.3));
  const std::vector<Member> members = make_members(o, trial, world_from_camera, rng);
  Session session = make_session(members, world_from_camera, session_fuser(o));
  const int steps = static_cast<int>(o.duration * o.rate);
  const auto k_count = static_cast<int>(members.size());
  std::vector<SE3> heads(members.size());
  for (int i = 0; i < steps; ++i) {
    for (int k = 0; k < k_count; ++k)
      heads[k] = feed(o, members[k], k, i, session, rng, totals, trial == 0);
    if (i / o.rate < 2.0 || i % 3 != 0) continue;
    std::size_t pair = 0;
    for (int a = 0; a < k_count; ++a) {
      for (int b = a + 1; b < k_count; ++b, ++pair) {
        const SE3 truth =
            truth_of(o, a, i / o.rate).head.inverse() * truth_of(o, b, i / o.rate).head;
        const SE3 rel = heads[a].inverse() * heads[b];
        totals.pair_position[pair].add(translation_distance(rel, truth));
        totals.pair_rotation[pair].add(rotation_distance(rel, truth));
      }
    }
  }
  std::vector<ErrorPaths> paths;
  paths.reserve(static_cast<std::size_t>(k_count));
  for (int a = 0; a < k_count; ++a)
    paths.push_back(error_paths(o, members[a], a, world_from_camera, rng));
  std::size_t pair = 0;
  for (int a = 0; a < k_count; ++a) {
    totals.calibration_error[a] += members[a].calibration_error / o.trials;
    for (int b = a + 1; b < k_count; ++b, ++pair) {
      const auto [p, r] = predict_pair(o, members[a], a, paths[a], members[b], b, paths[b], rng);
      totals.pair_predicted_position[pair] += p / o.trials;
      totals.pair_predicted_rotation[pair] += r / o.trials;
    }
  }
  totals.published += session.stats().published;
}

StabilityRow stability_of(const Totals& totals, const SE3& vr_a_from_camera,
                          const SE3& vr_b_from_camera) {
  std::vector<SE3> a, b;
  for (std::size_t i = 0; i < std::min(totals.locked_a.size(), totals.locked_b.size()); ++i) {
    a.push_back(totals.locked_a[i].pose);
    b.push_back(totals.locked_b[i].pose);
  }
  return stability_row(a, b, vr_a_from_camera, vr_b_from_camera);
}

}  // namespace

MultiUserReport simulate_multi_user(const MultiUserOptions& o) {
  o.check();
  const auto k = static_cast<std::size_t>(o.participants);
  const std::size_t pairs = k * (k - 1) / 2;
  Totals totals;
  totals.head_position.resize(k);
  totals.head_rotation.resize(k);
  totals.controller_position.resize(k);
  totals.calibration_error.assign(k, 0.0);
  totals.pair_position.resize(pairs);
  totals.pair_rotation.resize(pairs);
  totals.pair_predicted_position.assign(pairs, 0.0);
  totals.pair_predicted_rotation.assign(pairs, 0.0);
  for (int trial = 0; trial < o.trials; ++trial) {
    run_trial(o, trial, totals);
  }
  // The stability table uses the first trial's two calibrations again (same seeds).
  std::mt19937 rng(static_cast<std::mt19937::result_type>(o.seed * 7919u));
  const SE3 world_from_camera =
      walk_pose(o.walk, 0.0) *
      SE3(Eigen::Quaterniond(Eigen::AngleAxisd(-std::numbers::pi / 2, Eigen::Vector3d::UnitY())),
          Eigen::Vector3d(1.0, 0.5, -0.3));
  const std::vector<Member> first = make_members(o, 0, world_from_camera, rng);
  MultiUserReport report;
  report.stability = stability_of(totals, first[0].calibration.vr_from_camera,
                                  first[1].calibration.vr_from_camera);
  report.published = totals.published;
  for (std::size_t i = 0; i < k; ++i) {
    UserError u;
    u.id = first[i].id;
    u.system = first[i].model.name;
    u.head_position_rms = totals.head_position[i].rms();
    u.head_position_p95 = totals.head_position[i].p95();
    u.head_rotation_rms = totals.head_rotation[i].rms();
    u.controller_position_rms = totals.controller_position[i].rms();
    u.controller_position_p95 = totals.controller_position[i].p95();
    u.calibration_error = totals.calibration_error[i];
    u.published = totals.head_position[i].values.size();
    report.users.push_back(u);
  }
  std::size_t pair = 0;
  for (std::size_t a = 0; a < k; ++a) {
    for (std::size_t b = a + 1; b < k; ++b, ++pair) {
      PairError p;
      p.a = first[a].id;
      p.b = first[b].id;
      p.measured_position_rms = totals.pair_position[pair].rms();
      p.measured_rotation_rms = totals.pair_rotation[pair].rms();
      p.predicted_position_rms = std::sqrt(totals.pair_predicted_position[pair]);
      p.predicted_rotation_rms = std::sqrt(totals.pair_predicted_rotation[pair]);
      p.calibration_limited = !first[a].drifts && !first[b].drifts;
      report.pairs.push_back(p);
    }
  }
  return report;
}

}  // namespace coloc::fusion::session
