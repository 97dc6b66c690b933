#include "markers/sighting_fusion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "slam/core/error.hpp"

namespace coloc::markers {
namespace {

using Corners = std::array<Eigen::Vector3d, 4>;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

// Coordinate-wise median of the chosen corner sets.
Corners median_corners(const std::vector<Corners>& sets) {
  Corners out;
  for (int c = 0; c < 4; ++c) {
    for (int k = 0; k < 3; ++k) {
      std::vector<double> v;
      for (const Corners& s : sets)
        v.push_back(s[c][k]);
      out[c][k] = median(v);
    }
  }
  return out;
}

// The candidate corner sets of a sighting: the best, and the alternative when ambiguous.
std::vector<const Corners*> candidates(const Sighting& s) {
  if (s.ambiguous) return {&s.corners, &s.alternative};
  return {&s.corners};
}

// Per sighting, the candidate that agrees with the others (see the header).
std::vector<Corners> choose_candidates(const std::vector<Sighting>& sightings, double truncate) {
  const Corners* seed = &sightings.front().corners;
  double best_score = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < sightings.size(); ++i) {
    for (const Corners* c : candidates(sightings[i])) {
      double score = 0.0;
      for (std::size_t j = 0; j < sightings.size(); ++j) {
        if (j == i) continue;
        double nearest = truncate;
        for (const Corners* o : candidates(sightings[j]))
          nearest = std::min(nearest, corner_rms(*c, *o));
        score += nearest;
      }
      // Ties (e.g. a lone sighting) go to the first candidate seen: the smaller-error one.
      if (score < best_score - 1e-12) {
        best_score = score;
        seed = c;
      }
    }
  }
  std::vector<Corners> chosen;
  for (const Sighting& s : sightings) {
    const Corners* pick = &s.corners;
    for (const Corners* c : candidates(s)) {
      if (corner_rms(*c, *seed) < corner_rms(*pick, *seed)) pick = c;
    }
    chosen.push_back(*pick);
  }
  return chosen;
}

}  // namespace

void FusionOptions::check() const {
  if (!(min_gate > 0.0)) throw Error("must be positive (metres)", {.field = "min_gate"});
  if (!(mad_factor > 0.0)) throw Error("must be positive", {.field = "mad_factor"});
  if (!(min_weight_distance > 0.0)) {
    throw Error("must be positive (metres)", {.field = "min_weight_distance"});
  }
}

double corner_rms(const Corners& a, const Corners& b) {
  double sum = 0.0;
  for (int c = 0; c < 4; ++c)
    sum += (a[c] - b[c]).squaredNorm();
  return std::sqrt(sum / 4.0);
}

MapMarker fuse_sightings(const std::vector<Sighting>& sightings, const FusionOptions& options) {
  options.check();
  if (sightings.empty()) throw Error("no sightings to fuse", {.field = "sightings"});
  const int id = sightings.front().id;
  for (const Sighting& s : sightings) {
    if (s.id != id) throw Error("sightings of different markers", {.field = "id"});
  }
  const std::vector<Corners> chosen = choose_candidates(sightings, 4.0 * options.min_gate);

  // Robust centre, gate from the spread of the distances to it.
  const Corners centre = median_corners(chosen);
  std::vector<double> dist;
  for (const Corners& c : chosen)
    dist.push_back(corner_rms(c, centre));
  const double med = median(dist);
  std::vector<double> deviations;
  for (double d : dist)
    deviations.push_back(std::abs(d - med));
  const double gate = std::max(options.min_gate, options.mad_factor * 1.4826 * median(deviations));
  // With a median-of-two (or any tie), keep at least the sighting nearest the centre.
  const double nearest = *std::min_element(dist.begin(), dist.end());

  MapMarker m;
  m.id = id;
  Corners sum{};
  for (auto& c : sum)
    c.setZero();
  double weight_sum = 0.0, edge_sum = 0.0;
  std::vector<std::size_t> inliers;
  for (std::size_t i = 0; i < chosen.size(); ++i) {
    if (dist[i] > gate && dist[i] > nearest) {
      ++m.rejected_sightings;
      continue;
    }
    const double r = std::max(sightings[i].distance, options.min_weight_distance);
    const double w = 1.0 / (r * r);
    for (int c = 0; c < 4; ++c)
      sum[c] += w * chosen[i][c];
    weight_sum += w;
    edge_sum += sightings[i].edge_length;
    inliers.push_back(i);
    if (sightings[i].ambiguous) ++m.ambiguous_sightings;
    m.images.push_back(sightings[i].image);
  }
  for (int c = 0; c < 4; ++c)
    m.corners[c] = sum[c] / weight_sum;
  m.sightings = static_cast<int>(inliers.size());
  m.edge_length = edge_sum / static_cast<double>(inliers.size());
  double sq = 0.0;
  for (std::size_t i : inliers)
    sq += std::pow(corner_rms(chosen[i], m.corners), 2);
  m.residual = std::sqrt(sq / static_cast<double>(inliers.size()));
  return m;
}

std::map<int, MapMarker> fuse_all(const std::vector<Sighting>& sightings,
                                  const FusionOptions& options) {
  std::map<int, std::vector<Sighting>> by_id;
  for (const Sighting& s : sightings)
    by_id[s.id].push_back(s);
  std::map<int, MapMarker> out;
  for (const auto& [id, group] : by_id)
    out.emplace(id, fuse_sightings(group, options));
  return out;
}

}  // namespace coloc::markers
