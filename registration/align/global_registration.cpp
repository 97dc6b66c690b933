#include "registration/align/global_registration.hpp"

#include <pcl/features/fpfh_omp.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <unordered_map>

#include "registration/align/pcl_normals.hpp"
#include "slam/core/align.hpp"
#include "slam/core/error.hpp"
#include "slam/core/parallel.hpp"
#include "slam/core/timing.hpp"

namespace coloc::registration::align {
namespace {

using Cloud = NormalCloud;
using Features = pcl::PointCloud<pcl::FPFHSignature33>;

constexpr double kDeg = std::numbers::pi / 180.0;

// FPFH over `threads` threads: a third of the building's markerless registration on one thread
// (perf), and each point's descriptor is computed alone, so the result does not depend on it.
Features::Ptr fpfh(const Cloud::Ptr& cloud, double radius, int threads) {
  pcl::FPFHEstimationOMP<NormalPoint, NormalPoint, pcl::FPFHSignature33> estimation;
  estimation.setNumberOfThreads(static_cast<unsigned>(worker_count(threads)));
  estimation.setSearchMethod(std::make_shared<pcl::search::KdTree<NormalPoint>>());
  estimation.setRadiusSearch(radius);
  estimation.setInputCloud(cloud);
  estimation.setInputNormals(cloud);
  auto out = std::make_shared<Features>();
  estimation.compute(*out);
  return out;
}

Eigen::Vector3d xyz(const NormalPoint& p) {
  return {p.x, p.y, p.z};
}

// Nearest point within `reach` through a hash grid of cells `reach` wide (27 cells a query).
// ICP and scoring ask millions of such questions; PCL's k-d tree enters an OpenMP region per
// query, which costs more than the search on a busy 2-core machine.
class NearestGrid {
 public:
  NearestGrid(const Cloud& cloud, double reach) : cloud_(cloud), reach_(reach) {
    for (std::size_t i = 0; i < cloud.size(); ++i)
      cells_[key(cell_of(xyz(cloud[i])))].push_back(static_cast<int>(i));
  }
  // Index of the nearest point within reach, or -1; its squared distance in `distance2`.
  int nearest(const Eigen::Vector3d& q, double* distance2) const {
    const Eigen::Vector3i c = cell_of(q);
    int best = -1;
    double best_d2 = reach_ * reach_;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (const int i : it->second) {
            const double d2 = (xyz(cloud_[static_cast<std::size_t>(i)]) - q).squaredNorm();
            if (d2 <= best_d2) {
              best_d2 = d2;
              best = i;
            }
          }
        }
    if (distance2 != nullptr) *distance2 = best_d2;
    return best;
  }

 private:
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const {
    return (p / reach_).array().floor().cast<int>();
  }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    const auto part = [](int v) { return static_cast<std::uint64_t>(v + (1 << 20)) & 0x1fffffu; };
    return (part(c.x()) << 42) | (part(c.y()) << 21) | part(c.z());
  }
  const Cloud& cloud_;
  double reach_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

// Mutual nearest neighbours in descriptor space: (map index, scan index).
std::vector<std::pair<int, int>> mutual_matches(const Features& map, const Features& scan) {
  // Approximate search: exact nearest neighbours in 33 dimensions cost minutes on a room's
  // features, and a near-best descriptor serves RANSAC as well (the mutual check still holds).
  pcl::KdTreeFLANN<pcl::FPFHSignature33> scan_tree, map_tree;
  scan_tree.setEpsilon(2.0f);
  map_tree.setEpsilon(2.0f);
  scan_tree.setInputCloud(std::make_shared<Features>(scan));
  map_tree.setInputCloud(std::make_shared<Features>(map));
  std::vector<int> index(1);
  std::vector<float> distance(1);
  std::vector<std::pair<int, int>> matches;
  const auto finite = [](const pcl::FPFHSignature33& f) {
    return std::all_of(std::begin(f.histogram), std::end(f.histogram),
                       [](float x) { return std::isfinite(x); });
  };
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (!finite(map[i])) continue;  // too few neighbours for a descriptor
    if (scan_tree.nearestKSearch(map[i], 1, index, distance) != 1) continue;
    const int j = index[0];
    if (!finite(scan[static_cast<std::size_t>(j)])) continue;
    if (map_tree.nearestKSearch(scan[static_cast<std::size_t>(j)], 1, index, distance) != 1)
      continue;
    if (index[0] == static_cast<int>(i)) matches.emplace_back(static_cast<int>(i), j);
  }
  return matches;
}

