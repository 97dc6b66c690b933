#pragma once
// Private to the renderer: an OSMesa context with the GL helpers the renderer needs. Not a
// public header of coloc_render (it includes GL).

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
// osmesa.h includes GL/gl.h; glext.h adds the GL 2+ prototypes that libOSMesa exports.
#include <GL/glext.h>

#include <array>
#include <string>

namespace coloc::registration::render::detail {

// Owns one OSMesa context (GL 4.5 compatibility profile on llvmpipe). Rendering goes into
// framebuffer objects, so the context's own buffer is a 1x1 dummy.
class GlContext {
 public:
  GlContext();
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void make_current();

 private:
  OSMesaContext context_ = nullptr;
  std::array<unsigned char, 4> dummy_{};
};

// Compiles and links a vertex + fragment shader; throws coloc::Error with the GL log.
GLuint build_program(const char* vertex_source, const char* fragment_source, const char* name);

// Throws coloc::Error naming `what` when glGetError reports an error.
void check_gl(const char* what);

}  // namespace coloc::registration::render::detail
