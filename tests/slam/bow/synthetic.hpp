#pragma once
// A seeded synthetic set of binary descriptors for vocabulary tests: `prototypes` random
// descriptors, and images made of noisy copies of them (a few bits flipped), so that a good
// vocabulary puts copies of one prototype into one word.

#include <cstdint>
#include <vector>

#include "slam/features/descriptor.hpp"

namespace coloc::slam::bow::testing {

class SplitMix {
 public:
  explicit SplitMix(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

 private:
  std::uint64_t state_;
};

inline features::Descriptor random_descriptor(SplitMix& rng) {
  return {rng.next(), rng.next(), rng.next(), rng.next()};
}

inline features::Descriptor flip_bits(features::Descriptor d, int bits, SplitMix& rng) {
  for (int i = 0; i < bits; ++i) {
    const auto bit = static_cast<int>(rng.next() % 256);
    d[static_cast<std::size_t>(bit / 64)] ^= std::uint64_t{1} << (bit % 64);
  }
  return d;
}

struct SyntheticSet {
  std::vector<features::Descriptor> prototypes;
  std::vector<std::vector<features::Descriptor>> images;
  std::vector<std::vector<int>> prototype_of;  // per image, per descriptor
};

inline SyntheticSet make_synthetic_set(std::uint64_t seed, int prototypes = 60, int images = 30,
                                       int per_image = 80, int noise_bits = 12) {
  SplitMix rng(seed);
  SyntheticSet set;
  for (int p = 0; p < prototypes; ++p)
    set.prototypes.push_back(random_descriptor(rng));
  for (int i = 0; i < images; ++i) {
    set.images.emplace_back();
    set.prototype_of.emplace_back();
    for (int k = 0; k < per_image; ++k) {
      const auto p = static_cast<int>(rng.next() % static_cast<std::uint64_t>(prototypes));
      set.images.back().push_back(
          flip_bits(set.prototypes[static_cast<std::size_t>(p)], noise_bits, rng));
      set.prototype_of.back().push_back(p);
    }
  }
  return set;
}

}  // namespace coloc::slam::bow::testing