// A rigid transform from matched points; with gravity, the yaw and translation only.
std::optional<SE3> propose(const std::vector<Eigen::Vector3d>& src,
                           const std::vector<Eigen::Vector3d>& dst, bool gravity) {
  if (gravity) {
    // Yaw from the horizontal direction between the first two points, translation from the
    // centroids.
    const Eigen::Vector2d a = (src[1] - src[0]).head<2>(), b = (dst[1] - dst[0]).head<2>();
    if (a.norm() < 1e-3 || b.norm() < 1e-3) return std::nullopt;
    const double yaw = std::atan2(b.y(), b.x()) - std::atan2(a.y(), a.x());
    const SO3 r = SO3::exp(Eigen::Vector3d(0.0, 0.0, yaw));
    Eigen::Vector3d cs = Eigen::Vector3d::Zero(), cd = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < src.size(); ++k) {
      cs += src[k];
      cd += dst[k];
    }
    const double n = static_cast<double>(src.size());
    return SE3(r, cd / n - r * (cs / n));
  }
  const AlignmentResult a = align_points(src, dst);
  if (!a.usable) return std::nullopt;
  return a.dst_from_src.to_se3();
}

bool distinct(const SE3& a, const SE3& b, const GlobalRegistrationOptions& o) {
  const SE3 d = a.inverse() * b;
  return d.translation().norm() > o.distinct_m || d.so3().log().norm() > o.distinct_deg * kDeg;
}

struct Scored {
  SE3 scan_from_map;
  double fitness = 0.0, rmse = 0.0;
  // Pearson correlation of the grey levels of the inlier pairs (map point, nearest scan point):
  // near 1 when the colours agree where the shapes do, near 0 for a symmetric room turned
  // round. Invariant to the camera's and the scanner's gain and offset. NaN when either cloud
  // has no colour to compare (a constant grey) or fewer than 50 pairs.
  double colour_correlation = std::numeric_limits<double>::quiet_NaN();
};

double grey(const NormalPoint& p) {
  return 0.299 * p.r + 0.587 * p.g + 0.114 * p.b;
}

// Fitness, inlier RMSE and colour correlation of `map` moved by `t` against `scan` through its
// grid (reach: the inlier distance).
Scored score(const Cloud& map, const Cloud& scan, const NearestGrid& grid, const SE3& t) {
  std::size_t inliers = 0;
  double sum = 0.0;
  double sa = 0.0, sb = 0.0, saa = 0.0, sbb = 0.0, sab = 0.0;
  for (const NormalPoint& p : map) {
    const Eigen::Vector3d q = t * xyz(p);
    if (!q.allFinite()) continue;
    double d2 = 0.0;
    const int nearest = grid.nearest(q, &d2);
    if (nearest < 0) continue;
    ++inliers;
    sum += d2;
    const double a = grey(p), b = grey(scan[static_cast<std::size_t>(nearest)]);
    sa += a;
    sb += b;
    saa += a * a;
    sbb += b * b;
    sab += a * b;
  }
  Scored s{t};
  s.fitness = map.empty() ? 0.0 : static_cast<double>(inliers) / static_cast<double>(map.size());
  s.rmse = inliers == 0 ? 0.0 : std::sqrt(sum / static_cast<double>(inliers));
  if (inliers >= 50) {
    const double n = static_cast<double>(inliers);
    const double var_a = saa / n - (sa / n) * (sa / n), var_b = sbb / n - (sb / n) * (sb / n);
    if (var_a > 1.0 && var_b > 1.0)  // grey levels that vary by more than one step
      s.colour_correlation = (sab / n - (sa / n) * (sb / n)) / std::sqrt(var_a * var_b);
  }
  return s;
}

// The clouds on each ICP level's grid, and the scan's nearest-point grid at the level's reach,
// computed once for every proposal refined on them.
struct Level {
  Cloud::Ptr map, scan;
  std::shared_ptr<const NearestGrid> grid;
};

std::vector<Level> icp_levels(const render::PointCloud& map_cloud,
                              const render::PointCloud& scan_cloud,
                              const GlobalRegistrationOptions& o) {
  std::vector<Level> levels;
  for (const double voxel : o.icp_voxels) {
    Level l{thinned_with_normals(map_cloud, voxel, o.normal_radius * voxel),
            thinned_with_normals(scan_cloud, voxel, o.normal_radius * voxel), nullptr};
    if (l.map->size() < 10 || l.scan->size() < 10) continue;
    l.grid = std::make_shared<const NearestGrid>(*l.scan, 3.0 * voxel);
    levels.push_back(l);
  }
  return levels;
}

