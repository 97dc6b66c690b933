#include "slam/bow/matcher.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "slam/core/error.hpp"

namespace coloc::slam::bow {

void BowMatchOptions::check() const {
  if (max_distance < 0 || max_distance > 256) {
    throw Error("invalid BoW match option: must be in [0, 256]", {.field = "max_distance"});
  }
  if (!(ratio > 0.0 && ratio <= 1.0)) {
    throw Error("invalid BoW match option: must be in (0, 1]", {.field = "ratio"});
  }
  if (orientation_bins < 1) {
    throw Error("invalid BoW match option: must be at least 1", {.field = "orientation_bins"});
  }
}

std::vector<FeatureMatch> filter_by_rotation(const features::OrbFeatures& a,
                                             const features::OrbFeatures& b,
                                             const std::vector<FeatureMatch>& matches, int bins) {
  if (matches.empty() || bins < 1) return matches;
  const double two_pi = 2.0 * std::numbers::pi;
  std::vector<int> bin_of(matches.size());
  std::vector<int> count(static_cast<std::size_t>(bins), 0);
  for (std::size_t i = 0; i < matches.size(); ++i) {
    double rotation = static_cast<double>(a.keypoints[matches[i].index_a].angle) -
                      static_cast<double>(b.keypoints[matches[i].index_b].angle);
    rotation -= two_pi * std::floor(rotation / two_pi);  // [0, 2 pi)
    const int bin = static_cast<int>(std::lround(rotation / two_pi * bins)) % bins;
    bin_of[i] = bin;
    ++count[static_cast<std::size_t>(bin)];
  }
  // The three fullest bins (lowest bin first on ties).
  std::array<int, 3> top = {-1, -1, -1};
  for (int bin = 0; bin < bins; ++bin) {
    const int c = count[static_cast<std::size_t>(bin)];
    for (std::size_t t = 0; t < top.size(); ++t) {
      if (top[t] < 0 || c > count[static_cast<std::size_t>(top[t])]) {
        for (std::size_t u = top.size() - 1; u > t; --u)
          top[u] = top[u - 1];
        top[t] = bin;
        break;
      }
    }
  }
  const int best = count[static_cast<std::size_t>(top[0])];
  auto kept_bin = [&](int bin) {
    for (std::size_t t = 0; t < top.size(); ++t) {
      if (top[t] != bin) continue;
      return t == 0 || 10 * count[static_cast<std::size_t>(bin)] >= best;
    }
    return false;
  };
  std::vector<FeatureMatch> kept;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (kept_bin(bin_of[i])) kept.push_back(matches[i]);
  }
  return kept;
}

std::vector<FeatureMatch> match_by_bow(const features::OrbFeatures& a, const FeatureVector& fa,
                                       const features::OrbFeatures& b, const FeatureVector& fb,
                                       const BowMatchOptions& options) {
  options.check();
  if (fa.level != fb.level) {
    throw Error("BoW matching: direct indices of different levels", {.field = "level"});
  }
  // best_for_b[j]: the best accepted match ending at feature j of b.
  std::vector<FeatureMatch> best_for_b(b.size(), FeatureMatch{0, 0, 257});
  auto ia = fa.entries.begin();
  auto ib = fb.entries.begin();
  while (ia != fa.entries.end() && ib != fb.entries.end()) {
    if (ia->node < ib->node) {
      ++ia;
      continue;
    }
    if (ib->node < ia->node) {
      ++ib;
      continue;
    }
    const bool valid = std::all_of(ia->features.begin(), ia->features.end(),
                                   [&](std::uint32_t i) { return i < a.size(); }) &&
                       std::all_of(ib->features.begin(), ib->features.end(),
                                   [&](std::uint32_t j) { return j < b.size(); });
    if (!valid) {
      throw Error("BoW matching: a direct index refers to a feature the image does not have",
                  {.field = "features"});
    }
    for (std::uint32_t i : ia->features) {
      features::NearestTwo nearest;
      for (std::uint32_t j : ib->features)
        nearest.offer(features::hamming_distance(a.descriptors[i], b.descriptors[j]), j);
      const int best = nearest.best, second = nearest.second;
      const auto best_j = static_cast<std::uint32_t>(nearest.index);
      if (best > options.max_distance) continue;
      if (static_cast<double>(best) >= options.ratio * static_cast<double>(second)) continue;
      FeatureMatch& current = best_for_b[best_j];
      if (best < current.distance || (best == current.distance && i < current.index_a)) {
        current = {i, best_j, best};
      }
    }
    ++ia;
    ++ib;
  }
  std::vector<FeatureMatch> matches;
  for (const FeatureMatch& m : best_for_b) {
    if (m.distance <= 256) matches.push_back(m);
  }
  std::sort(matches.begin(), matches.end(),
            [](const FeatureMatch& x, const FeatureMatch& y) { return x.index_a < y.index_a; });
  if (options.check_orientation) {
    matches = filter_by_rotation(a, b, matches, options.orientation_bins);
  }
  return matches;
}

}  // namespace coloc::slam::bow
