#pragma once
// Binary 256-bit descriptors (steered BRIEF, as ORB) and their Hamming distance.

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>

namespace coloc::slam::features {

// 256 bits stored as four 64-bit words; bit i of the descriptor is bit (i % 64) of word i / 64.
using Descriptor = std::array<std::uint64_t, 4>;

inline int hamming_distance(const Descriptor& a, const Descriptor& b) {
  return std::popcount(a[0] ^ b[0]) + std::popcount(a[1] ^ b[1]) + std::popcount(a[2] ^ b[2]) +
         std::popcount(a[3] ^ b[3]);
}

// The two smallest distances offered and the index of the smallest: what Lowe's ratio test
// needs. Distances are 0..256; 257 means "none yet".
struct NearestTwo {
  int best = 257;
  int second = 257;
  std::size_t index = 0;

  void offer(int distance, std::size_t i) {
    if (distance < best) {
      second = best;
      best = distance;
      index = i;
    } else if (distance < second) {
      second = distance;
    }
  }
};

inline bool descriptor_bit(const Descriptor& d, int i) {
  return ((d[i >> 6] >> (i & 63)) & 1U) != 0;
}

}  // namespace coloc::slam::features