// Point-to-plane ICP from `t`, coarse to fine (`levels_used` of them: where a candidate
// converges shows on the coarse level already; only the winner needs the fine one). Our own
// Gauss-Newton step with a small damping term: where the geometry leaves a direction free (a
// corridor's axis) the step along it is zero instead of the singular solve's NaN (PCL's
// point-to-plane ICP aborts there), and the verdict sees the freedom through its probes.
SE3 refine(const std::vector<Level>& levels, SE3 t, const GlobalRegistrationOptions& o,
           std::size_t levels_used) {
  for (std::size_t k = 0; k < std::min(levels.size(), levels_used); ++k) {
    const Cloud& map = *levels[k].map;
    const Cloud& scan = *levels[k].scan;
    const NearestGrid& grid = *levels[k].grid;
    for (int it = 0; it < o.icp_iterations; ++it) {
      Eigen::Matrix<double, 6, 6> h = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
      std::size_t used = 0;
      // A large map's points are taken evenly, at most icp_max_points per iteration: six
      // parameters need thousands of point-to-plane rows, not millions.
      const std::size_t stride =
          std::max<std::size_t>(1, map.size() / static_cast<std::size_t>(o.icp_max_points));
      for (std::size_t i = 0; i < map.size(); i += stride) {
        const NormalPoint& p = map[i];
        const Eigen::Vector3d q = t * xyz(p);
        const int nearest = grid.nearest(q, nullptr);
        if (nearest < 0) continue;
        const NormalPoint& s = scan[static_cast<std::size_t>(nearest)];
        const Eigen::Vector3d n(s.normal_x, s.normal_y, s.normal_z);
        const double r = n.dot(q - xyz(s));
        Eigen::Matrix<double, 6, 1> j;
        j << q.cross(n), n;  // d r / d(rotation, translation), left perturbation
        h += j * j.transpose();
        g += j * r;
        ++used;
      }
      if (used < 6) break;
      const double damping = 1e-6 * h.trace() / 6.0 + 1e-12;
      const Eigen::Matrix<double, 6, 1> step =
          -(h + damping * Eigen::Matrix<double, 6, 6>::Identity()).ldlt().solve(g);
      if (!step.allFinite()) break;
      t = SE3(SO3::exp(step.head<3>()), step.tail<3>()) * t;
      // Converged: a step of a tenth of a millimetre and 1e-5 rad (2 arc seconds) changes
      // neither the fitness nor the verdict.
      if (step.head<3>().norm() < 1e-5 && step.tail<3>().norm() < 1e-4) break;
    }
  }
  return t;
}

// Where a symmetric or repeated space would let the map sit as well: the winner moved by a
// metre along each axis and turned half a turn about the vertical (and, without gravity, about
// the horizontal axes), each about the map's centre in the scan.
std::vector<SE3> probes(const SE3& winner, const Cloud& map, bool gravity) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : map)
    centre += xyz(p);
  centre = winner * (centre / static_cast<double>(std::max<std::size_t>(map.size(), 1)));
  std::vector<SE3> out;
  for (int axis = 0; axis < 3; ++axis)
    for (const double step : {-1.0, 1.0})
      out.push_back(SE3(SO3(), step * Eigen::Vector3d::Unit(axis)) * winner);
  for (int axis = gravity ? 2 : 0; axis < 3; ++axis) {
    const SE3 turn(SO3::exp(std::numbers::pi * Eigen::Vector3d::Unit(axis)),
                   Eigen::Vector3d::Zero());
    out.push_back(SE3(SO3(), centre) * turn * SE3(SO3(), -centre) * winner);
  }
  return out;
}

// Whether `a`'s colours agree with the scan's clearly better than `b`'s (GlobalRegistrationOptions:
// min_colour_correlation, colour_margin).
bool better_coloured(const Scored& a, const Scored& b, const GlobalRegistrationOptions& o) {
  return std::isfinite(a.colour_correlation) && a.colour_correlation >= o.min_colour_correlation &&
         (!std::isfinite(b.colour_correlation) ||
          a.colour_correlation - b.colour_correlation >= o.colour_margin);
}

