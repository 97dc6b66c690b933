#include "slam/mapdb/synthetic_map.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "slam/core/error.hpp"

namespace coloc::slam::mapdb {

void SyntheticMapOptions::check() const {
  if (keyframes < 1) throw Error("SyntheticMapOptions: keyframes < 1");
  if (keypoints < 1 || keypoints > 100000)
    throw Error("SyntheticMapOptions: keypoints not in 1..100000");
  if (track_length < 2) throw Error("SyntheticMapOptions: track_length < 2");
  if (!(matched_fraction >= 0.0 && matched_fraction <= 1.0))
    throw Error("SyntheticMapOptions: matched_fraction not in [0, 1]");
  if (!(depth_fraction >= 0.0 && depth_fraction <= 1.0))
    throw Error("SyntheticMapOptions: depth_fraction not in [0, 1]");
  if (marker_every < 0 || erase_every < 0 || loop_edges < 0)
    throw Error("SyntheticMapOptions: marker_every / erase_every / loop_edges negative");
  if (depth_factor < 0 || depth_factor > map::KeyframeDepth::kMaxFactor)
    throw Error("SyntheticMapOptions: depth_factor not in 0..64");
}

std::shared_ptr<const frame::FrameGeometry> synthetic_geometry() {
  PinholeCamera cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = cam.fy = 525.0;
  cam.cx = 319.5;
  cam.cy = 239.5;
  std::vector<float> scales;
  scales.reserve(8);
  for (int l = 0; l < 8; ++l)
    scales.push_back(static_cast<float>(std::pow(1.2, l)));
  return std::make_shared<frame::FrameGeometry>(frame::FrameGeometry::make(cam, 40.0, 3.0, scales));
}

namespace {

using Rng = std::mt19937_64;

double uniform(Rng& rng, double a, double b) {
  return std::uniform_real_distribution<double>(a, b)(rng);
}

frame::Frame random_frame(const SyntheticMapOptions& o, KeyframeId id,
                          const std::shared_ptr<const frame::FrameGeometry>& g, Rng& rng) {
  const auto n = static_cast<std::size_t>(o.keypoints);
  features::OrbFeatures f;
  f.image_width = 640;
  f.image_height = 480;
  std::vector<float> depth(n, -1.0f), u_right(n, -1.0f);
  for (std::size_t i = 0; i < n; ++i) {
    features::Keypoint k;
    k.ux = static_cast<float>(uniform(rng, 0.0, 640.0));
    k.uy = static_cast<float>(uniform(rng, 0.0, 480.0));
    k.x = k.ux + static_cast<float>(uniform(rng, -0.5, 0.5));  // as if undistorted
    k.y = k.uy + static_cast<float>(uniform(rng, -0.5, 0.5));
    k.angle = static_cast<float>(uniform(rng, 0.0, 6.283185307179586));
    k.response = static_cast<float>(uniform(rng, 7.0, 120.0));
    k.level = static_cast<int>(rng() % static_cast<std::uint64_t>(g->levels()));
    f.keypoints.push_back(k);
    f.descriptors.push_back({rng(), rng(), rng(), rng()});
    if (uniform(rng, 0.0, 1.0) < o.depth_fraction) {
      depth[i] = static_cast<float>(uniform(rng, 0.5, 6.0));
      u_right[i] = static_cast<float>(k.ux - g->bf / depth[i]);
    }
  }
  frame::Frame frame(FrameId(3 * id.value()), 0.1 * static_cast<double>(id.value()), std::move(f),
                     std::move(depth), std::move(u_right), g);
  const SO3 rotation = SO3::exp(Eigen::Vector3d(
      uniform(rng, -0.05, 0.05), uniform(rng, -0.05, 0.05), uniform(rng, -0.05, 0.05)));
  const Eigen::Vector3d centre(0.1 * static_cast<double>(id.value()), uniform(rng, -0.02, 0.02),
                               0.0);
  frame.cam_from_world = SE3(rotation, -(rotation * centre));
  frame.has_pose = true;
  return frame;
}

std::vector<markers::MarkerObservation> random_markers(Rng& rng) {
  std::vector<markers::MarkerObservation> out;
  for (int m = 0; m < 2; ++m) {
    markers::MarkerObservation o;
    o.id = static_cast<int>(rng() % 50);
    const Eigen::Vector2d c(uniform(rng, 80.0, 560.0), uniform(rng, 80.0, 400.0));
    const double s = uniform(rng, 15.0, 60.0);
    o.corners = {c + Eigen::Vector2d(-s, -s), c + Eigen::Vector2d(s, -s), c + Eigen::Vector2d(s, s),
                 c + Eigen::Vector2d(-s, s)};
    o.image_width = 640;
    o.image_height = 480;
    out.push_back(o);
  }
  return out;
}

struct Track {
  MapPointId point;
  int remaining;  // further keyframes that will observe it
};

// Continues the open tracks into keyframe `k` and starts new ones at its free keypoints.
void add_observations(map::Map& m, const SyntheticMapOptions& o, KeyframeId k,
                      std::vector<Track>& tracks, Rng& rng) {
  const map::Keyframe& kf = *m.keyframe(k);
  std::vector<std::uint32_t> free(kf.frame.size());
  std::iota(free.begin(), free.end(), 0u);
  std::shuffle(free.begin(), free.end(), rng);
  std::size_t next = 0;
  std::vector<Track> open;
  for (Track& t : tracks) {
    if (!m.point(t.point) || next >= free.size()) continue;
    m.add_observation(t.point, k, free[next++]);
    m.update_point(t.point);
    if (--t.remaining > 0) open.push_back(t);
  }
  const auto fresh = static_cast<std::size_t>(o.matched_fraction * o.keypoints / o.track_length);
  for (std::size_t i = 0; i < fresh && next < free.size(); ++i) {
    const std::uint32_t idx = free[next++];
    const map::Keyframe& kk = *m.keyframe(k);
    const Eigen::Vector3d p =
        kk.frame.has_depth(idx) ? kk.frame.unproject_world(idx)
                                : kk.frame.cam_from_world.inverse() *
                                      Eigen::Vector3d(uniform(rng, -1, 1), uniform(rng, -1, 1), 3);
    open.push_back({m.add_point(p, k, idx).id, o.track_length - 1});
  }
  tracks = std::move(open);
}

// Keyframes 0.1 s apart; the values are random but of the right size.
void add_imu(map::Map& m, const std::vector<KeyframeId>& ids, Rng& rng) {
  auto noise = [&](double scale) {
    return Eigen::Vector3d(uniform(rng, -scale, scale), uniform(rng, -scale, scale),
                           uniform(rng, -scale, scale));
  };
  const std::size_t second = ids.size() / 2;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const KeyframeId recording = ids[i < second ? 0 : second];
    map::Keyframe& kf = *m.keyframe(ids[i]);
    if (i % 7 != 3)
      kf.gravity =
          map::GravityWindow{recording, Eigen::Vector3d(0.0, -9.81, 0.0) + noise(0.5), noise(0.3)};
    if (i + 1 == ids.size() || i + 1 == second) continue;  // no link across recordings
    map::GyroLink link{recording, ids[i + 1], SO3::exp(noise(0.1)), {}, 0.1};
    link.bias_jacobian = -0.1 * Eigen::Matrix3d::Identity() + SO3::hat(noise(0.005));
    kf.gyro = link;
  }
}

map::KeyframeDepth random_depth(int factor, Rng& rng) {
  map::KeyframeDepth d;
  d.factor = factor;
  d.width = 640 / factor;
  d.height = 480 / factor;
  d.millimetres.resize(static_cast<std::size_t>(d.width) * static_cast<std::size_t>(d.height));
  std::uniform_int_distribution<int> mm(300, 6000);
  for (std::uint16_t& v : d.millimetres)
    v = uniform(rng, 0.0, 1.0) < 0.1 ? 0 : static_cast<std::uint16_t>(mm(rng));
  return d;
}

}  // namespace

