#pragma once
// The voxel grid of load_scan_cloud (scan_cloud.hpp) built while the scan is read, one point at
// a time, so its memory grows with the occupied voxels, not with the points: a site scan of
// 200 million points would take ~7 GB as a cloud in memory before thinning.
//
// Result: exactly that of the batch voxel_downsample (scan_cloud.hpp) on the same points in the
// same order: one point per occupied voxel at the mean position and colour of its kept points,
// voxels in ascending voxel_key order. Positions may differ from the batch result by float
// rounding (sums are kept relative to the voxel's corner, in float: below voxel_size * n * 3e-8
// for n points in the voxel).
//
// The finest-stations rule, streamed: a voxel keeps the points whose spacing s satisfies
// s <= 1.5 * finest, finest being the smallest spacing of any point in the voxel over the whole
// file. The final finest is not known while reading, but it only falls, so the threshold only
// falls and a point once rejected stays rejected. A voxel holds the smallest spacing seen
// (finest), the largest spacing among the points it accepted (widest) and their sums. A point
// with s >= finest is added when s <= 1.5 * finest, else rejected for good. A finer point
// (s < finest) lowers the threshold to t = 1.5 * s: when widest <= t every accepted point stays
// (add), when the old finest > t every one leaves (the sums restart from this point); when
// finest <= t < widest, some accepted points leave and the sums cannot say which: the voxel is
// marked ambiguous. Its finest stays exact; after the file, if any voxel is ambiguous, the
// caller reads the file a second time (begin_second_pass) and those voxels alone are summed
// again against their final finest. Ambiguity needs a station 1.5x finer to arrive after two
// stations whose spacings differ in that voxel, so it is rare and the second pass often absent.
//
// Memory: 48 bytes per cell in 256 open-addressing tables (linear probing, grown by doubling
// at 3/4 load, each on its own so growth never holds a second copy of the whole grid): 64 to
// 128, typically ~90 bytes per occupied voxel. take_means() adds 32 bytes per voxel as the
// tables are freed, then 19-23 per voxel for the cloud.
//
// Not thread-safe; one grid per load.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "registration/render/scene.hpp"

namespace coloc::registration::align {

// The voxel of `p` (file frame, metres) for 1 / voxel size `inv_size`: 21 bits per axis,
// +-1M voxels (10 km at 1 cm); beyond, the outer voxels take the points. Ascending keys sort by
// x, then y, then z.
std::uint64_t voxel_key(const Eigen::Vector3f& p, double inv_size);

class VoxelGrid {
 public:
  // voxel_size in metres (> 0). finest_stations: apply the rule above to the spacings given to
  // add(); false averages every point of a voxel (spacing ignored, no spacings out).
  VoxelGrid(double voxel_size, bool finest_stations);

  // One point: file frame (metres), 8-bit colour, spacing (metres, > 0 with the rule).
  void add(const Eigen::Vector3f& p, const std::array<std::uint8_t, 3>& rgb, float spacing);

  std::uint64_t voxels() const { return voxels_; }
  std::uint64_t ambiguous() const { return ambiguous_; }
  std::size_t bytes() const;  // memory the tables hold

  // The ambiguous voxels: their box (file frame, metres) and finest spacing; the second
  // reading may skip the stations that cannot reach within 1.5x of it.
  struct Voxel {
    Eigen::Vector3d lo, hi;
    double finest;
  };
  std::vector<Voxel> ambiguous_voxels() const;

  // Restarts the sums of the ambiguous voxels; add() then updates those alone, with the points
  // within 1.5x of their final finest spacing. Feed the same points again.
  void begin_second_pass();

  // The voxels in ascending key order: mean points, mean colours and, with the rule, each
  // voxel's mean spacing (metres) in splat_sizes. Empties the grid.
  render::PointCloud take_means();

 private:
  struct Cell {
    std::uint64_t key;
    float finest, widest;         // spacings, metres (see above)
    std::array<float, 3> offset;  // sum of (point - voxel corner), metres
    float spacing;                // sum of spacings
    std::array<std::uint32_t, 3> rgb;
    std::uint32_t count;  // points summed; kAmbiguous bit when the sums await the second pass
  };
  static_assert(sizeof(Cell) == 48);
  struct Table {
    std::vector<Cell> cells;
    std::size_t used = 0;
  };

  Cell& find_or_insert(std::uint64_t key, bool& inserted);
  Cell* find(std::uint64_t key);
  void grow(Table& t);
  void accumulate(Cell& c, const Eigen::Vector3f& p, const std::array<std::uint8_t, 3>& rgb,
                  float spacing) const;
  Eigen::Vector3d corner(std::uint64_t key) const;

  double size_, inv_size_;
  bool finest_stations_;
  bool second_pass_ = false;
  std::uint64_t voxels_ = 0, ambiguous_ = 0;
  std::vector<Table> tables_;
};

}  // namespace coloc::registration::align
