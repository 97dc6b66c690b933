#include "slam/map/inertial.hpp"

namespace coloc::slam::map {

GyroLink chain(const GyroLink& a_to_b, const GyroLink& b_to_c) {
  GyroLink out;
  out.recording = a_to_b.recording;
  out.next = b_to_c.next;
  out.cam_from_next = a_to_b.cam_from_next * b_to_c.cam_from_next;
  out.bias_jacobian =
      b_to_c.cam_from_next.inverse().matrix() * a_to_b.bias_jacobian + b_to_c.bias_jacobian;
  out.dt = a_to_b.dt + b_to_c.dt;
  return out;
}

}  // namespace coloc::slam::map
