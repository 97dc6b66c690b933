#include "slam/localize/surface_grid.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "slam/core/error.hpp"

namespace coloc::slam::localize {

namespace {

constexpr std::uint64_t kEmpty = std::numeric_limits<std::uint64_t>::max();
constexpr std::int64_t kAxisOffset = std::int64_t{1} << 20;  // 21 bits an axis: +-1M voxels
constexpr std::int64_t kAxisMax = (std::int64_t{1} << 21) - 1;

std::array<std::int64_t, 3> voxel_of(const Eigen::Vector3d& x, double inv_voxel) {
  std::array<std::int64_t, 3> v{};
  for (int a = 0; a < 3; ++a)
    v[a] = std::clamp(static_cast<std::int64_t>(std::floor(x[a] * inv_voxel)) + kAxisOffset,
                      std::int64_t{0}, kAxisMax);
  return v;
}

std::uint64_t key_of(const std::array<std::int64_t, 3>& v) {
  return (static_cast<std::uint64_t>(v[0]) << 42) | (static_cast<std::uint64_t>(v[1]) << 21) |
         static_cast<std::uint64_t>(v[2]);
}

// Calls f(key) for the 27 voxels around (and including) voxel c that lie on the grid.
template <typename F>
void for_each_neighbour(const std::array<std::int64_t, 3>& c, F&& f) {
  for (std::int64_t dx = -1; dx <= 1; ++dx)
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dz = -1; dz <= 1; ++dz) {
        const std::array<std::int64_t, 3> n{c[0] + dx, c[1] + dy, c[2] + dz};
        if (n[0] >= 0 && n[1] >= 0 && n[2] >= 0 && n[0] <= kAxisMax && n[1] <= kAxisMax &&
            n[2] <= kAxisMax)
          f(key_of(n));
      }
}

// splitmix64's finalizer: every key bit reaches the low bits the mask keeps (a multiply alone
// leaves the x bits, shifted 42 up, out of them, and a row of voxels along x into one probe run).
std::uint64_t slot_of(std::uint64_t key, std::uint64_t mask) {
  key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9ULL;
  key = (key ^ (key >> 27)) * 0x94D049BB133111EBULL;
  return (key ^ (key >> 31)) & mask;
}

// Sums of a voxel's points about the cloud's first point (doubles: a 1 cm spread 100 m from it
// keeps 8 significant digits of its variance).
struct Moments {
  double n = 0.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  void add(const Moments& m) {
    n += m.n;
    sum += m.sum;
    outer += m.outer;
  }
};

}  // namespace

void SurfaceGridOptions::check() const {
  if (!(fine_voxel_m > 0.0)) throw Error("SurfaceGridOptions.fine_voxel_m must be > 0");
  if (!(coarse_voxel_m >= fine_voxel_m))
    throw Error("SurfaceGridOptions.coarse_voxel_m must be >= fine_voxel_m");
  if (!(max_curvature > 0.0 && max_curvature <= 1.0 / 3.0))
    throw Error("SurfaceGridOptions.max_curvature must be in (0, 1/3]");
}

template <typename Value>
SurfaceGrid::HashTable<Value>::HashTable(std::size_t count) {
  std::uint64_t capacity = 16;
  while (capacity < count * 2)  // at most half full: short probe runs
    capacity <<= 1;
  mask = capacity - 1;
  slots.assign(capacity, Slot{kEmpty, Value{}});
}

template <typename Value>
void SurfaceGrid::HashTable<Value>::insert(std::uint64_t key, const Value& value) {
  std::uint64_t s = slot_of(key, mask);
  while (slots[s].key != kEmpty)
    s = (s + 1) & mask;
  slots[s] = {key, value};
}

template <typename Value>
const Value* SurfaceGrid::HashTable<Value>::find(std::uint64_t key) const {
  for (std::uint64_t s = slot_of(key, mask);; s = (s + 1) & mask) {
    if (slots[s].key == key) return &slots[s].value;
    if (slots[s].key == kEmpty) return nullptr;
  }
}

