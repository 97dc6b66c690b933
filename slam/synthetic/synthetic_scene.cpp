#include "slam/synthetic/synthetic_scene.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "slam/core/error.hpp"

namespace coloc::slam::synthetic {

void SyntheticSceneOptions::check() const {
  if (frames < 1) throw Error("SyntheticSceneOptions.frames must be >= 1");
  if (!(fps > 0.0)) throw Error("SyntheticSceneOptions.fps must be > 0");
  if (width < 16 || height < 16) throw Error("SyntheticSceneOptions.width/height too small");
  if (!(fx > 0.0 && fy > 0.0)) throw Error("SyntheticSceneOptions.fx/fy must be > 0");
  if (!(hover_period_s > 0.0)) throw Error("SyntheticSceneOptions.hover_period_s must be > 0");
  if (!(room_max.array() > room_min.array()).all())
    throw Error("SyntheticSceneOptions.room_max must exceed room_min");
}

SyntheticRgbdScene::SyntheticRgbdScene(SyntheticSceneOptions options)
    : options_(std::move(options)) {
  options_.check();
}

SE3 SyntheticRgbdScene::world_from_cam(int index) const {
  const double t = index / options_.fps;
  const double a = options_.amplitude, r = options_.rotation_amplitude;
  if (options_.trajectory == SyntheticTrajectory::kHover) {
    // Incommensurate slow frequencies: the camera sweeps back and forth over one area.
    const double w = 2.0 * std::numbers::pi / options_.hover_period_s;
    const Eigen::Vector3d position(a * std::sin(w * t), 0.5 * a * std::sin(1.37 * w * t + 0.4),
                                   0.3 * a * std::sin(0.71 * w * t));
    const Eigen::Vector3d rotation(0.5 * r * std::sin(1.19 * w * t + 0.2), r * std::sin(w * t),
                                   0.3 * r * std::sin(0.83 * w * t));
    return SE3(SO3::exp(rotation), position);
  }
  const Eigen::Vector3d position(a * std::sin(1.3 * t), 0.4 * a * std::sin(2.1 * t + 0.3),
                                 0.6 * a * (1.0 - std::cos(0.9 * t)));
  const Eigen::Vector3d rotation(0.5 * r * std::sin(1.7 * t), r * std::sin(1.1 * t),
                                 0.3 * r * std::sin(0.7 * t));
  return SE3(SO3::exp(rotation), position);
}

namespace {

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finalizer
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

double SyntheticRgbdScene::texture(int face, double a, double b) const {
  // Random cells at three scales: their corners are the corners FAST finds.
  static constexpr double kScales[3] = {0.05, 0.13, 0.31};
  static constexpr double kWeights[3] = {0.45, 0.35, 0.2};
  double v = 0.0;
  for (int s = 0; s < 3; ++s) {
    const auto i = static_cast<std::int64_t>(std::floor(a / kScales[s]));
    const auto j = static_cast<std::int64_t>(std::floor(b / kScales[s]));
    std::uint64_t h = mix(options_.seed ^ mix(static_cast<std::uint64_t>(face * 7 + s)));
    h = mix(h ^ static_cast<std::uint64_t>(i));
    h = mix(h ^ static_cast<std::uint64_t>(j));
    v += kWeights[s] * static_cast<double>(h >> 11) / static_cast<double>(1ULL << 53);
  }
  return v;
}

SyntheticFrame SyntheticRgbdScene::frame(int index) const {
  if (index < 0 || index >= options_.frames)
    throw Error("SyntheticRgbdScene::frame: index out of range");
  SyntheticFrame f;
  f.timestamp = index / options_.fps;
  f.world_from_cam = world_from_cam(index);
  f.color.create(options_.height, options_.width, CV_8UC3);
  f.depth.create(options_.height, options_.width, CV_32FC1);
  const Eigen::Matrix3d r = f.world_from_cam.rotation();
  const Eigen::Vector3d o = f.world_from_cam.translation();
  constexpr int kSub = 2;  // 2x2 supersampling against aliasing
  for (int v = 0; v < options_.height; ++v) {
    for (int u = 0; u < options_.width; ++u) {
      double colour = 0.0, depth = 0.0;
      for (int sv = 0; sv < kSub; ++sv) {
        for (int su = 0; su < kSub; ++su) {
          const double pu = u + (su + 0.5) / kSub - 0.5, pv = v + (sv + 0.5) / kSub - 0.5;
          const Eigen::Vector3d ray_cam((pu - options_.cx) / options_.fx,
                                        (pv - options_.cy) / options_.fy, 1.0);
          const Eigen::Vector3d d = r * ray_cam;
          double best = std::numeric_limits<double>::infinity();
          int face = 0;
          for (int axis = 0; axis < 3; ++axis) {
            if (std::abs(d[axis]) < 1e-12) continue;
            const double wall = d[axis] > 0 ? options_.room_max[axis] : options_.room_min[axis];
            const double s = (wall - o[axis]) / d[axis];
            if (s > 0 && s < best) {
              best = s;
              face = 2 * axis + (d[axis] > 0 ? 1 : 0);
            }
          }
          const Eigen::Vector3d hit = o + best * d;
          const int axis = face / 2;
          colour += texture(face, hit[(axis + 1) % 3], hit[(axis + 2) % 3]);
          depth += best;  // ray_cam has z = 1, so the ray parameter is the depth
        }
      }
      colour /= kSub * kSub;
      depth /= kSub * kSub;
      const auto c = static_cast<unsigned char>(std::clamp(30.0 + 200.0 * colour, 0.0, 255.0));
      f.color.at<cv::Vec3b>(v, u) = cv::Vec3b(c, c, c);
      f.depth.at<float>(v, u) = static_cast<float>(depth);
    }
  }
  return f;
}

settings::Settings SyntheticRgbdScene::settings() const {
  settings::Settings s;
  PinholeCamera cam;
  cam.width = options_.width;
  cam.height = options_.height;
  cam.fx = options_.fx;
  cam.fy = options_.fy;
  cam.cx = options_.cx;
  cam.cy = options_.cy;
  s.camera = cam;
  s.fps = options_.fps;
  s.readout_time = 0.0;  // ray-cast: a global shutter
  settings::DepthSettings d;
  d.bf = 40.0;
  d.baseline = d.bf / options_.fx;
  d.th_depth = 40.0;
  d.close_depth = d.th_depth * d.baseline;
  d.depth_map_factor = 1.0;
  s.depth = d;
  return s;
}

}  // namespace coloc::slam::synthetic
