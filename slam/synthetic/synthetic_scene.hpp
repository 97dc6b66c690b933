#pragma once
// A seeded synthetic RGB-D scene for tests and demos (COLMAP's habit: the generator lives in
// the library). The camera moves inside a textured box room; each frame is ray-cast exactly:
// colour from a multi-scale random-cell texture on the walls (sharp cell corners give ORB
// features), depth in metres along the optical axis, and the true world_from_cam.
// Deterministic for a given seed. Pinhole camera without distortion.
#include <cstdint>
#include <opencv2/core/mat.hpp>

#include "slam/core/se3.hpp"
#include "slam/settings/settings.hpp"

namespace coloc::slam::synthetic {

// kWander: a Lissajous-like path over the room (frequencies about 1 rad/s).
// kHover: a slow oscillation around the start pose (period hover_period_s), so the camera
// keeps seeing the same area; with frequent keyframes these become redundant (culling tests).
enum class SyntheticTrajectory { kWander, kHover };

struct SyntheticSceneOptions {
  std::uint64_t seed = 7;
  int frames = 40;
  double fps = 30.0;
  int width = 640, height = 480;
  double fx = 525.0, fy = 525.0, cx = 319.5, cy = 239.5;
  Eigen::Vector3d room_min{-2.0, -1.5, -1.0};  // metres, world frame (camera starts at 0)
  Eigen::Vector3d room_max{2.0, 1.5, 3.0};
  double amplitude = 0.25;           // metres: translation amplitude of the trajectory
  double rotation_amplitude = 0.15;  // radians
  SyntheticTrajectory trajectory = SyntheticTrajectory::kWander;
  double hover_period_s = 4.0;  // kHover: seconds per oscillation of the main axis
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct SyntheticFrame {
  double timestamp = 0.0;
  cv::Mat color;  // CV_8UC3 BGR
  cv::Mat depth;  // CV_32FC1 metres
  SE3 world_from_cam;
};

class SyntheticRgbdScene {
 public:
  explicit SyntheticRgbdScene(SyntheticSceneOptions options = {});
  int size() const { return options_.frames; }
  SE3 world_from_cam(int index) const;
  SyntheticFrame frame(int index) const;
  // Settings as a camera YAML would give them (bf = 40 like TUM's, ThDepth 40).
  settings::Settings settings() const;

 private:
  double texture(int face, double a, double b) const;
  SyntheticSceneOptions options_;
};

}  // namespace coloc::slam::synthetic