// The best of `refined` (sorted by fitness, best first) and its runner-up, both refined on
// every level and judged on the finest: at the coarse level's generous inlier distance a shift
// along a large wall still looks good; at the finest it does not, unless the space really
// repeats. The runner-up is the better of the best two far from the winner (none with a guess:
// the user vouches for the basin). Of two that fit the shape nearly alike, the one whose
// colours agree wins.
std::pair<Scored, std::optional<Scored>> judge_best(const std::vector<Scored>& refined,
                                                    const std::vector<Level>& levels,
                                                    const GlobalRegistrationOptions& o,
                                                    bool from_initial) {
  const Level& finest = levels.back();
  const NearestGrid fine_grid(*finest.scan, o.inlier_factor * o.icp_voxels[levels.size() - 1]);
  const auto judge = [&](const SE3& t) {
    return score(*finest.map, *finest.scan, fine_grid, refine(levels, t, o, levels.size()));
  };
  Scored winner = judge(refined.front().scan_from_map);
  std::vector<SE3> rivals;  // the best two far from the winner
  for (const Scored& s : refined) {
    if (from_initial || rivals.size() == 2) break;
    if (distinct(s.scan_from_map, winner.scan_from_map, o)) rivals.push_back(s.scan_from_map);
  }
  std::vector<Scored> judged(rivals.size());
  parallel_for(rivals.size(), o.threads, [&](std::size_t i) { judged[i] = judge(rivals[i]); });
  std::optional<Scored> runner_up;
  for (const Scored& rival : judged)
    if (distinct(rival.scan_from_map, winner.scan_from_map, o) &&
        (!runner_up || rival.fitness > runner_up->fitness))
      runner_up = rival;
  if (runner_up && runner_up->fitness >= o.ambiguity * winner.fitness &&
      better_coloured(*runner_up, winner, o))
    std::swap(winner, *runner_up);
  return {winner, runner_up};
}

// The global search: FPFH features of both clouds, their mutual matches, and RANSAC over
// samples of matches (2 with gravity: yaw and translation; else 3) whose pairwise distances agree.
// Returns the `hypotheses` most voted distinct transforms (scan_from_map), best first; counts
// the mutual matches in `matches_found`. Throws coloc::Error when the clouds share too few
// features or no transform is consistent.
std::vector<SE3> feature_proposals(const Cloud::Ptr& map, const Cloud::Ptr& scan,
                                   const GlobalRegistrationOptions& o, std::size_t& matches_found) {
  const double v = o.voxel_size;
  const double inlier = o.inlier_factor * v;
  const Features::Ptr map_features = fpfh(map, o.feature_radius * v, o.threads);
  const Features::Ptr scan_features = fpfh(scan, o.feature_radius * v, o.threads);
  const auto matches = mutual_matches(*map_features, *scan_features);
  matches_found = matches.size();
  const std::size_t sample = o.gravity ? 2 : 3;
  if (matches.size() < sample + 3)
    throw Error("the map and the scan share too few features (" + std::to_string(matches.size()) +
                    " mutual matches): too little overlap? Give --initial or use markers",
                {.field = "registration"});
  std::mt19937_64 rng(o.seed);
  std::uniform_int_distribution<std::size_t> pick(0, matches.size() - 1);
  struct Proposal {
    SE3 t;
    std::size_t votes;
  };
  std::vector<Proposal> best;  // distinct, most votes first
  std::vector<Eigen::Vector3d> src(sample), dst(sample);
  const int iterations = o.ransac_iterations > 0 ? o.ransac_iterations : o.gravity ? 10000 : 100000;
  for (int it = 0; it < iterations; ++it) {
    bool similar = true;
    for (std::size_t k = 0; k < sample; ++k) {
      const auto& [i, j] = matches[pick(rng)];
      src[k] = xyz((*map)[static_cast<std::size_t>(i)]);
      dst[k] = xyz((*scan)[static_cast<std::size_t>(j)]);
    }
    // Prerejection: a rigid motion keeps the sample's pairwise distances.
    for (std::size_t a = 0; a < sample && similar; ++a)
      for (std::size_t b = a + 1; b < sample && similar; ++b) {
        const double ls = (src[a] - src[b]).norm(), ld = (dst[a] - dst[b]).norm();
        similar =
            std::min(ls, ld) > 2.0 * v && std::min(ls, ld) / std::max(ls, ld) > o.edge_similarity;
      }
    if (!similar) continue;
    const std::optional<SE3> t = propose(src, dst, o.gravity);
    if (!t) continue;
    std::size_t votes = 0;
    for (const auto& [i, j] : matches)
      if ((*t * xyz((*map)[static_cast<std::size_t>(i)]) -
           xyz((*scan)[static_cast<std::size_t>(j)]))
              .norm() < inlier)
        ++votes;
    auto same = std::find_if(best.begin(), best.end(),
                             [&](const Proposal& p) { return !distinct(p.t, *t, o); });
    if (same != best.end()) {
      if (votes > same->votes) *same = {*t, votes};
    } else {
      best.push_back({*t, votes});
    }
    std::sort(best.begin(), best.end(),
              [](const Proposal& a, const Proposal& b) { return a.votes > b.votes; });
    if (best.size() > static_cast<std::size_t>(o.hypotheses)) best.resize(o.hypotheses);
  }
  if (best.empty())
    throw Error(
        "no consistent transform among the feature matches: too little overlap or a "
        "featureless scene? Give --initial or use markers",
        {.field = "registration"});
  std::vector<SE3> proposals(best.size());
  std::transform(best.begin(), best.end(), proposals.begin(),
                 [](const Proposal& p) { return p.t; });
  return proposals;
}

