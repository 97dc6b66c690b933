#pragma once
// Private to the renderer: a point cloud prepared for drawing (cells, one GL vertex buffer in
// upload order), the part that Renderers may share. Not a public header (it includes GL).
//
// Memory per point: the vertex in the GL buffer (20 B, Mesa's copy) and its place in
// `cells.order` (4 B). The 3-D point behind a pixel is not kept on the CPU: the point shader
// writes the vertex's own position (a flat varying, so its exact float bits) into the position
// attachment.

#include <cstddef>

#include "registration/render/cloud_cells.hpp"
#include "registration/render/gl_context.hpp"
#include "registration/render/scene.hpp"

namespace coloc::registration::render::detail {

struct PointBuffer {
  GlName<glDeleteBuffers> vbo;  // deleted with a context of its share group current
  GLsizei count = 0;
  float max_pixels = 0.0f;
  CloudCells cells;  // upload order; no cells: uploaded in cloud order, drawn whole

  // The cloud index of the point uploaded at `position`.
  int cloud_index(int position) const {
    return cells.order.empty() ? position
                               : static_cast<int>(cells.order[static_cast<std::size_t>(position)]);
  }
  std::size_t bytes() const;  // CPU + GL buffer
};

// Groups `cloud` into cells of `cull_cell` metres (0: none) and uploads it into a new buffer of
// the current context, in pieces, so no second copy of the whole cloud is ever held. The buffer
// is complete (glFinish) when this returns, so other contexts of the share group may draw it.
PointBuffer make_point_buffer(const PointCloud& cloud, double cull_cell);

// A vertex array of the current context reading `buffer` (vertex arrays are per context).
GlName<glDeleteVertexArrays> make_point_vertex_array(const PointBuffer& buffer);

}  // namespace coloc::registration::render::detail
