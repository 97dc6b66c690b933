#pragma once
// Private to the renderer: an OSMesa context with the GL helpers the renderer needs. Not a
// public header of coloc_render (it includes GL).

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
// osmesa.h includes GL/gl.h; glext.h adds the GL 2+ prototypes that libOSMesa exports.
#include <GL/glext.h>

#include <array>
#include <string>
#include <utility>

namespace coloc::registration::render::detail {

// Owns one OSMesa context (GL 4.5 compatibility profile on llvmpipe). Rendering goes into
// framebuffer objects, so the context's own buffer is a 1x1 dummy. A context made with `share`
// joins its share group: buffers, textures and programs are visible to both (vertex arrays and
// framebuffers are not: GL keeps container objects per context). Mesa reference-counts the group,
// so either context may be destroyed first; keeping a shared object alive while another context
// draws it is the owner's job.
class GlContext {
 public:
  explicit GlContext(const GlContext* share = nullptr);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void make_current();
  // Leaves no context current in this thread when this one is, so a context that only holds
  // shared objects is never current in two threads.
  void release();

 private:
  OSMesaContext context_ = nullptr;
  std::array<unsigned char, 4> dummy_{};
};

// One GL object name (a buffer or a vertex array), deleted by the destructor. Deletion needs a
// context current that can see the name (its share group for a buffer, its own context for a
// vertex array): the owner resets it with that context current.
template <void (*Delete)(GLsizei, const GLuint*)>
class GlName {
 public:
  GlName() = default;
  explicit GlName(GLuint id) : id_(id) {}
  ~GlName() { reset(); }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  GlName(GlName&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  GlName& operator=(GlName&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, 0);
    }
    return *this;
  }
  void reset() {
    if (id_ != 0) Delete(1, &id_);
    id_ = 0;
  }
  GLuint get() const { return id_; }

 private:
  GLuint id_ = 0;
};

inline GlName<glDeleteBuffers> gen_buffer() {
  GLuint id = 0;
  glGenBuffers(1, &id);
  return GlName<glDeleteBuffers>(id);
}

inline GlName<glDeleteVertexArrays> gen_vertex_array() {
  GLuint id = 0;
  glGenVertexArrays(1, &id);
  return GlName<glDeleteVertexArrays>(id);
}

// Compiles and links a vertex + fragment shader; throws coloc::Error with the GL log.
GLuint build_program(const char* vertex_source, const char* fragment_source, const char* name);

// Throws coloc::Error naming `what` when glGetError reports an error.
void check_gl(const char* what);

}  // namespace coloc::registration::render::detail