std::string figures(const Scored& s, double runner_up) {
  std::ostringstream out;
  out.precision(3);
  out << "fitness " << s.fitness << ", inlier RMSE " << s.rmse << " m, runner-up fitness "
      << runner_up << ", colour correlation " << s.colour_correlation;
  return out.str();
}

// The share of the scan's voxels that the map moved by `scan_from_map` reaches.
double overlap(const Cloud& map, const Cloud& scan, const SE3& scan_from_map, double reach) {
  Cloud moved = map;
  for (auto& p : moved) {
    const Eigen::Vector3d q = scan_from_map * xyz(p);
    p.x = static_cast<float>(q.x());
    p.y = static_cast<float>(q.y());
    p.z = static_cast<float>(q.z());
  }
  return score(scan, moved, NearestGrid(moved, reach), SE3()).fitness;
}

// Throws the named error when the winner is weak, its colours disagree, or a rival far from it
// fits nearly as well and the colours do not tell them apart; records in `report` whether the
// colours decided.
void verdict(const Scored& winner, const std::optional<Scored>& runner_up,
             const GlobalRegistrationOptions& o, GlobalRegistrationReport& report) {
  if (winner.fitness < o.min_fitness)
    throw Error("no transform puts the map on the scan (" + figures(winner, report.runner_up) +
                    "; needs fitness >= " + std::to_string(o.min_fitness) +
                    "): another building, or too little overlap? Give --initial or use markers",
                {.field = "registration"});
  if (std::isfinite(winner.colour_correlation) &&
      winner.colour_correlation < o.min_colour_agreement)
    throw Error("the shape fits but the colours do not (" + figures(winner, report.runner_up) +
                    "; needs a colour correlation >= " + std::to_string(o.min_colour_agreement) +
                    "): another place of the same shape? Give --initial or use markers",
                {.field = "registration"});
  // A rival that fits the shape nearly as well is told apart by the colours when they agree
  // clearly better at the winner (a symmetric room whose walls differ in what hangs on them).
  const bool colours_decide = !runner_up || better_coloured(winner, *runner_up, o);
  report.decided_by_colour = report.runner_up >= o.ambiguity * winner.fitness && colours_decide;
  if (report.runner_up >= o.ambiguity * winner.fitness && !colours_decide)
    throw Error("ambiguous: another transform, far from the best, fits the map nearly as well (" +
                    figures(winner, report.runner_up) +
                    ") and the colours do not tell them apart: a symmetric or repeated space. "
                    "Give --initial or use markers",
                {.field = "registration"});
}

}  // namespace

void GlobalRegistrationOptions::check() const {
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!positive(voxel_size))
    throw Error("must be a positive number of metres", {.field = "voxel_size"});
  if (!positive(normal_radius) || !positive(feature_radius) || !positive(inlier_factor))
    throw Error("radii and the inlier factor must be positive", {.field = "feature_radius"});
  if (ransac_iterations < 0)
    throw Error("must be >= 0 (0: by the sample size)", {.field = "ransac_iterations"});
  if (!(edge_similarity > 0.0 && edge_similarity < 1.0))
    throw Error("must be in (0, 1)", {.field = "edge_similarity"});
  if (hypotheses < 1) throw Error("must be >= 1", {.field = "hypotheses"});
  if (threads < 0) throw Error("must be >= 0 (0: one per core)", {.field = "threads"});
  if (icp_voxels.empty()) throw Error("at least one ICP level", {.field = "icp_voxels"});
  if (icp_max_points < 100) throw Error("must be >= 100", {.field = "icp_max_points"});
  for (double v : icp_voxels)
    if (!positive(v)) throw Error("must be positive", {.field = "icp_voxels"});
  if (!(min_fitness > 0.0 && min_fitness <= 1.0))
    throw Error("must be in (0, 1]", {.field = "min_fitness"});
  if (!(ambiguity > 0.0 && ambiguity <= 1.0))
    throw Error("must be in (0, 1]", {.field = "ambiguity"});
  if (!(min_colour_correlation > -1.0 && min_colour_correlation <= 1.0))
    throw Error("must be in (-1, 1]", {.field = "min_colour_correlation"});
  if (!(colour_margin > 0.0)) throw Error("must be positive", {.field = "colour_margin"});
  if (!(min_colour_agreement > -1.0 && min_colour_agreement <= min_colour_correlation))
    throw Error("must be in (-1, min_colour_correlation]", {.field = "min_colour_agreement"});
}

