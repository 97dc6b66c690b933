#include "registration/align/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "slam/core/error.hpp"

namespace coloc::registration::align {

namespace {

using Rng = std::mt19937_64;
constexpr double kDeg = M_PI / 180.0;
constexpr double kZMin = -1.2, kZMax = 1.6;  // wall band the points cover (metres)

double uniform(Rng& rng, double a, double b) {
  return std::uniform_real_distribution<double>(a, b)(rng);
}

double gauss(Rng& rng, double sigma) {
  return sigma > 0.0 ? std::normal_distribution<double>(0.0, sigma)(rng) : 0.0;
}

SO3 bend(const SyntheticRegistrationOptions& o, double x) {
  return SO3::exp(Eigen::Vector3d(0.0, 0.0, o.bend_deg_per_m * kDeg * x));
}

// world_from_cam of keyframe i: at (x, 0, 0) looking at the wall (+y), z up, with a little
// seeded yaw and pitch so that the views are not all parallel.
SE3 true_world_from_cam(const SyntheticRegistrationOptions& o, int i, Rng& rng) {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d::UnitX();   // camera x: right, along the walk
  r.col(1) = -Eigen::Vector3d::UnitZ();  // camera y: down
  r.col(2) = Eigen::Vector3d::UnitY();   // camera z: toward the wall
  const SO3 jitter = SO3::exp(Eigen::Vector3d(uniform(rng, -0.08, 0.08), uniform(rng, -0.12, 0.12),
                                              0.0));  // pitch, yaw (camera frame)
  return SE3(SO3::from_matrix(r) * jitter,
             Eigen::Vector3d(o.keyframe_spacing * i, 0.0, uniform(rng, -0.05, 0.05)));
}

std::array<Eigen::Vector3d, 4> marker_corners_at(const Eigen::Vector3d& c, double s) {
  const Eigen::Vector3d right = 0.5 * s * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d up = 0.5 * s * Eigen::Vector3d::UnitZ();
  return {c - right + up, c + right + up, c + right - up, c - right - up};
}

bool in_image(const Eigen::Vector2d& uv, double margin) {
  return uv.x() >= margin && uv.x() < 640.0 - margin && uv.y() >= margin && uv.y() < 480.0 - margin;
}

// The keypoints keyframe `cam_from_world` sees (true projections plus noise) with their depth;
// `which` gets the point index of each keypoint.
slam::frame::Frame observe_points(const SyntheticRegistrationOptions& o, int i,
                                  const SE3& cam_from_world,
                                  const std::vector<Eigen::Vector3d>& points,
                                  const std::shared_ptr<const slam::frame::FrameGeometry>& g,
                                  std::vector<std::size_t>& which, Rng& rng) {
  const double bf = g->bf;
  slam::features::OrbFeatures f;
  f.image_width = 640;
  f.image_height = 480;
  std::vector<float> depth, u_right;
  which.clear();
  for (std::size_t p = 0; p < points.size(); ++p) {
    const Eigen::Vector3d pc = cam_from_world * points[p];
    if (pc.z() < 0.3 || pc.z() > 8.0) continue;
    Eigen::Vector2d uv(525.0 * pc.x() / pc.z() + 319.5, 525.0 * pc.y() / pc.z() + 239.5);
    if (!in_image(uv, 2.0)) continue;
    uv += Eigen::Vector2d(gauss(rng, o.pixel_noise), gauss(rng, o.pixel_noise));
    slam::features::Keypoint k;
    k.x = k.ux = static_cast<float>(uv.x());
    k.y = k.uy = static_cast<float>(uv.y());
    f.keypoints.push_back(k);
    f.descriptors.push_back({rng(), rng(), rng(), rng()});
    const double d = pc.z() * (1.0 + gauss(rng, o.depth_noise));
    depth.push_back(static_cast<float>(d));
    u_right.push_back(static_cast<float>(uv.x() - bf / d));
    which.push_back(p);
  }
  return slam::frame::Frame(FrameId(static_cast<std::uint64_t>(i)), 0.5 * i, std::move(f),
                            std::move(depth), std::move(u_right), g);
}

// The markers keyframe `cam_from_world` sees whole (10 px inside the image), noisy corners.
std::vector<markers::MarkerObservation> observe_markers(const SyntheticRegistrationOptions& o,
                                                        const SE3& cam_from_world,
                                                        const SyntheticRegistration& s, Rng& rng) {
  std::vector<markers::MarkerObservation> out;
  for (const auto& [mid, m] : s.scan_markers.markers) {
    markers::MarkerObservation obs;
    obs.id = mid;
    obs.image_width = 640;
    obs.image_height = 480;
    bool visible = true;
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector3d pc = cam_from_world * m.corners[static_cast<std::size_t>(c)];
      const Eigen::Vector2d uv = project(Camera(s.camera), pc);
      visible = visible && pc.z() > 0.3 && in_image(uv, 10.0);
      obs.corners[static_cast<std::size_t>(c)] =
          uv + Eigen::Vector2d(gauss(rng, o.pixel_noise), gauss(rng, o.pixel_noise));
    }
    if (visible) out.push_back(obs);
  }
  return out;
}

// Wall points (returned) and markers (into `markers`), scan frame.
std::vector<Eigen::Vector3d> place_scene(const SyntheticRegistrationOptions& o, Rng& rng,
                                         markers::MarkerMap& markers) {
  std::vector<Eigen::Vector3d> points;
  const double area = (o.length + 2.0) * (kZMax - kZMin);
  const auto n_points = static_cast<std::size_t>(o.points_per_m2 * area);
  for (std::size_t i = 0; i < n_points; ++i) {
    points.emplace_back(uniform(rng, -1.0, o.length + 1.0),
                        o.wall_distance - uniform(rng, 0.0, o.wall_relief),
                        uniform(rng, kZMin, kZMax));
  }
  markers.dictionary = "synthetic";
  markers.frame = "scan";
  int id = 0;
  for (double x = 1.0; x < o.length; x += o.marker_spacing, ++id) {
    markers::MapMarker m;
    m.id = id;
    const Eigen::Vector3d c(x, o.wall_distance - 1e-3, id % 2 == 0 ? 0.1 : 0.6);
    m.corners = marker_corners_at(c, o.marker_size);
    m.edge_length = o.marker_size;
    m.sightings = 1;
    markers.markers.emplace(id, m);
  }
  return points;
}

}  // namespace

