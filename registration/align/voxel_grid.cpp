#include "registration/align/voxel_grid.hpp"

#include <algorithm>
#include <cmath>

namespace coloc::registration::align {

namespace {

constexpr std::int64_t kHalf = 1 << 20;
constexpr std::uint64_t kAxisMask = (1u << 21) - 1;
constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // keys use 63 bits, so never a key
constexpr std::uint32_t kAmbiguous = 1u << 31;
// Colour sums are 32-bit: 255 * 2^24 fits, so a voxel sums at most 2^24 points and ignores
// the rest (16.7 million points in one voxel: far beyond any scanner's density at 1 cm).
constexpr std::uint32_t kMaxCount = 1u << 24;
constexpr int kTableBits = 8;  // 256 tables, chosen by the hash's top bits

std::uint64_t mix(std::uint64_t k) {  // splitmix64's finalizer: voxel keys are far from random
  k ^= k >> 30;
  k *= 0xbf58476d1ce4e5b9ull;
  k ^= k >> 27;
  k *= 0x94d049bb133111ebull;
  return k ^ (k >> 31);
}

// The batch rule's test (scan_cloud.cpp), in the same arithmetic so both agree at the boundary.
bool within(float spacing, float finest) {
  return !(static_cast<double>(spacing) > 1.5 * static_cast<double>(finest));
}

}  // namespace

std::uint64_t voxel_key(const Eigen::Vector3f& p, double inv_size) {
  const auto axis = [&](float v) {
    const auto i = static_cast<std::int64_t>(std::floor(static_cast<double>(v) * inv_size));
    return static_cast<std::uint64_t>(std::clamp<std::int64_t>(i + kHalf, 0, 2 * kHalf - 1));
  };
  return (axis(p.x()) << 42) | (axis(p.y()) << 21) | axis(p.z());
}

VoxelGrid::VoxelGrid(double voxel_size, bool finest_stations)
    : size_(voxel_size),
      inv_size_(1.0 / voxel_size),
      finest_stations_(finest_stations),
      tables_(std::size_t{1} << kTableBits) {}

std::size_t VoxelGrid::bytes() const {
  std::size_t n = tables_.capacity() * sizeof(Table);
  for (const Table& t : tables_)
    n += t.cells.capacity() * sizeof(Cell);
  return n;
}

Eigen::Vector3d VoxelGrid::corner(std::uint64_t key) const {
  const auto axis = [&](int shift) {
    return static_cast<double>(static_cast<std::int64_t>((key >> shift) & kAxisMask) - kHalf) *
           size_;
  };
  return {axis(42), axis(21), axis(0)};
}

void VoxelGrid::grow(Table& t) {
  std::vector<Cell> old(std::max<std::size_t>(64, 2 * t.cells.size()), Cell{.key = kEmpty,
                                                                            .finest = 0.0f,
                                                                            .widest = 0.0f,
                                                                            .offset = {},
                                                                            .spacing = 0.0f,
                                                                            .rgb = {},
                                                                            .count = 0});
  old.swap(t.cells);
  const std::size_t mask = t.cells.size() - 1;
  for (const Cell& c : old) {
    if (c.key == kEmpty) continue;
    std::size_t i = mix(c.key) & mask;
    while (t.cells[i].key != kEmpty)
      i = (i + 1) & mask;
    t.cells[i] = c;
  }
}

VoxelGrid::Cell& VoxelGrid::find_or_insert(std::uint64_t key, bool& inserted) {
  const std::uint64_t h = mix(key);
  Table& t = tables_[h >> (64 - kTableBits)];
  if (4 * (t.used + 1) > 3 * t.cells.size()) grow(t);
  const std::size_t mask = t.cells.size() - 1;
  for (std::size_t i = h & mask;; i = (i + 1) & mask) {
    Cell& c = t.cells[i];
    if (c.key == key) {
      inserted = false;
      return c;
    }
    if (c.key == kEmpty) {
      c.key = key;
      ++t.used;
      ++voxels_;
      inserted = true;
      return c;
    }
  }
}

VoxelGrid::Cell* VoxelGrid::find(std::uint64_t key) {
  const std::uint64_t h = mix(key);
  Table& t = tables_[h >> (64 - kTableBits)];
  if (t.cells.empty()) return nullptr;
  const std::size_t mask = t.cells.size() - 1;
  for (std::size_t i = h & mask;; i = (i + 1) & mask) {
    if (t.cells[i].key == key) return &t.cells[i];
    if (t.cells[i].key == kEmpty) return nullptr;
  }
}

void VoxelGrid::accumulate(Cell& c, const Eigen::Vector3f& p,
                           const std::array<std::uint8_t, 3>& rgb, float spacing) const {
  if ((c.count & ~kAmbiguous) >= kMaxCount) return;
  const Eigen::Vector3d o = corner(c.key);
  for (int a = 0; a < 3; ++a) {
    c.offset[a] += static_cast<float>(static_cast<double>(p[a]) - o[a]);
    c.rgb[a] += rgb[a];
  }
  c.spacing += spacing;
  ++c.count;
}

void VoxelGrid::add(const Eigen::Vector3f& p, const std::array<std::uint8_t, 3>& rgb,
                    float spacing) {
  const std::uint64_t key = voxel_key(p, inv_size_);
  if (second_pass_) {
    Cell* c = find(key);
    if (c && (c->count & kAmbiguous) && within(spacing, c->finest)) accumulate(*c, p, rgb, spacing);
    return;
  }
  bool inserted = false;
  Cell& c = find_or_insert(key, inserted);
  const auto restart = [&] {
    c.offset = {};
    c.rgb = {};
    c.spacing = 0.0f;
    c.count = 0;
    c.finest = c.widest = spacing;
    accumulate(c, p, rgb, spacing);
  };
  if (inserted || !finest_stations_) {
    if (inserted) {
      restart();
    } else {
      accumulate(c, p, rgb, spacing);
    }
    return;
  }
  if (spacing >= c.finest) {  // the threshold stays: in or out for good
    if (!within(spacing, c.finest)) return;
    c.widest = std::max(c.widest, spacing);
    accumulate(c, p, rgb, spacing);
    return;
  }
  // A finer point: the threshold falls to 1.5 * spacing.
  if (within(c.widest, spacing)) {  // every accepted point stays
    c.finest = spacing;
    accumulate(c, p, rgb, spacing);
  } else if (!within(c.finest, spacing)) {  // every accepted point leaves
    if (c.count & kAmbiguous) --ambiguous_;
    restart();
  } else {  // some leave, the sums cannot say which: summed again in the second pass
    if (!(c.count & kAmbiguous)) ++ambiguous_;
    c.count |= kAmbiguous;
    c.finest = spacing;
  }
}

std::vector<VoxelGrid::Voxel> VoxelGrid::ambiguous_voxels() const {
  std::vector<Voxel> out;
  for (const Table& t : tables_) {
    for (const Cell& c : t.cells) {
      if (c.key == kEmpty || !(c.count & kAmbiguous)) continue;
      const Eigen::Vector3d lo = corner(c.key);
      out.push_back({lo, lo + Eigen::Vector3d::Constant(size_), static_cast<double>(c.finest)});
    }
  }
  return out;
}

void VoxelGrid::begin_second_pass() {
  second_pass_ = true;
  for (Table& t : tables_) {
    for (Cell& c : t.cells) {
      if (c.key == kEmpty || !(c.count & kAmbiguous)) continue;
      c.offset = {};
      c.rgb = {};
      c.spacing = 0.0f;
      c.count = kAmbiguous;
    }
  }
}

render::PointCloud VoxelGrid::take_means() {
  struct Mean {
    std::uint64_t key;
    Eigen::Vector3f point;
    float spacing;
    std::array<std::uint8_t, 3> rgb;
  };
  std::vector<Mean> means;
  // Reserved, not touched: pages become resident as the tables below are freed.
  means.reserve(voxels_);
  for (Table& t : tables_) {
    for (const Cell& c : t.cells) {
      if (c.key == kEmpty) continue;
      const double n = static_cast<double>(c.count & ~kAmbiguous);
      const Eigen::Vector3d o = corner(c.key);
      Mean m{.key = c.key, .point = {}, .spacing = 0.0f, .rgb = {}};
      for (int a = 0; a < 3; ++a) {
        m.point[a] = static_cast<float>(o[a] + static_cast<double>(c.offset[a]) / n);
        m.rgb[a] = static_cast<std::uint8_t>(std::lround(static_cast<double>(c.rgb[a]) / n));
      }
      m.spacing = static_cast<float>(static_cast<double>(c.spacing) / n);
      means.push_back(m);
    }
    std::vector<Cell>().swap(t.cells);
    t.used = 0;
  }
  voxels_ = ambiguous_ = 0;
  second_pass_ = false;
  std::sort(means.begin(), means.end(), [](const Mean& a, const Mean& b) { return a.key < b.key; });
  render::PointCloud out;
  out.points.reserve(means.size());
  out.colours.reserve(means.size());
  if (finest_stations_) out.splat_sizes.reserve(means.size());
  for (const Mean& m : means) {
    out.points.push_back(m.point);
    out.colours.push_back(m.rgb);
    if (finest_stations_) out.splat_sizes.push_back(m.spacing);
  }
  return out;
}

}  // namespace coloc::registration::align
