#pragma once
// The one way coloc writes PLY point files (the twin's scan, `coloc e57 to-ply`, `coloc mapdb
// export --ply`): binary little-endian, one vertex element, written as a stream (a scan of
// hundreds of millions of points is never held in memory), the vertex count patched into the
// header at the end, and the file replaced atomically (AtomicFile) when complete.
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <type_traits>
#include <vector>

#include "slam/core/atomic_file.hpp"

namespace coloc {

enum class PlyType : std::uint8_t { kFloat, kUchar, kUint };

struct PlyProperty {
  std::string name;
  PlyType type;
};

// The common layout: float x, y, z and uchar red, green, blue (a coloured cloud).
std::vector<PlyProperty> ply_xyz_rgb();

class PlyWriter {
 public:
  // Claims `target` at once (an unwritable path is a coloc::Error naming it before any work).
  PlyWriter(std::filesystem::path target, std::vector<PlyProperty> properties,
            const std::string& comment);
  PlyWriter(const PlyWriter&) = delete;
  PlyWriter& operator=(const PlyWriter&) = delete;

  // One vertex: its properties in the declared order, as float, std::uint8_t or std::uint32_t.
  template <class... T>
  void add(const T&... values) {
    static_assert((... && (std::is_same_v<T, float> || std::is_same_v<T, std::uint8_t> ||
                           std::is_same_v<T, std::uint32_t>)),
                  "PLY properties are float, uchar or uint");
    char bytes[(0 + ... + sizeof(T))];
    std::size_t at = 0;
    ((std::memcpy(bytes + at, &values, sizeof(T)), at += sizeof(T)), ...);
    add_bytes(bytes, at);
  }
  // Whole vertices as raw little-endian bytes, in the declared layout (a batch: `size` is a
  // multiple of the vertex's size).
  void add_bytes(const void* bytes, std::size_t size);

  std::uint64_t vertices() const { return vertices_; }
  // Patches the count, flushes and renames over the target. Throws coloc::Error naming it.
  // Without commit() the target is untouched.
  void commit();

 private:
  AtomicFile file_;
  std::ofstream out_;
  std::streampos count_position_;
  std::size_t vertex_size_ = 0;
  std::uint64_t vertices_ = 0;
};

}  // namespace coloc
