#include "slam/core/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <vector>

#include "slam/core/atomic_file.hpp"
#include "slam/core/error.hpp"
#include "slam/core/input_file.hpp"
#include "slam/core/rigid.hpp"

namespace coloc {

Trajectory read_tum_trajectory(const std::filesystem::path& path) {
  check_input_file(path, "trajectory file");
  std::ifstream in(path);
  if (!in) throw Error("cannot open trajectory file", {.file = path.string()});
  Trajectory trajectory;
  std::vector<std::int64_t> lines;  // of each pose, for errors after sorting
  std::string line;
  std::int64_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    double v[8];
    int n = 0;
    while (n < 8 && fields >> v[n])
      ++n;
    if (n != 8) {
      throw Error("expected 8 numbers 't tx ty tz qx qy qz qw', read " + std::to_string(n),
                  {.file = path.string(), .line = line_no});
    }
    if (!std::all_of(v, v + 8, [](double x) { return std::isfinite(x); })) {
      throw Error("non-finite number", {.file = path.string(), .line = line_no});
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (!std::isfinite(q.norm()) || std::abs(q.norm() - 1.0) > 1e-2) {
      throw Error("quaternion is not of unit norm (|q| = " + std::to_string(q.norm()) + ")",
                  {.file = path.string(), .line = line_no});
    }
    trajectory.push_back({v[0], SE3(q, Eigen::Vector3d(v[1], v[2], v[3]))});
    lines.push_back(line_no);
  }
  std::vector<std::size_t> order(trajectory.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return trajectory[a].timestamp < trajectory[b].timestamp;
  });
  Trajectory sorted;
  sorted.reserve(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const StampedPose& p = trajectory[order[k]];
    if (!sorted.empty() && sorted.back().timestamp == p.timestamp) {
      // One instant, two poses: which one is meant is unknowable (a concatenated or duplicated
      // file). An exact repeat is harmless and dropped.
      const SE3& q = sorted.back().world_from_cam;
      if (q.translation() != p.world_from_cam.translation() ||
          q.quaternion().coeffs() != p.world_from_cam.quaternion().coeffs()) {
        throw Error("two different poses for timestamp " + std::to_string(p.timestamp) +
                        " (also on line " + std::to_string(lines[order[k - 1]]) + ")",
                    {.file = path.string(), .line = lines[order[k]]});
      }
      continue;
    }
    sorted.push_back(p);
  }
  return sorted;
}

std::size_t write_tum_trajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  AtomicOutput out(path);
  out << "# timestamp tx ty tz qx qy qz qw (world_from_cam)\n";
  std::size_t non_finite = 0;
  for (const auto& p : trajectory) {
    if (!std::isfinite(p.timestamp) || !finite_pose(p.world_from_cam)) {
      ++non_finite;
      continue;
    }
    const Eigen::Vector3d& t = p.world_from_cam.translation();
    const Eigen::Quaterniond& q = p.world_from_cam.quaternion();
    out << std::fixed << std::setprecision(6) << p.timestamp << ' ' << std::setprecision(9) << t.x()
        << ' ' << t.y() << ' ' << t.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' '
        << q.w() << '\n';
  }
  out.commit();
  return non_finite;
}

std::vector<std::pair<std::size_t, std::size_t>> associate_by_time(const Trajectory& a,
                                                                   const Trajectory& b,
                                                                   double max_dt) {
  // Candidate pairs within max_dt (b is sorted, so a window per a), then greedy by |dt|.
  struct Candidate {
    double dt;
    std::size_t i;
    std::size_t j;
  };
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double t = a[i].timestamp;
    auto it = std::lower_bound(b.begin(), b.end(), t - max_dt,
                               [](const StampedPose& p, double v) { return p.timestamp < v; });
    for (; it != b.end() && it->timestamp <= t + max_dt; ++it) {
      const auto j = static_cast<std::size_t>(it - b.begin());
      candidates.push_back({std::abs(it->timestamp - t), i, j});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.dt < y.dt; });
  std::vector<char> used_a(a.size(), 0);
  std::vector<char> used_b(b.size(), 0);
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (const auto& c : candidates) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = 1;
    pairs.emplace_back(c.i, c.j);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

namespace {

// Score of a chain of pairs: more pairs first, then a smaller total |dt|.
struct ChainScore {
  std::size_t count = 0;
  double dt_sum = 0.0;
  bool better_than(const ChainScore& o) const {
    return count != o.count ? count > o.count : dt_sum < o.dt_sum;
  }
};

// Fenwick tree over b-indices holding the best chain ending at or before an index.
class PrefixBest {
 public:
  explicit PrefixBest(std::size_t n) : score_(n + 1), pair_(n + 1, kNone) {}
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);

  // Best chain whose last pair has b-index < j.
  std::pair<ChainScore, std::size_t> query(std::size_t j) const {
    ChainScore best;
    std::size_t arg = kNone;
    for (std::size_t k = j; k > 0; k -= k & (~k + 1)) {
      if (score_[k].better_than(best)) {
        best = score_[k];
        arg = pair_[k];
      }
    }
    return {best, arg};
  }

  void update(std::size_t j, const ChainScore& s, std::size_t pair) {
    for (std::size_t k = j + 1; k < score_.size(); k += k & (~k + 1)) {
      if (s.better_than(score_[k])) {
        score_[k] = s;
        pair_[k] = pair;
      }
    }
  }

 private:
  std::vector<ChainScore> score_;
  std::vector<std::size_t> pair_;
};

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> associate_in_order(const std::vector<double>& a,
                                                                    const std::vector<double>& b,
                                                                    double max_dt) {
  struct Candidate {
    std::size_t i, j;
    double dt;
  };
  std::vector<Candidate> cands;  // sorted by i, and by decreasing j within one i
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto lo = std::lower_bound(b.begin(), b.end(), a[i] - max_dt);
    const auto hi = std::upper_bound(b.begin(), b.end(), a[i] + max_dt);
    for (auto it = hi; it != lo;) {
      --it;
      cands.push_back({i, static_cast<std::size_t>(it - b.begin()), std::abs(*it - a[i])});
    }
  }
  // Weighted longest increasing subsequence in j; processing one i's candidates in decreasing
  // j keeps two pairs of the same i out of one chain.
  PrefixBest tree(b.size());
  std::vector<std::size_t> prev(cands.size(), PrefixBest::kNone);
  ChainScore best;
  std::size_t best_end = PrefixBest::kNone;
  for (std::size_t k = 0; k < cands.size(); ++k) {
    const auto [before, arg] = tree.query(cands[k].j);
    const ChainScore s{before.count + 1, before.dt_sum + cands[k].dt};
    prev[k] = arg;
    tree.update(cands[k].j, s, k);
    if (s.better_than(best)) {
      best = s;
      best_end = k;
    }
  }
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t k = best_end; k != PrefixBest::kNone; k = prev[k]) {
    pairs.emplace_back(cands[k].i, cands[k].j);
  }
  std::reverse(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace coloc