GlobalRegistrationReport register_clouds(const render::PointCloud& map_cloud,
                                         const render::PointCloud& scan_cloud,
                                         const GlobalRegistrationOptions& o,
                                         const std::optional<SE3>& initial) {
  o.check();
  Stopwatch watch;
  const double v = o.voxel_size;
  const Cloud::Ptr map = thinned_with_normals(map_cloud, v, o.normal_radius * v);
  const Cloud::Ptr scan = thinned_with_normals(scan_cloud, v, o.normal_radius * v);
  if (map->size() < 30 || scan->size() < 30)
    throw Error("too few points to register (" + std::to_string(map->size()) + " of the map, " +
                    std::to_string(scan->size()) + " of the scan on a " + std::to_string(v) +
                    " m grid)",
                {.field = "registration"});
  GlobalRegistrationReport report;
  report.map_points = map->size();
  report.scan_points = scan->size();
  const double inlier = o.inlier_factor * v;
  const NearestGrid scan_grid(*scan, inlier);

  std::vector<SE3> proposals;
  if (initial) {
    proposals.push_back(*initial);
    report.from_initial = true;
  } else {
    proposals = feature_proposals(map, scan, o, report.matches);
  }

  // Refine every proposal; the best explains the map. Then whether it is unique: the other
  // proposals, and the winner's probes, refined; the best of them far from the winner is the
  // runner-up.
  const std::vector<Level> levels = icp_levels(map_cloud, scan_cloud, o);
  if (levels.empty())
    throw Error("too few points on the ICP grids to refine", {.field = "registration"});
  // Each start is refined on its own, so the starts share the threads.
  const auto refine_all = [&](const std::vector<SE3>& starts) {
    std::vector<Scored> out(starts.size());
    parallel_for(starts.size(), o.threads, [&](std::size_t i) {
      out[i] = score(*map, *scan, scan_grid, refine(levels, starts[i], o, 1));
    });
    return out;
  };
  std::vector<Scored> refined = refine_all(proposals);
  std::sort(refined.begin(), refined.end(),
            [](const Scored& a, const Scored& b) { return a.fitness > b.fitness; });
  if (!initial) {
    const std::vector<Scored> probed =
        refine_all(probes(refined.front().scan_from_map, *map, o.gravity));
    refined.insert(refined.end(), probed.begin(), probed.end());
  }
  // The best of proposals and probes (a probe may find a better fit than every proposal).
  std::stable_sort(refined.begin(), refined.end(),
                   [](const Scored& a, const Scored& b) { return a.fitness > b.fitness; });
  const auto [winner, runner_up] = judge_best(refined, levels, o, initial.has_value());
  if (runner_up) {
    report.runner_up = runner_up->fitness;
    report.runner_up_colour_correlation = runner_up->colour_correlation;
  }
  report.colour_correlation = winner.colour_correlation;
  report.scan_from_map = winner.scan_from_map;
  report.fitness = winner.fitness;
  report.rmse = winner.rmse;
  report.overlap = overlap(*map, *scan, winner.scan_from_map, inlier);
  report.ms = watch.elapsed_ms();
  spdlog::debug(
      "global registration: fitness {:.3f}, RMSE {:.4f} m, overlap {:.3f}, runner-up {:.3f}, "
      "colour correlation {:.3f} (runner-up {:.3f}), {} matches, {:.0f} ms",
      report.fitness, report.rmse, report.overlap, report.runner_up, report.colour_correlation,
      report.runner_up_colour_correlation, report.matches, report.ms);
  verdict(winner, runner_up, o, report);
  return report;
}

}  // namespace coloc::registration::align
