#include "registration/render/renderer.hpp"

#include <cmath>
#include <cstddef>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "registration/render/cloud_cells.hpp"
#include "registration/render/distortion_warp.hpp"
#include "registration/render/gl_context.hpp"
#include "registration/render/point_buffer.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::render {
namespace {

constexpr const char* kMeshVertex = R"(#version 330
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec3 a_tint;
uniform mat4 u_cam_from_world;
uniform mat4 u_proj;
out vec3 v_pcam;
out vec2 v_uv;
out vec3 v_tint;
void main() {
  vec4 pc = u_cam_from_world * vec4(a_pos, 1.0);
  v_pcam = pc.xyz;
  v_uv = a_uv;
  v_tint = a_tint;
  gl_Position = u_proj * pc;
})";

constexpr const char* kMeshFragment = R"(#version 330
in vec3 v_pcam;
in vec2 v_uv;
in vec3 v_tint;
uniform sampler2D u_texture;
uniform int u_textured;
layout(location = 0) out vec4 o_colour;
layout(location = 1) out vec4 o_pcam;
layout(location = 2) out int o_index;
void main() {
  vec3 c = v_tint;
  if (u_textured != 0) c *= texture(u_texture, v_uv).rgb;
  o_colour = vec4(c, 1.0);
  o_pcam = vec4(v_pcam, 1.0);
  o_index = -1;
})";

constexpr const char* kPointVertex = R"(#version 330
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_colour;
layout(location = 2) in float a_splat;
uniform mat4 u_cam_from_world;
uniform mat4 u_proj;
uniform float u_focal;
uniform float u_max_pixels;
flat out vec3 v_world;
flat out float v_depth;
flat out vec3 v_colour;
flat out int v_index;
void main() {
  vec4 pc = u_cam_from_world * vec4(a_pos, 1.0);
  v_world = a_pos;
  v_depth = pc.z;
  v_colour = a_colour;
  v_index = gl_VertexID;
  gl_Position = u_proj * pc;
  gl_PointSize = clamp(u_focal * a_splat / max(pc.z, 1e-6), 1.0, u_max_pixels);
})";

// The position attachment holds (world point, depth) for a splat, where the mesh writes
// (camera-frame point, 1): flat varyings carry the vertex's position with its exact float bits,
// so read_back needs no CPU copy of the cloud's points (12 B per point).
constexpr const char* kPointFragment = R"(#version 330
flat in vec3 v_world;
flat in float v_depth;
flat in vec3 v_colour;
flat in int v_index;
layout(location = 0) out vec4 o_colour;
layout(location = 1) out vec4 o_pcam;
layout(location = 2) out int o_index;
void main() {
  o_colour = vec4(v_colour, 1.0);
  o_pcam = vec4(v_world, v_depth);
  o_index = v_index;
})";

// OpenGL projection for a pinhole camera whose pixel centres sit at integer coordinates. Row v of
// the image becomes row v of the framebuffer (y_ndc grows with v), so readback needs no flip.
Eigen::Matrix4f projection(const PinholeCamera& c, double n, double f) {
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  p(0, 0) = 2.0 * c.fx / c.width;
  p(0, 2) = 2.0 * (c.cx + 0.5) / c.width - 1.0;
  p(1, 1) = 2.0 * c.fy / c.height;
  p(1, 2) = 2.0 * (c.cy + 0.5) / c.height - 1.0;
  p(2, 2) = (f + n) / (f - n);
  p(2, 3) = -2.0 * f * n / (f - n);
  p(3, 2) = 1.0;
  return p.cast<float>();
}

struct MeshBuffers {
  GLuint vao = 0;
  GLuint vbo = 0;
  struct Part {
    GLuint ibo = 0;
    GLsizei count = 0;
    GLuint texture = 0;  // 0: untextured
  };
  std::vector<Part> parts;
  std::vector<GLuint> textures;
};

struct Framebuffer {
  GLuint fbo = 0;
  std::array<GLuint, 4> renderbuffers{};  // colour, position, index, depth
  int width = 0;
  int height = 0;
};

}  // namespace

