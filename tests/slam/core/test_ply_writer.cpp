// The one PLY writer: the header a reader needs (count patched at the end), the vertices'
// bytes in the declared layout, batches, and nothing under the target until commit().
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "slam/core/error.hpp"
#include "slam/core/ply_writer.hpp"

namespace coloc {
namespace {

namespace fs = std::filesystem;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path temp_file(const std::string& name) {
  const fs::path path = fs::path(::testing::TempDir()) / name;
  fs::remove(path);
  return path;
}

TEST(PlyWriter, WritesHeaderCountAndVerticesInOrder) {
  const fs::path path = temp_file("ply_writer_points.ply");
  PlyWriter ply(path, {{"x", PlyType::kFloat}, {"red", PlyType::kUchar}, {"n", PlyType::kUint}},
                "test points");
  ply.add(1.5f, std::uint8_t{200}, std::uint32_t{7});
  ply.add(-2.0f, std::uint8_t{3}, std::uint32_t{70000});
  EXPECT_FALSE(fs::exists(path)) << "nothing under the target before commit()";
  ply.commit();
  const std::string text = read_file(path);
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment test points\n"
      "element vertex 00000000000000000002\nproperty float x\nproperty uchar red\n"
      "property uint n\nend_header\n";
  ASSERT_EQ(text.substr(0, header.size()), header);
  ASSERT_EQ(text.size(), header.size() + 2 * 9);
  float x = 0.0f;
  std::uint32_t n = 0;
  std::memcpy(&x, text.data() + header.size() + 9, 4);
  std::memcpy(&n, text.data() + header.size() + 9 + 5, 4);
  EXPECT_EQ(x, -2.0f);
  EXPECT_EQ(static_cast<std::uint8_t>(text[header.size() + 4]), 200);
  EXPECT_EQ(n, 70000u);
}

TEST(PlyWriter, BatchesMustBeWholeVertices) {
  const fs::path path = temp_file("ply_writer_batch.ply");
  PlyWriter ply(path, {{"x", PlyType::kFloat}, {"y", PlyType::kFloat}}, "");
  const float batch[6] = {1, 2, 3, 4, 5, 6};
  ply.add_bytes(batch, sizeof batch);
  EXPECT_EQ(ply.vertices(), 3u);
  EXPECT_THROW(ply.add_bytes(batch, 5), Error);
  ply.commit();
  EXPECT_NE(read_file(path).find("element vertex 00000000000000000003\n"), std::string::npos);
}

TEST(PlyWriter, AnAbandonedWriteLeavesThePreviousFile) {
  const fs::path path = temp_file("ply_writer_previous.ply");
  std::ofstream(path) << "previous";
  {
    PlyWriter ply(path, {{"x", PlyType::kFloat}}, "");
    ply.add(1.0f);
  }  // no commit: a failed export
  EXPECT_EQ(read_file(path), "previous");
  EXPECT_THROW(PlyWriter("/nonexistent-dir/x.ply", {{"x", PlyType::kFloat}}, ""), Error);
}

}  // namespace
}  // namespace coloc
