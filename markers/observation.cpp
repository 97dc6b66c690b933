#include "markers/observation.hpp"

namespace coloc::markers {

Eigen::Vector2d MarkerObservation::centre() const {
  return 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
}

double MarkerObservation::perimeter() const {
  double p = 0.0;
  for (int i = 0; i < 4; ++i)
    p += (corners[(i + 1) % 4] - corners[i]).norm();
  return p;
}

}  // namespace coloc::markers