void RenderOptions::check() const {
  if (!(near_plane > 0.0)) throw Error("near_plane must be > 0", {.field = "near_plane"});
  if (!(far_plane > near_plane)) {
    throw Error("far_plane must exceed near_plane", {.field = "far_plane"});
  }
  if (supersample < 1 || supersample % 2 == 0 || supersample > 7) {
    throw Error("supersample must be odd, 1..7", {.field = "supersample"});
  }
  if (anisotropy < 1 || anisotropy > 16) {
    throw Error("anisotropy must be in 1..16", {.field = "anisotropy"});
  }
  if (!(cull_cell >= 0.0)) throw Error("cull_cell must be >= 0", {.field = "cull_cell"});
}

struct SharedPointCloud::Impl {
  detail::GlContext context;  // the share group's first context; current only here
  detail::PointBuffer buffer;

  Impl(const PointCloud& cloud, const RenderOptions& options) {
    options.check();
    cloud.check();
    buffer = detail::make_point_buffer(cloud, options.cull_cell);
    context.release();
  }

  ~Impl() {
    context.make_current();
    buffer.vbo.reset();
    context.release();
  }
};

SharedPointCloud::SharedPointCloud(const PointCloud& cloud, const RenderOptions& options)
    : impl_(std::make_unique<Impl>(cloud, options)) {}
SharedPointCloud::~SharedPointCloud() = default;

std::size_t SharedPointCloud::size() const {
  return static_cast<std::size_t>(impl_->buffer.count);
}

std::size_t SharedPointCloud::bytes() const {
  return impl_->buffer.bytes();
}

struct Renderer::Impl {
  RenderOptions options;
  // The shared cloud drawn, if any. Declared before `context` so that the share group's first
  // context outlives this one (Mesa would cope, but then deletion order is plain to read).
  std::shared_ptr<const SharedPointCloud> shared;
  detail::GlContext context;
  GLuint mesh_program = 0;
  GLuint point_program = 0;
  MeshBuffers mesh;
  std::optional<detail::PointBuffer> own_cloud;    // set_point_cloud's, in this context
  const detail::PointBuffer* cloud = nullptr;      // own_cloud or shared's; null: none
  detail::GlName<glDeleteVertexArrays> cloud_vao;  // this context's view of *cloud
  Framebuffer framebuffer;
  DistortionWarp warp;

  Impl(RenderOptions o, std::shared_ptr<const SharedPointCloud> s)
      : options(o), shared(std::move(s)), context(shared ? &shared->impl_->context : nullptr) {
    options.check();
    mesh_program = detail::build_program(kMeshVertex, kMeshFragment, "mesh");
    point_program = detail::build_program(kPointVertex, kPointFragment, "points");
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    glEnable(GL_PROGRAM_POINT_SIZE);
    glDisable(GL_DITHER);
    glDisable(GL_MULTISAMPLE);
    detail::check_gl("renderer setup");
    if (shared) use_cloud(shared->impl_->buffer);
  }

  ~Impl() {
    context.make_current();
    release_mesh();
    release_framebuffer();
    glDeleteProgram(mesh_program);
    glDeleteProgram(point_program);
    release_cloud();  // last: dropping a shared cloud may leave no context current
  }

  void release_mesh() {
    for (auto& part : mesh.parts)
      glDeleteBuffers(1, &part.ibo);
    if (!mesh.textures.empty()) {
      glDeleteTextures(static_cast<GLsizei>(mesh.textures.size()), mesh.textures.data());
    }
    glDeleteBuffers(1, &mesh.vbo);
    glDeleteVertexArrays(1, &mesh.vao);
    mesh = {};
  }

  // Needs this context current; it is current again on return.
  void release_cloud() {
    cloud_vao.reset();
    cloud = nullptr;
    own_cloud.reset();
    if (shared) {
      shared.reset();  // the last holder deletes the buffer in the cloud's own context
      context.make_current();
    }
  }

  void use_cloud(const detail::PointBuffer& buffer) {
    cloud = &buffer;
    cloud_vao = detail::make_point_vertex_array(buffer);
  }

