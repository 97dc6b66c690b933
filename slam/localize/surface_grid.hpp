#pragma once
// The laser scan as a surface a depth image can be aligned to at camera rate: surfels (a point
// and a normal) on a hashed voxel grid, at two resolutions. A query looks in the 27 voxels
// around a point for the nearest surfel, so it costs the same whatever the scan's size; a
// k-d tree over millions of points costs more per query and far more to build.
//
// A voxel's surfel: the mean of the scan points in it, and the normal of the points in the
// voxel and its 26 neighbours (a block three voxels wide), kept only when that block is planar
// (surface variation, the smallest eigenvalue over their sum, at most max_curvature): edges,
// clutter and noise have no plane to measure a point-to-plane distance to. The coarse level
// (larger voxels) lets an alignment start 5-10 cm off; the fine level then measures against the
// surface's detail.
//
// Frames: the scan's (a registered map's world), metres. Built once, then read-only: queries
// from several threads are safe.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace coloc::slam::localize {

struct SurfaceGridOptions {
  double fine_voxel_m = 0.02;
  double coarse_voxel_m = 0.05;
  // As PCL's surface variation: 0 on a plane, 1/3 isotropic. Loose on purpose: the edges of
  // furniture are what fixes a camera's position along a table or a wall (7-Scenes frames
  // from 5 cm off: 28 mm median error with 0.08, 7.3 mm with 0.25).
  double max_curvature = 0.25;
  // Throws coloc::Error naming the first invalid field.
  void check() const;
};

struct Surfel {
  Eigen::Vector3f point = Eigen::Vector3f::Zero();
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  // unit
};

class SurfaceGrid {
 public:
  enum class Resolution : std::uint8_t { kCoarse = 0, kFine = 1 };

  // `points`: the scan (any density; a 1 cm voxel-thinned cloud is plenty). Throws coloc::Error
  // (field "scan") when no voxel has a planar neighbourhood.
  SurfaceGrid(const std::vector<Eigen::Vector3f>& points, const SurfaceGridOptions& options = {});

  // A surfel near `x` within `max_distance` metres: the one of x's own voxel when it has one
  // within reach, else the nearest (Euclidean) of the 27 voxels around it; null when none is.
  // `max_distance` above the level's voxel size may miss surfels beyond the block.
  const Surfel* nearest(Resolution resolution, const Eigen::Vector3d& x, double max_distance) const;

  std::size_t surfels(Resolution resolution) const {
    return levels_[static_cast<int>(resolution)].count;
  }
  std::size_t bytes() const;  // memory held
  const SurfaceGridOptions& options() const { return options_; }

 private:
  // Open addressing with linear probing; the value beside its key, so a lookup touches one
  // cache line.
  template <typename Value>
  struct HashTable {
    struct Slot {
      std::uint64_t key;
      Value value;
    };
    std::vector<Slot> slots;
    std::uint64_t mask = 0;
    explicit HashTable(std::size_t count = 0);
    void insert(std::uint64_t key, const Value& value);
    const Value* find(std::uint64_t key) const;
  };
  struct Level {
    double voxel = 0.0, inv_voxel = 0.0;
    HashTable<Surfel> surfels;
    std::size_t count = 0;
  };
  static Level build(const std::vector<Eigen::Vector3f>& points, double voxel,
                     double max_curvature);

  SurfaceGridOptions options_;
  Level levels_[2];
};

}  // namespace coloc::slam::localize