map::Map make_synthetic_map(const SyntheticMapOptions& o,
                            const std::shared_ptr<const frame::FrameGeometry>& geometry,
                            const bow::Vocabulary* vocabulary,
                            const std::function<void(int, int)>& progress) {
  o.check();
  if (!geometry) throw Error("make_synthetic_map: no geometry");
  Rng rng(o.seed);
  map::Map m;
  std::vector<Track> tracks;
  for (int i = 0; i < o.keyframes; ++i) {
    map::Keyframe kf;
    kf.id = m.next_keyframe_id();
    kf.frame = random_frame(o, kf.id, geometry, rng);
    if (vocabulary)
      vocabulary->transform(kf.frame.features.descriptors, kf.frame.bow, kf.frame.feature_vector);
    if (o.marker_every > 0 && i % o.marker_every == 0) {
      kf.markers = random_markers(rng);
      kf.marker_size = 0.15;
    }
    if (o.depth_factor > 0 && i % 3 != 1) kf.depth = random_depth(o.depth_factor, rng);
    const KeyframeId id = m.add_keyframe(std::move(kf)).id;
    add_observations(m, o, id, tracks, rng);
    m.update_connections(id);
    if (progress) progress(i + 1, o.keyframes);
  }
  std::vector<KeyframeId> ids;
  for (const auto& [id, kf] : m.keyframes())
    ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  // Loop l ties the keyframes at positions 1 + 2 l and n - 1 - 3 l (the first one stays out;
  // loops that do not fit a small map are left out).
  for (int l = 0; l < o.loop_edges; ++l) {
    const std::size_t a = 1 + 2 * static_cast<std::size_t>(l);
    const std::size_t back = 3 * static_cast<std::size_t>(l) + 1;
    if (a >= ids.size() || back >= ids.size() || a == ids.size() - back) continue;
    const std::size_t b = ids.size() - back;
    m.keyframe(ids[a])->loop_edges.insert(ids[b]);
    m.keyframe(ids[b])->loop_edges.insert(ids[a]);
  }
  if (o.imu) add_imu(m, ids, rng);
  if (o.erase_every > 0) {
    for (std::size_t i = 1; i < ids.size(); ++i) {
      if (i % static_cast<std::size_t>(o.erase_every) == 0) m.erase_keyframe(ids[i]);
    }
  }
  return m;
}

}  // namespace coloc::slam::mapdb
