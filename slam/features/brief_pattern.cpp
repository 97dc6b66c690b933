#include "slam/features/brief_pattern.hpp"

#include <cmath>
#include <numbers>

namespace coloc::slam::features {
namespace {

// splitmix64: a tiny, well-mixed generator with a fixed definition (std:: distributions are
// implementation-defined, which would make the pattern differ between standard libraries).
std::uint64_t next_random(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Approximately Gaussian integer: sum of four uniforms on [-5, 5] (sigma ~ 6.3 px, close to the
// patch size / 5 that Calonder et al. found best for BRIEF's isotropic Gaussian sampling).
int gaussian_like(std::uint64_t& state) {
  int sum = 0;
  for (int i = 0; i < 4; ++i)
    sum += static_cast<int>(next_random(state) % 11) - 5;
  return sum;
}

struct Point {
  int x;
  int y;
};

Point sample_point(std::uint64_t& state) {
  constexpr int r2 = BriefPattern::kRadius * BriefPattern::kRadius;
  while (true) {
    const Point p{gaussian_like(state), gaussian_like(state)};
    if (p.x * p.x + p.y * p.y <= r2) return p;
  }
}

}  // namespace

BriefPattern::BriefPattern(std::uint64_t seed) {
  std::uint64_t state = seed;
  std::vector<Point> base;
  base.reserve(2 * kPairs);
  while (base.size() < 2 * kPairs) {
    const Point p = sample_point(state);
    const Point q = sample_point(state);
    if (p.x == q.x && p.y == q.y) continue;  // a pixel compared with itself carries no information
    base.push_back(p);
    base.push_back(q);
  }
  rotated_.resize(static_cast<std::size_t>(kAngleBins) * 2 * kPairs);
  for (int bin = 0; bin < kAngleBins; ++bin) {
    const double angle = 2.0 * std::numbers::pi * bin / kAngleBins;
    const double c = std::cos(angle);
    const double s = std::sin(angle);
    Offset* out = &rotated_[static_cast<std::size_t>(bin) * 2 * kPairs];
    for (std::size_t i = 0; i < base.size(); ++i) {
      const double x = base[i].x;
      const double y = base[i].y;
      // Rotation stays inside the disc of radius kRadius (+0.5 from rounding).
      out[i].dx = static_cast<std::int8_t>(std::lround(c * x - s * y));
      out[i].dy = static_cast<std::int8_t>(std::lround(s * x + c * y));
    }
  }
}

int BriefPattern::angle_bin(float angle) {
  const float turns = angle * static_cast<float>(kAngleBins / (2.0 * std::numbers::pi));
  const int bin = static_cast<int>(std::lround(turns)) % kAngleBins;
  return bin < 0 ? bin + kAngleBins : bin;
}

}  // namespace coloc::slam::features
