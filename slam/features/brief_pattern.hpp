#pragma once
// The sampling pattern of our steered BRIEF: 256 point pairs inside a disc, pre-rotated into
// kAngleBins orientations so a descriptor needs only table look-ups. Internal to the extractor.

#include <array>
#include <cstdint>
#include <vector>

namespace coloc::slam::features {

class BriefPattern {
 public:
  static constexpr int kPairs = 256;
  static constexpr int kAngleBins = 64;
  // Every test point lies within this radius (pixels) of the keypoint, at any rotation.
  static constexpr int kRadius = 13;

  // The pattern is a fixed function of `seed` computed with integer arithmetic only, so it is
  // the same on every platform.
  explicit BriefPattern(std::uint64_t seed = 0x0c01'0cb1'2e5eULL);

  struct Offset {
    std::int8_t dx;
    std::int8_t dy;
  };
  // The 2 * kPairs points (p0, q0, p1, q1, ...) of the pattern rotated by the angle of `bin`
  // (bin * 2 pi / kAngleBins, counter-clockwise in image coordinates: x right, y down).
  const Offset* rotated(int bin) const {
    return &rotated_[static_cast<std::size_t>(bin) * 2 * kPairs];
  }
  // Angle bin nearest to an angle in radians (any value).
  static int angle_bin(float angle);

 private:
  std::vector<Offset> rotated_;  // kAngleBins * 2 * kPairs
};

}  // namespace coloc::slam::features
