#pragma once
// Guidance during a registration session: is the data so far enough, which way to rotate next,
// and does a candidate registration add information. Frames as in handeye.hpp; rotation axes
// are reported in the device (controller) frame, the one a user can act on.
//
// Information measure: for the device-side motions A_ij = device_j_from_device_i of all pairs,
// H = blockdiag(sum theta^2 (I - a a^T), sum (R_A - I)^T (R_A - I)): the rotation constraint
// w_A = R_X w_B pins R_X across the axis a (strength theta^2) and the translation equations pin
// t_X through (R_A - I). Gains are log det(H + eps I) differences (nats).

#include <Eigen/Core>
#include <span>
#include <string>

#include "registration/handeye/handeye.hpp"

namespace coloc::registration::handeye {

struct SessionStatus {
  bool solvable = false;  // solve() would accept the data (>= 3 registrations, 2 axes, rotation)
  int registrations = 0;
  double axis_spread = 0.0;         // rad, as Conditioning::axis_spread
  Eigen::Vector3d weakest_axis;     // unit, device frame: rotate about this next
  double information_logdet = 0.0;  // log det(H + eps I)
  std::string advice;               // one sentence for the user
};

SessionStatus session_status(std::span<const Registration> registrations,
                             const Options& options = {});

struct NextRegistrationAdvice {
  bool adds_information = false;
  bool consistent = true;         // passes the angle-consistency test against the others
  double information_gain = 0.0;  // nats (log det increase)
  double nearest_rotation = 0.0;  // rad, rotation to the closest existing registration
  std::string advice;
};

// min_gain: the smallest log-det increase worth a registration (0.05 nats ~ 5 % more
// information volume).
NextRegistrationAdvice assess_next_registration(std::span<const Registration> so_far,
                                                const Registration& candidate,
                                                const Options& options = {},
                                                double min_gain = 0.05);

}  // namespace coloc::registration::handeye
