#include "slam/core/ply_writer.hpp"

#include <bit>
#include <cstdio>

#include "slam/core/error.hpp"

namespace coloc {
namespace {

static_assert(std::endian::native == std::endian::little, "PLY is written little-endian");

// The count is written as 20 digits (zero-padded) so it can be patched in place at the end:
// any uint64 fits, and readers parse it as a plain integer.
constexpr int kCountDigits = 20;

const char* type_name(PlyType type) {
  switch (type) {
    case PlyType::kFloat:
      return "float";
    case PlyType::kUchar:
      return "uchar";
    case PlyType::kUint:
      return "uint";
  }
  return "?";
}

std::size_t type_size(PlyType type) {
  return type == PlyType::kFloat ? 4 : type == PlyType::kUchar ? 1 : 4;
}

}  // namespace

std::vector<PlyProperty> ply_xyz_rgb() {
  return {{"x", PlyType::kFloat},   {"y", PlyType::kFloat},     {"z", PlyType::kFloat},
          {"red", PlyType::kUchar}, {"green", PlyType::kUchar}, {"blue", PlyType::kUchar}};
}

PlyWriter::PlyWriter(std::filesystem::path target, std::vector<PlyProperty> properties,
                     const std::string& comment)
    : file_(std::move(target)), out_(file_.temp_path(), std::ios::binary | std::ios::trunc) {
  if (!out_) throw Error("cannot write the PLY file", {.file = file_.target().string()});
  if (properties.empty()) throw Error("a PLY vertex needs properties", {.field = "properties"});
  out_ << "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) out_ << "comment " << comment << '\n';
  out_ << "element vertex ";
  count_position_ = out_.tellp();
  out_ << std::string(kCountDigits, '0') << '\n';
  for (const PlyProperty& p : properties) {
    out_ << "property " << type_name(p.type) << ' ' << p.name << '\n';
    vertex_size_ += type_size(p.type);
  }
  out_ << "end_header\n";
}

void PlyWriter::add_bytes(const void* bytes, std::size_t size) {
  if (size % vertex_size_ != 0)
    throw Error(std::to_string(size) + " bytes are not whole PLY vertices of " +
                    std::to_string(vertex_size_),
                {.file = file_.target().string()});
  out_.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(size));
  vertices_ += size / vertex_size_;
}

void PlyWriter::commit() {
  char count[kCountDigits + 1];
  std::snprintf(count, sizeof count, "%020llu", static_cast<unsigned long long>(vertices_));
  out_.seekp(count_position_);
  out_.write(count, kCountDigits);
  out_.close();
  if (!out_) throw Error("cannot write the PLY file", {.file = file_.target().string()});
  file_.commit();
}

}  // namespace coloc
