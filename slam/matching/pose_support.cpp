#include "slam/matching/pose_support.hpp"

namespace coloc::slam::matching {

int optimize_frame_pose(frame::Frame& frame, const map::Map& map,
                        const optim::PoseOptimizerOptions& options,
                        const optim::CentrePrior* prior) {
  const auto& g = frame.geometry();
  std::vector<optim::PoseObservation> obs;
  std::vector<std::size_t> index;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    frame.outlier[i] = 0;
    const map::MapPoint* p = frame.points[i].valid() ? map.point(frame.points[i]) : nullptr;
    if (!p) {
      frame.points[i] = MapPointId::invalid();
      continue;
    }
    optim::PoseObservation o;
    o.world = p->position;
    o.pixel = frame.pixel(i);
    o.u_right = frame.u_right[i];
    o.inv_sigma2 = 1.0 / g.level_sigma2[static_cast<std::size_t>(frame.level(i))];
    obs.push_back(o);
    index.push_back(i);
  }
  if (obs.size() < 3) return 0;
  const auto result = optim::optimize_pose(frame.cam_from_world, obs,
                                           {g.fx, g.fy, g.cx, g.cy, g.bf}, options, prior);
  frame.cam_from_world = result.cam_from_world;
  for (std::size_t k = 0; k < index.size(); ++k)
    frame.outlier[index[k]] = result.outlier[k];
  return result.inliers;
}

void drop_outliers(frame::Frame& frame) {
  for (std::size_t i = 0; i < frame.size(); ++i) {
    if (frame.outlier[i]) {
      frame.points[i] = MapPointId::invalid();
      frame.outlier[i] = 0;
    }
  }
}

}  // namespace coloc::slam::matching