void SyntheticRegistrationOptions::check() const {
  if (!(length > 0.0)) throw Error("must be positive (metres)", {.field = "length"});
  if (!(keyframe_spacing > 0.0)) throw Error("must be positive", {.field = "keyframe_spacing"});
  if (!(wall_distance > 1.0)) throw Error("must be > 1 (metres)", {.field = "wall_distance"});
  if (!(wall_relief >= 0.0 && wall_relief < wall_distance - 0.5))
    throw Error("must be in [0, wall_distance - 0.5)", {.field = "wall_relief"});
  if (!(points_per_m2 > 0.0)) throw Error("must be positive", {.field = "points_per_m2"});
  if (!(marker_spacing > 0.0)) throw Error("must be positive", {.field = "marker_spacing"});
  if (!(marker_size > 0.0)) throw Error("must be positive", {.field = "marker_size"});
  if (!(pixel_noise >= 0.0) || !(depth_noise >= 0.0))
    throw Error("must be >= 0", {.field = "pixel_noise"});
}

Eigen::Vector3d drift_point(const SyntheticRegistrationOptions& o, const Eigen::Vector3d& p) {
  return o.slam_from_scan * (bend(o, p.x()) * p);
}

SyntheticRegistration make_synthetic_registration(const SyntheticRegistrationOptions& o) {
  o.check();
  Rng rng(o.seed);
  SyntheticRegistration s;
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.fx = s.camera.fy = 525.0;
  s.camera.cx = 319.5;
  s.camera.cy = 239.5;
  s.geometry = std::make_shared<slam::frame::FrameGeometry>(
      slam::frame::FrameGeometry::make(s.camera, 40.0, 3.0, {1.0f}));

  // Wall points and markers, scan frame.
  const std::vector<Eigen::Vector3d> points = place_scene(o, rng, s.scan_markers);

  // Keyframes: true observations, drifted poses.
  const int n_keyframes = static_cast<int>(std::floor(o.length / o.keyframe_spacing)) + 1;
  std::vector<std::vector<std::pair<std::size_t, std::uint32_t>>> seen(points.size());
  for (int i = 0; i < n_keyframes; ++i) {
    const SE3 world_from_cam = true_world_from_cam(o, i, rng);
    const SE3 cam_from_world = world_from_cam.inverse();
    slam::map::Keyframe kf;
    kf.id = s.map.next_keyframe_id();
    std::vector<std::size_t> which;
    kf.frame = observe_points(o, i, cam_from_world, points, s.geometry, which, rng);
    const SO3 r_drift = o.slam_from_scan.so3() * bend(o, world_from_cam.translation().x());
    const SE3 drifted(r_drift * world_from_cam.so3(), drift_point(o, world_from_cam.translation()));
    kf.frame.cam_from_world = drifted.inverse();
    kf.frame.has_pose = true;
    kf.markers = observe_markers(o, cam_from_world, s, rng);
    kf.marker_size = kf.markers.empty() ? 0.0 : o.marker_size;
    const KeyframeId kid = s.map.add_keyframe(std::move(kf)).id;
    s.true_cam_from_scan.emplace(kid, cam_from_world);
    for (std::size_t k = 0; k < which.size(); ++k)
      seen[which[k]].emplace_back(static_cast<std::size_t>(kid.value()),
                                  static_cast<std::uint32_t>(k));
  }
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (seen[p].size() < 2) continue;
    const auto& [first_kf, first_index] = seen[p].front();
    const MapPointId pid =
        s.map.add_point(drift_point(o, points[p]), KeyframeId(first_kf), first_index).id;
    for (std::size_t k = 1; k < seen[p].size(); ++k)
      s.map.add_observation(pid, KeyframeId(seen[p][k].first), seen[p][k].second);
    s.map.update_point(pid);
    s.true_points.emplace(pid, points[p]);
  }
  for (const auto& [kid, kf] : s.true_cam_from_scan)
    s.map.update_connections(kid);
  return s;
}