SurfaceGrid::Level SurfaceGrid::build(const std::vector<Eigen::Vector3f>& points, double voxel,
                                      double max_curvature) {
  Level level;
  level.voxel = voxel;
  level.inv_voxel = 1.0 / voxel;
  if (points.empty()) return level;
  const Eigen::Vector3d origin = points.front().cast<double>();

  // The voxels' moments: points sorted by voxel, one Moments per run of equal keys.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    order[i] = {key_of(voxel_of(points[i].cast<double>(), level.inv_voxel)),
                static_cast<std::uint32_t>(i)};
  std::sort(order.begin(), order.end());
  std::vector<std::uint64_t> voxel_keys;
  std::vector<Moments> moments;
  for (const auto& [key, i] : order) {
    if (voxel_keys.empty() || voxel_keys.back() != key) {
      voxel_keys.push_back(key);
      moments.emplace_back();
    }
    const Eigen::Vector3d d = points[i].cast<double>() - origin;
    Moments& m = moments.back();
    m.n += 1.0;
    m.sum += d;
    m.outer += d * d.transpose();
  }
  order = {};
  HashTable<std::uint32_t> voxel_index(voxel_keys.size());
  for (std::size_t v = 0; v < voxel_keys.size(); ++v)
    voxel_index.insert(voxel_keys[v], static_cast<std::uint32_t>(v));

  std::vector<std::pair<std::uint64_t, Surfel>> planar;
  for (std::size_t v = 0; v < voxel_keys.size(); ++v) {
    const std::uint64_t key = voxel_keys[v];
    const std::array<std::int64_t, 3> c{static_cast<std::int64_t>(key >> 42),
                                        static_cast<std::int64_t>((key >> 21) & kAxisMax),
                                        static_cast<std::int64_t>(key & kAxisMax)};
    Moments block;
    for_each_neighbour(c, [&](std::uint64_t k) {
      if (const std::uint32_t* i = voxel_index.find(k)) block.add(moments[*i]);
    });
    if (block.n < 5.0) continue;  // too few points for a plane
    const Eigen::Vector3d mean = block.sum / block.n;
    const Eigen::Matrix3d cov = block.outer / block.n - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    const Eigen::Vector3d lambda = eig.eigenvalues().cwiseMax(0.0);
    const double total = lambda.sum();
    if (!(total > 0.0) || lambda[0] / total > max_curvature) continue;
    // The voxel's own mean on the block's plane (the block's mean sits off a curved surface).
    const Moments& own = moments[v];
    planar.emplace_back(key, Surfel{(origin + own.sum / own.n).cast<float>(),
                                    eig.eigenvectors().col(0).normalized().cast<float>()});
  }
  // The table keeps the planar voxels only: a query never meets a voxel without a surfel.
  level.surfels = HashTable<Surfel>(planar.size());
  for (const auto& [key, surfel] : planar)
    level.surfels.insert(key, surfel);
  level.count = planar.size();
  return level;
}

SurfaceGrid::SurfaceGrid(const std::vector<Eigen::Vector3f>& points,
                         const SurfaceGridOptions& options)
    : options_(options) {
  options_.check();
  levels_[static_cast<int>(Resolution::kCoarse)] =
      build(points, options_.coarse_voxel_m, options_.max_curvature);
  levels_[static_cast<int>(Resolution::kFine)] =
      build(points, options_.fine_voxel_m, options_.max_curvature);
  if (levels_[static_cast<int>(Resolution::kFine)].count == 0)
    throw Error("no part of the scan is planar enough to align depth images to (" +
                    std::to_string(points.size()) + " points)",
                {.field = "scan"});
}

const Surfel* SurfaceGrid::nearest(Resolution resolution, const Eigen::Vector3d& x,
                                   double max_distance) const {
  const Level& t = levels_[static_cast<int>(resolution)];
  const std::array<std::int64_t, 3> c = voxel_of(x, t.inv_voxel);
  // The voxel's own surfel stands for the plane through it: a point-to-plane distance needs a
  // point on the right plane, not the nearest one, and one lookup costs 1/27 of the block.
  if (const Surfel* own = t.surfels.find(key_of(c));
      own && (own->point.cast<double>() - x).squaredNorm() <= max_distance * max_distance)
    return own;
  const Surfel* best = nullptr;
  double best_d2 = max_distance * max_distance;
  for_each_neighbour(c, [&](std::uint64_t k) {
    const Surfel* s = t.surfels.find(k);
    if (!s) return;
    const double d2 = (s->point.cast<double>() - x).squaredNorm();
    if (d2 <= best_d2) {
      best_d2 = d2;
      best = s;
    }
  });
  return best;
}

std::size_t SurfaceGrid::bytes() const {
  std::size_t b = 0;
  for (const Level& t : levels_)
    b += t.surfels.slots.capacity() * sizeof(HashTable<Surfel>::Slot);
  return b;
}

}  // namespace coloc::slam::localize