  void release_framebuffer() {
    if (framebuffer.fbo == 0) return;
    glDeleteRenderbuffers(4, framebuffer.renderbuffers.data());
    glDeleteFramebuffers(1, &framebuffer.fbo);
    framebuffer = {};
  }

  GLuint upload_texture(const cv::Mat& image) const {
    cv::Mat rgb = image.isContinuous() ? image : image.clone();
    GLuint id = 0;
    glGenTextures(1, &id);
    glBindTexture(GL_TEXTURE_2D, id);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, rgb.cols, rgb.rows, 0, GL_RGB, GL_UNSIGNED_BYTE,
                 rgb.data);
    glGenerateMipmap(GL_TEXTURE_2D);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    detail::check_gl("texture upload");
    if (options.anisotropy > 1) {
      glTexParameterf(GL_TEXTURE_2D, GL_TEXTURE_MAX_ANISOTROPY_EXT,
                      static_cast<float>(options.anisotropy));
      glGetError();  // anisotropic filtering is optional: ignore if unsupported
    }
    return id;
  }

  void upload_mesh(const TexturedMesh& m) {
    release_mesh();
    std::vector<float> interleaved;
    interleaved.reserve(m.vertices.size() * 8);
    for (std::size_t i = 0; i < m.vertices.size(); ++i) {
      interleaved.insert(interleaved.end(),
                         {m.vertices[i].x(), m.vertices[i].y(), m.vertices[i].z(), m.uvs[i].x(),
                          m.uvs[i].y(), m.tints[i].x(), m.tints[i].y(), m.tints[i].z()});
    }
    glGenVertexArrays(1, &mesh.vao);
    glBindVertexArray(mesh.vao);
    glGenBuffers(1, &mesh.vbo);
    glBindBuffer(GL_ARRAY_BUFFER, mesh.vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)),
                 interleaved.data(), GL_STATIC_DRAW);
    const GLsizei stride = 8 * sizeof(float);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<const void*>(3 * sizeof(float)));
    glEnableVertexAttribArray(2);
    glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride,
                          reinterpret_cast<const void*>(5 * sizeof(float)));
    glBindVertexArray(0);
    for (const cv::Mat& t : m.textures)
      mesh.textures.push_back(upload_texture(t));
    for (const auto& part : m.parts) {
      MeshBuffers::Part p;
      p.count = static_cast<GLsizei>(part.indices.size());
      p.texture = part.texture >= 0 ? mesh.textures[static_cast<std::size_t>(part.texture)] : 0;
      glGenBuffers(1, &p.ibo);
      glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, p.ibo);
      glBufferData(GL_ELEMENT_ARRAY_BUFFER,
                   static_cast<GLsizeiptr>(part.indices.size() * sizeof(std::uint32_t)),
                   part.indices.data(), GL_STATIC_DRAW);
      mesh.parts.push_back(p);
    }
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, 0);
    detail::check_gl("mesh upload");
  }

  void upload_cloud(const PointCloud& c) {
    release_cloud();
    own_cloud = detail::make_point_buffer(c, options.cull_cell);
    use_cloud(*own_cloud);
  }

  void ensure_framebuffer(int width, int height) {
    if (framebuffer.fbo != 0 && framebuffer.width == width && framebuffer.height == height) return;
    release_framebuffer();
    glGenFramebuffers(1, &framebuffer.fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.fbo);
    glGenRenderbuffers(4, framebuffer.renderbuffers.data());
    const std::array<GLenum, 4> formats{GL_RGBA8, GL_RGBA32F, GL_R32I, GL_DEPTH_COMPONENT32F};
    const std::array<GLenum, 4> attachments{GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                            GL_COLOR_ATTACHMENT2, GL_DEPTH_ATTACHMENT};
    for (std::size_t i = 0; i < 4; ++i) {
      glBindRenderbuffer(GL_RENDERBUFFER, framebuffer.renderbuffers[i]);
      glRenderbufferStorage(GL_RENDERBUFFER, formats[i], width, height);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, attachments[i], GL_RENDERBUFFER,
                                framebuffer.renderbuffers[i]);
    }
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw Error("OSMesa: framebuffer of " + std::to_string(width) + "x" + std::to_string(height) +
                  " is incomplete");
    }
    framebuffer.width = width;
    framebuffer.height = height;
    detail::check_gl("framebuffer setup");
  }

  void set_common_uniforms(GLuint program, const Eigen::Matrix4f& cam_from_world,
                           const Eigen::Matrix4f& proj) const {
    glUseProgram(program);
    glUniformMatrix4fv(glGetUniformLocation(program, "u_cam_from_world"), 1, GL_FALSE,
                       cam_from_world.data());
    glUniformMatrix4fv(glGetUniformLocation(program, "u_proj"), 1, GL_FALSE, proj.data());
  }

  // Draws into the framebuffer with an ideal (distortion-free) camera of the render size.
  void draw(const PinholeCamera& ideal, const SE3& cam_from_world, Layer layers) {
    ensure_framebuffer(ideal.width, ideal.height);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.fbo);
    const GLenum buffers[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glDrawBuffers(3, buffers);
    glViewport(0, 0, ideal.width, ideal.height);
    const float bg[] = {options.background[0] / 255.0f, options.background[1] / 255.0f,
                        options.background[2] / 255.0f, 1.0f};
    const float zero[] = {0.0f, 0.0f, 0.0f, 0.0f};
    const GLint minus_one[] = {-1, -1, -1, -1};
    glClearBufferfv(GL_COLOR, 0, bg);
    glClearBufferfv(GL_COLOR, 1, zero);
    glClearBufferiv(GL_COLOR, 2, minus_one);
    glClear(GL_DEPTH_BUFFER_BIT);

    const Eigen::Matrix4f pose = cam_from_world.matrix().cast<float>();
    const Eigen::Matrix4f proj = projection(ideal, options.near_plane, options.far_plane);
    const auto has = [&](Layer l) {
      return (static_cast<unsigned>(layers) & static_cast<unsigned>(l)) != 0;
    };
    if (has(Layer::kMesh) && mesh.vao != 0) {
      set_common_uniforms(mesh_program, pose, proj);
      glUniform1i(glGetUniformLocation(mesh_program, "u_texture"), 0);
      glActiveTexture(GL_TEXTURE0);
      glBindVertexArray(mesh.vao);
      for (const auto& part : mesh.parts) {
        glUniform1i(glGetUniformLocation(mesh_program, "u_textured"), part.texture != 0);
        glBindTexture(GL_TEXTURE_2D, part.texture);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, part.ibo);
        glDrawElements(GL_TRIANGLES, part.count, GL_UNSIGNED_INT, nullptr);
      }
    }
    if (has(Layer::kPoints) && cloud != nullptr) {
      set_common_uniforms(point_program, pose, proj);
      glUniform1f(glGetUniformLocation(point_program, "u_focal"),
                  static_cast<float>(std::max(ideal.fx, ideal.fy)));
      glUniform1f(glGetUniformLocation(point_program, "u_max_pixels"), cloud->max_pixels);
      glBindVertexArray(cloud_vao.get());
      if (cloud->cells.cells.empty()) {
        glDrawArrays(GL_POINTS, 0, cloud->count);
      } else {
        for (const auto& [first, count] :
             visible_ranges(cloud->cells, ideal, cam_from_world, options.near_plane,
                            options.far_plane, 0.5 * cloud->max_pixels + 1.0))
          glDrawArrays(GL_POINTS, static_cast<GLint>(first), static_cast<GLsizei>(count));
      }
    }
    glBindVertexArray(0);
    glFinish();
    detail::check_gl("draw");
  }

  // Reads the framebuffer into colour (full render size) and the other layers at the centre
  // samples of each supersampled pixel.
  RenderResult read_back(const SE3& world_from_cam, int s) {
    const int w = framebuffer.width;
    const int h = framebuffer.height;
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    cv::Mat colour(h, w, CV_8UC3);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, w, h, GL_RGB, GL_UNSIGNED_BYTE, colour.data);
    // Mesh: (camera-frame point, 1); splat: (world point, depth); nothing: 0.
    cv::Mat pcam(h, w, CV_32FC4);
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, pcam.data);
    cv::Mat index(h, w, CV_32S);
    glReadBuffer(GL_COLOR_ATTACHMENT2);
    glReadPixels(0, 0, w, h, GL_RED_INTEGER, GL_INT, index.data);
    detail::check_gl("read back");

    RenderResult r;
    if (s == 1) {
      r.colour = colour;
    } else {
      cv::resize(colour, r.colour, cv::Size(w / s, h / s), 0, 0, cv::INTER_AREA);
    }
    const int ow = w / s;
    const int oh = h / s;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    r.depth = cv::Mat(oh, ow, CV_32F);
    r.points = cv::Mat(oh, ow, CV_32FC3);
    r.index = cv::Mat(oh, ow, CV_32S);
    const Eigen::Matrix3d rot = world_from_cam.rotation();
    const Eigen::Vector3d trans = world_from_cam.translation();
    for (int v = 0; v < oh; ++v) {
      const int sv = v * s + s / 2;
      for (int u = 0; u < ow; ++u) {
        const int su = u * s + s / 2;
        const int id = index.at<int>(sv, su);  // upload position
        const bool splat = id >= 0 && cloud != nullptr;
        r.index.at<int>(v, u) = splat ? cloud->cloud_index(id) : -1;
        auto& out = r.points.at<cv::Vec3f>(v, u);
        const cv::Vec4f& pc = pcam.at<cv::Vec4f>(sv, su);
        if (pc[3] <= 0.0f) {
          r.depth.at<float>(v, u) = 0.0f;
          out = cv::Vec3f(nan, nan, nan);
          continue;
        }
        if (splat) {
          r.depth.at<float>(v, u) = pc[3];
          out = cv::Vec3f(pc[0], pc[1], pc[2]);
        } else {
          r.depth.at<float>(v, u) = pc[2];
          const Eigen::Vector3d p = rot * Eigen::Vector3d(pc[0], pc[1], pc[2]) + trans;
          out = cv::Vec3f(static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()));
        }
      }
    }
    return r;
  }
};