double keyframe_centre_rms(const SyntheticRegistration& scene, const slam::map::Map& map) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const auto& [id, kf] : map.keyframes()) {
    const auto it = scene.true_cam_from_scan.find(id);
    if (it == scene.true_cam_from_scan.end()) continue;
    sum += (kf.camera_centre() - it->second.inverse().translation()).squaredNorm();
    ++n;
  }
  return n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
}

render::PointCloud synthetic_scan_surface(const SyntheticRegistration& scene, double patch_size,
                                          double spacing, std::uint64_t seed) {
  if (!(spacing > 0.0 && patch_size >= spacing))
    throw Error("needs 0 < spacing <= patch_size", {.field = "spacing"});
  Rng rng(seed);
  std::vector<MapPointId> ids;
  for (const auto& [id, p] : scene.true_points)
    ids.push_back(id);
  std::sort(ids.begin(), ids.end());  // deterministic
  render::PointCloud cloud;
  cloud.splat_size = static_cast<float>(spacing);
  const int steps = static_cast<int>(std::lround(patch_size / spacing));
  for (MapPointId id : ids) {
    // Facing -y (the walk), turned about z and x by up to 60 degrees.
    const SO3 turn = SO3::exp(
        Eigen::Vector3d(uniform(rng, -60.0, 60.0) * kDeg, 0.0, uniform(rng, -60.0, 60.0) * kDeg));
    const Eigen::Vector3d a = turn * Eigen::Vector3d::UnitX();
    const Eigen::Vector3d b = turn * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d& c = scene.true_points.at(id);
    for (int i = 0; i <= steps; ++i) {
      for (int j = 0; j <= steps; ++j) {
        const Eigen::Vector3d p =
            c + (i * spacing - 0.5 * patch_size) * a + (j * spacing - 0.5 * patch_size) * b;
        cloud.points.push_back(p.cast<float>());
        cloud.colours.push_back({128, 128, 128});
      }
    }
  }
  return cloud;
}

KeyframeDepthSamples synthetic_depth_samples(const SyntheticRegistration& scene,
                                             const render::PointCloud& scan,
                                             std::size_t per_keyframe) {
  KeyframeDepthSamples out;
  for (const auto& [id, cam_from_scan] : scene.true_cam_from_scan) {
    std::vector<Eigen::Vector3d> seen;
    for (const Eigen::Vector3f& pf : scan.points) {
      const Eigen::Vector3d p = cam_from_scan * pf.cast<double>();
      if (p.z() < 0.3 || p.z() > 6.0) continue;
      if (in_image(scene.camera.project(p), 0.0)) seen.push_back(p);
    }
    std::vector<Eigen::Vector3d>& samples = out[id];
    const std::size_t step =
        std::max<std::size_t>(1, seen.size() / std::max<std::size_t>(1, per_keyframe));
    for (std::size_t i = 0; i < seen.size(); i += step)
      samples.push_back(seen[i]);
  }
  return out;
}

}  // namespace coloc::registration::align
