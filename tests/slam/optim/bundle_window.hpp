#pragma once
// A local BA window for the solver tests and the benchmark: keyframes walking past points, with
// stereo-like and monocular observations, wrong matches and rolling-shutter shears.
#include <cstdint>
#include <random>
#include <vector>

#include "slam/optim/bundle_adjustment.hpp"

namespace coloc::slam::optim {

// The solver tests' camera (fx, fy, cx, cy, bf).
inline const Intrinsics kTestK{520.0, 515.0, 320.0, 240.0, 40.0};

struct Window {
  BundleProblem problem;
  std::vector<SE3> truth;
};

struct WindowShape {
  int poses = 12;
  int fixed = 2;  // the first ones
  std::uint32_t points = 400;
  double seen = 0.7;  // chance that a keyframe sees a point
  std::uint32_t seed = 1;
};

// A window of keyframes walking and turning past points, the first ones fixed. Observations are
// stereo-like or monocular in turn, 0.5 px of noise, one in forty off by 20-40 px (wrong matches),
// each with its row's rolling-shutter shear; a few points are seen once only, monocularly (their
// depth is unobservable: the damping must hold them).
inline Window make_window(const WindowShape& shape) {
  std::mt19937 rng(shape.seed);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_real_distribution<double> xy(-2.0, 2.0), z(2.0, 6.0), wrong(20.0, 40.0);
  std::bernoulli_distribution sees(shape.seen), outlier(0.025), flip(0.5);
  Window w;
  for (int i = 0; i < shape.poses; ++i) {
    const SE3 truth(SO3::exp({0.01 * i, 0.05 * i, -0.01 * i}),
                    Eigen::Vector3d(-0.12 * i, 0.02 * i, 0.01 * i));
    w.truth.push_back(truth);
    const Vector6d off = (Vector6d() << 0.01 * noise(rng), 0.01 * noise(rng), 0.01 * noise(rng),
                          0.004 * noise(rng), 0.004 * noise(rng), 0.004 * noise(rng))
                             .finished();
    w.problem.poses.push_back({i < shape.fixed ? truth : SE3::exp(off) * truth, i < shape.fixed});
  }
  for (std::uint32_t j = 0; j < shape.points; ++j) {
    const Eigen::Vector3d world(xy(rng), xy(rng), z(rng));
    w.problem.points.push_back(world + 0.02 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    const bool once = j % 50 == 0;
    for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(shape.poses); ++i) {
      if (once ? i != 3 : !sees(rng)) continue;
      const Eigen::Vector3d pc = w.truth[i] * world;
      if (pc.z() < 0.5) continue;  // behind the camera, or too close
      BundleProblem::Observation o;
      o.pose = i;
      o.point = j;
      o.pixel = {kTestK.fx * pc.x() / pc.z() + kTestK.cx + noise(rng),
                 kTestK.fy * pc.y() / pc.z() + kTestK.cy + noise(rng)};
      if (outlier(rng)) o.pixel.x() += flip(rng) ? wrong(rng) : -wrong(rng);
      o.u_right = (once || (i + j) % 3 == 0) ? -1.0 : o.pixel.x() - kTestK.bf / pc.z();
      o.inv_sigma2 = (j % 4 == 0) ? 1.0 / 1.44 : 1.0;  // a coarser pyramid level
      o.shear = Eigen::Vector3d(0.3, -0.5, 0.1) * ((o.pixel.y() - 240.0) / 480.0);
      w.problem.observations.push_back(o);
    }
  }
  return w;
}

}  // namespace coloc::slam::optim