Renderer::Renderer(RenderOptions options) : impl_(std::make_unique<Impl>(options, nullptr)) {}

Renderer::Renderer(RenderOptions options, std::shared_ptr<const SharedPointCloud> cloud) {
  if (!cloud) throw Error("Renderer: no shared point cloud", {.field = "cloud"});
  impl_ = std::make_unique<Impl>(options, std::move(cloud));
}
Renderer::~Renderer() = default;
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;

const RenderOptions& Renderer::options() const {
  return impl_->options;
}

void Renderer::set_mesh(const TexturedMesh& mesh) {
  mesh.check();
  impl_->context.make_current();
  impl_->upload_mesh(mesh);
}

void Renderer::set_point_cloud(const PointCloud& cloud) {
  cloud.check();
  impl_->context.make_current();
  impl_->upload_cloud(cloud);
}

void Renderer::clear_mesh() {
  impl_->context.make_current();
  impl_->release_mesh();
}

void Renderer::clear_point_cloud() {
  impl_->context.make_current();
  impl_->release_cloud();
}

RenderResult Renderer::render(const PinholeCamera& camera, const SE3& cam_from_world,
                              Layer layers) {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0.0) || !(camera.fy > 0.0)) {
    throw Error("render: camera needs positive width, height, fx and fy", {.field = "camera"});
  }
  impl_->context.make_current();
  const int s = impl_->options.supersample;
  PinholeCamera ideal = camera;
  ideal.distortion = {};
  if (camera.has_distortion()) ideal = impl_->warp.prepare(camera);
  PinholeCamera big = ideal;
  big.width *= s;
  big.height *= s;
  big.fx *= s;
  big.fy *= s;
  big.cx = (ideal.cx + 0.5) * s - 0.5;
  big.cy = (ideal.cy + 0.5) * s - 0.5;
  if (std::max(big.width, big.height) > 16384) {
    throw Error("render: image too large for the rasterizer (16384 px max incl. supersampling)",
                {.field = "camera"});
  }
  impl_->draw(big, cam_from_world, layers);
  RenderResult r = impl_->read_back(cam_from_world.inverse(), s);
  if (camera.has_distortion()) r = impl_->warp.apply(r);
  return r;
}

}  // namespace coloc::registration::render
