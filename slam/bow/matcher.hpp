#pragma once
// Descriptor matching between two images accelerated by the vocabulary's direct index
// (ORB-SLAM's SearchByBoW): a feature of image A is compared only with the features of image B
// that descend through the same vocabulary node. A match needs Hamming distance <= max_distance
// and must pass the ratio test against the second-best candidate; each feature of B keeps only
// its best match; finally a histogram of orientation differences (angle_a - angle_b) keeps the
// matches in its three fullest bins, since one rigid image motion rotates all features alike.

#include <cstdint>
#include <vector>

#include "slam/bow/bow_vector.hpp"
#include "slam/features/orb_extractor.hpp"

namespace coloc::slam::bow {

struct BowMatchOptions {
  int max_distance = 50;  // Hamming distance (ORB-SLAM's TH_LOW)
  double ratio = 0.75;    // best < ratio * second best
  bool check_orientation = true;
  int orientation_bins = 30;  // histogram bins over 2 pi

  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct FeatureMatch {
  std::uint32_t index_a = 0;  // into a's keypoints/descriptors
  std::uint32_t index_b = 0;
  int distance = 0;  // Hamming
};

// `fa` and `fb` must be the direct indices of `a` and `b` computed at the same level by the same
// vocabulary. Result sorted by index_a; one-to-one. Deterministic.
std::vector<FeatureMatch> match_by_bow(const features::OrbFeatures& a, const FeatureVector& fa,
                                       const features::OrbFeatures& b, const FeatureVector& fb,
                                       const BowMatchOptions& options = {});

// The orientation-consistency filter alone: keeps the matches whose rotation (angle_a -
// angle_b) falls in the three fullest of `bins` histogram bins (the 2nd and 3rd only when they
// hold at least a tenth of the fullest).
std::vector<FeatureMatch> filter_by_rotation(const features::OrbFeatures& a,
                                             const features::OrbFeatures& b,
                                             const std::vector<FeatureMatch>& matches, int bins);

}  // namespace coloc::slam::bow
