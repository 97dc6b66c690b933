#include "registration/render/point_buffer.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "slam/core/error.hpp"

namespace coloc::registration::render::detail {
namespace {

struct Vertex {
  float x, y, z;
  std::uint8_t r, g, b, pad;
  float size;
};
static_assert(sizeof(Vertex) == 20);

// Vertices filled and sent per piece: 20 MB, small beside a site's cloud, large enough that the
// number of glBufferSubData calls does not matter.
constexpr std::size_t kPiece = std::size_t{1} << 20;

}  // namespace

std::size_t PointBuffer::bytes() const {
  return static_cast<std::size_t>(count) * sizeof(Vertex) +
         cells.order.capacity() * sizeof(std::uint32_t) +
         cells.cells.capacity() * sizeof(CloudCells::Cell);
}

PointBuffer make_point_buffer(const PointCloud& c, double cull_cell) {
  // Upload positions reach the shader as gl_VertexID and come back as an int index.
  if (c.points.size() > static_cast<std::size_t>(std::numeric_limits<GLint>::max()))
    throw Error("point cloud: more than 2^31 - 1 points to draw", {.field = "points"});
  PointBuffer b;
  if (cull_cell > 0.0) b.cells = group_into_cells(c, static_cast<float>(cull_cell));
  const std::size_t n = c.points.size();
  b.vbo = gen_buffer();
  glBindBuffer(GL_ARRAY_BUFFER, b.vbo.get());
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(n * sizeof(Vertex)), nullptr,
               GL_STATIC_DRAW);
  std::vector<Vertex> piece(std::min(n, kPiece));
  for (std::size_t start = 0; start < n; start += kPiece) {
    const std::size_t end = std::min(n, start + kPiece);
    for (std::size_t pos = start; pos < end; ++pos) {
      const std::size_t i = b.cells.order.empty() ? pos : b.cells.order[pos];
      const Eigen::Vector3f& p = c.points[i];
      piece[pos - start] = {p.x(),
                            p.y(),
                            p.z(),
                            c.colours[i][0],
                            c.colours[i][1],
                            c.colours[i][2],
                            0,
                            c.splat_sizes.empty() ? c.splat_size : c.splat_sizes[i]};
    }
    glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(start * sizeof(Vertex)),
                    static_cast<GLsizeiptr>((end - start) * sizeof(Vertex)), piece.data());
  }
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  b.count = static_cast<GLsizei>(n);
  b.max_pixels = c.max_splat_pixels;
  glFinish();
  check_gl("point cloud upload");
  return b;
}

GlName<glDeleteVertexArrays> make_point_vertex_array(const PointBuffer& buffer) {
  GlName<glDeleteVertexArrays> vao = gen_vertex_array();
  glBindVertexArray(vao.get());
  glBindBuffer(GL_ARRAY_BUFFER, buffer.vbo.get());
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(Vertex),
                        reinterpret_cast<const void*>(offsetof(Vertex, r)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, sizeof(Vertex),
                        reinterpret_cast<const void*>(offsetof(Vertex, size)));
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  check_gl("point cloud vertex array");
  return vao;
}

}  // namespace coloc::registration::render::detail
