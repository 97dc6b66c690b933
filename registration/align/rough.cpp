#include "registration/align/rough.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "markers/sighting_fusion.hpp"
#include "slam/core/align.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::align {

namespace {

struct Pair {
  int id;
  const SlamMarker* slam;
  const markers::MapMarker* scan;
};

double residual(const Sim3& t, const Pair& p) {
  std::array<Eigen::Vector3d, 4> moved;
  for (int c = 0; c < 4; ++c)
    moved[c] = t * p.slam->corners[c];
  return markers::corner_rms(moved, p.scan->corners);
}

// Umeyama on the corners of the chosen markers; nullopt when degenerate.
std::optional<Sim3> fit(const std::vector<const Pair*>& chosen, bool scale) {
  std::vector<Eigen::Vector3d> src, dst;
  for (const Pair* p : chosen) {
    for (int c = 0; c < 4; ++c) {
      src.push_back(p->slam->corners[c]);
      dst.push_back(p->scan->corners[c]);
    }
  }
  const AlignmentResult r = align_points(src, dst, {.estimate_scale = scale});
  if (!r.usable) return std::nullopt;
  return r.dst_from_src;
}

struct Consensus {
  Sim3 transform;
  std::vector<const Pair*> inliers;
  double sum = 0.0;  // of the inliers' residuals
};

Consensus consensus(const Sim3& t, const std::vector<Pair>& pairs, double threshold) {
  Consensus c{t, {}, 0.0};
  for (const Pair& p : pairs) {
    const double r = residual(t, p);
    if (r < threshold) {
      c.inliers.push_back(&p);
      c.sum += r;
    }
  }
  return c;
}

bool better(const Consensus& a, const Consensus& b) {
  if (a.inliers.size() != b.inliers.size()) return a.inliers.size() > b.inliers.size();
  return a.sum < b.sum;
}

std::string id_list(const std::vector<int>& ids) {
  std::ostringstream s;
  for (std::size_t i = 0; i < ids.size(); ++i)
    s << (i ? ", " : "") << ids[i];
  return ids.empty() ? "none" : s.str();
}

// Leave-one-out centre residual of pairs[i] under the transform fitted to the markers of `set`
// other than it; -1 when fewer than two remain or the fit is degenerate. Centre distance: a
// marker seen from one keyframe has a poor orientation (IPPE on a small square), which corner
// distances would mistake for a displacement.
double loo(const std::vector<Pair>& pairs, const std::vector<const Pair*>& set, std::size_t i,
           bool scale) {
  std::vector<const Pair*> others;
  for (const Pair* p : set) {
    if (p != &pairs[i]) others.push_back(p);
  }
  if (others.size() < 2) return -1.0;
  const auto t = fit(others, scale);
  if (!t) return -1.0;
  return ((*t) * pairs[i].slam->centre() - pairs[i].scan->centre()).norm();
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Fills loo_residual and consistent of each marker (same order as `pairs`). Iterative, worst
// first, so that a moved marker does not mask itself by dragging the others' fits: the worst
// leave-one-out marker is inconsistent when its residual exceeds the gate computed from the
// remaining markers' own leave-one-out residuals (without it); then it leaves the set.
void leave_one_out(const std::vector<Pair>& pairs, const std::vector<const Pair*>& inliers,
                   const RoughOptions& o, std::vector<MarkerResidual>& out) {
  for (std::size_t i = 0; i < pairs.size(); ++i)
    out[i].loo_residual = loo(pairs, inliers, i, o.estimate_scale);
  std::vector<const Pair*> set = inliers;
  while (set.size() > 3) {
    std::size_t worst = pairs.size();
    for (const Pair* p : set) {
      const auto i = static_cast<std::size_t>(p - pairs.data());
      if (worst == pairs.size() || out[i].loo_residual > out[worst].loo_residual) worst = i;
    }
    std::vector<const Pair*> rest;
    for (const Pair* p : set) {
      if (p != &pairs[worst]) rest.push_back(p);
    }
    std::vector<double> values;
    for (const Pair* p : rest) {
      const double r =
          loo(pairs, rest, static_cast<std::size_t>(p - pairs.data()), o.estimate_scale);
      if (r >= 0.0) values.push_back(r);
    }
    const double gate = std::max(o.consistency_min, o.consistency_factor * median_of(values));
    if (!(out[worst].loo_residual > gate)) break;
    out[worst].consistent = false;
    set = std::move(rest);
  }
}

}  // namespace

void RoughOptions::check() const {
  if (!(inlier_threshold > 0.0))
    throw Error("must be positive (metres)", {.field = "inlier_threshold"});
  if (min_markers < 2) throw Error("must be >= 2", {.field = "min_markers"});
  if (!(consistency_min > 0.0))
    throw Error("must be positive (metres)", {.field = "consistency_min"});
  if (!(consistency_factor > 0.0)) throw Error("must be positive", {.field = "consistency_factor"});
  if (!(min_pair_distance >= 0.0))
    throw Error("must be >= 0 (metres)", {.field = "min_pair_distance"});
}

std::vector<int> RoughAlignment::inlier_ids() const {
  std::vector<int> ids;
  for (const MarkerResidual& m : markers) {
    if (m.inlier) ids.push_back(m.id);
  }
  return ids;
}

RoughAlignment rough_align(const SlamMarkers& slam, const markers::MarkerMap& scan,
                           const RoughOptions& o) {
  o.check();
  RoughAlignment out;
  std::vector<Pair> pairs;
  for (const auto& [id, m] : slam.markers) {
    const auto it = scan.markers.find(id);
    if (it == scan.markers.end()) {
      out.only_in_slam.push_back(id);
    } else {
      pairs.push_back({id, &m, &it->second});
    }
  }
  for (const auto& [id, m] : scan.markers) {
    if (!slam.markers.count(id)) out.only_in_scan.push_back(id);
  }
  const std::string where = "Seen in the map: " + describe_sightings(slam) + ". In the scan: ids " +
                            id_list([&] {
                              std::vector<int> v;
                              for (const auto& [id, m] : scan.markers)
                                v.push_back(id);
                              return v;
                            }()) +
                            ".";
  if (pairs.size() < static_cast<std::size_t>(o.min_markers)) {
    throw Error(std::to_string(pairs.size()) + " marker(s) common to the map and the scan, " +
                    std::to_string(o.min_markers) + " needed. " + where,
                {.field = "markers"});
  }

  Consensus best;
  bool have = false;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    for (std::size_t j = i + 1; j < pairs.size(); ++j) {
      const double apart = (pairs[i].slam->centre() - pairs[j].slam->centre()).norm();
      if (apart < o.min_pair_distance) continue;
      const auto t = fit({&pairs[i], &pairs[j]}, o.estimate_scale);
      if (!t) continue;
      Consensus c = consensus(*t, pairs, o.inlier_threshold);
      if (!have || better(c, best)) {
        best = std::move(c);
        have = true;
      }
    }
  }
  // Refit on the inliers until the set stops changing (a few rounds at most).
  for (int round = 0; have && round < 10; ++round) {
    const auto t = fit(best.inliers, o.estimate_scale);
    if (!t) break;
    Consensus c = consensus(*t, pairs, o.inlier_threshold);
    const bool same = c.inliers == best.inliers;
    if (c.inliers.size() < best.inliers.size()) break;
    best = std::move(c);
    if (same) break;
  }

