#include "registration/render/gl_context.hpp"

#include <vector>

#include "slam/core/error.hpp"

namespace coloc::registration::render::detail {

GlContext::GlContext(const GlContext* share) {
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            0,
                            OSMESA_STENCIL_BITS,
                            0,
                            OSMESA_PROFILE,
                            OSMESA_COMPAT_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            3,
                            0};
  context_ = OSMesaCreateContextAttribs(attributes, share != nullptr ? share->context_ : nullptr);
  if (context_ == nullptr) {
    throw Error("OSMesa: cannot create a GL 3.3 compatibility context (is Mesa's llvmpipe there?)");
  }
  make_current();
}

GlContext::~GlContext() {
  if (context_ != nullptr) OSMesaDestroyContext(context_);
}

void GlContext::make_current() {
  if (OSMesaGetCurrentContext() == context_) return;
  if (!OSMesaMakeCurrent(context_, dummy_.data(), GL_UNSIGNED_BYTE, 1, 1)) {
    throw Error("OSMesa: cannot make the context current");
  }
}

void GlContext::release() {
  if (context_ != nullptr && OSMesaGetCurrentContext() == context_)
    OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0);
}

namespace {

GLuint compile(GLenum type, const char* source, const char* name) {
  const GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint length = 0;
    glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
    std::vector<char> log(static_cast<std::size_t>(length) + 1, '\0');
    glGetShaderInfoLog(shader, length, nullptr, log.data());
    glDeleteShader(shader);
    throw Error(std::string("shader '") + name + "' does not compile: " + log.data());
  }
  return shader;
}

}  // namespace

GLuint build_program(const char* vertex_source, const char* fragment_source, const char* name) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex_source, name);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, fragment_source, name);
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint length = 0;
    glGetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
    std::vector<char> log(static_cast<std::size_t>(length) + 1, '\0');
    glGetProgramInfoLog(program, length, nullptr, log.data());
    glDeleteProgram(program);
    throw Error(std::string("shader program '") + name + "' does not link: " + log.data());
  }
  return program;
}

void check_gl(const char* what) {
  const GLenum error = glGetError();
  if (error != GL_NO_ERROR) {
    throw Error(std::string("OpenGL error 0x") + std::to_string(error) + " in " + what);
  }
}

}  // namespace coloc::registration::render::detail