  const Sim3 t = have ? best.transform : Sim3();
  const std::set<const Pair*> inlier_set(best.inliers.begin(), best.inliers.end());
  double sq = 0.0;
  for (const Pair& p : pairs) {
    MarkerResidual r{p.id, have ? residual(t, p) : -1.0, inlier_set.count(&p) > 0,
                     p.slam->keyframes.size()};
    if (r.inlier) sq += r.residual * r.residual;
    out.markers.push_back(r);
  }
  out.inliers = best.inliers.size();
  if (!have || out.inliers < static_cast<std::size_t>(o.min_markers)) {
    std::ostringstream s;
    s << "the markers are inconsistent: the best rigid alignment agrees with " << out.inliers
      << " of " << pairs.size() << " common markers within " << o.inlier_threshold << " m ("
      << o.min_markers << " needed). Residual per marker (m):";
    for (const MarkerResidual& r : out.markers)
      s << " id " << r.id << " " << std::round(r.residual * 1000) / 1000;
    s << ". " << where;
    throw Error(s.str(), {.field = "markers"});
  }
  leave_one_out(pairs, best.inliers, o, out.markers);
  out.scan_from_slam = t;
  out.rms = std::sqrt(sq / static_cast<double>(out.inliers));
  return out;
}

}  // namespace coloc::registration::align
