#include "registration/twin/scene.hpp"

#include <opencv2/aruco.hpp>
#include <random>

#include "registration/twin/textures.hpp"
#include "slam/core/error.hpp"

namespace coloc::registration::twin {
namespace {

using Vec3 = Eigen::Vector3d;
using render::TexturedMesh;

constexpr int kWallTextures = 4;
constexpr int kFloorTextures = 2;
constexpr int kFurnitureTextures = 3;

// Collects quads into per-texture parts.
class MeshBuilder {
 public:
  MeshBuilder(TexturedMesh& mesh, double tile) : mesh_(mesh), tile_(tile) {}

  // Quad a, b, c, d (counter-clockwise seen from the front) with explicit uvs and one tint per
  // corner.
  void quad(int texture, const std::array<Vec3, 4>& p, const std::array<Eigen::Vector2f, 4>& uv,
            const std::array<float, 4>& tint) {
    auto& part = part_for(texture);
    const auto base = static_cast<std::uint32_t>(mesh_.vertices.size());
    for (int k = 0; k < 4; ++k) {
      mesh_.vertices.push_back(p[static_cast<std::size_t>(k)].cast<float>());
      mesh_.uvs.push_back(uv[static_cast<std::size_t>(k)]);
      mesh_.tints.push_back(Eigen::Vector3f::Constant(tint[static_cast<std::size_t>(k)]));
    }
    part.indices.insert(part.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }

  // A vertical wall quad from (x0,y0) to (x1,y1), z in [z0, z1], seen from the side `normal`
  // points to; texture coordinates in metres so neighbouring quads continue seamlessly.
  void wall(int texture, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double z0, double z1,
            const Eigen::Vector2d& normal, float shade) {
    const Eigen::Vector2d right(-normal.y(), normal.x());  // (-n) x z, as seen from the front
    const auto u = [&](const Eigen::Vector2d& p) {
      return static_cast<float>(p.dot(right) / tile_);
    };
    const auto v = [&](double z) { return static_cast<float>((tile_ - z) / tile_); };
    Eigen::Vector2d l = a, r = b;
    if (u(l) > u(r)) std::swap(l, r);
    // Darker near the floor: a cheap ambient-occlusion look.
    const float bottom = shade * static_cast<float>(z0 < 0.01 ? 0.72 : 0.9);
    quad(texture,
         {Vec3(l.x(), l.y(), z0), Vec3(r.x(), r.y(), z0), Vec3(r.x(), r.y(), z1),
          Vec3(l.x(), l.y(), z1)},
         {Eigen::Vector2f(u(l), v(z0)), Eigen::Vector2f(u(r), v(z0)), Eigen::Vector2f(u(r), v(z1)),
          Eigen::Vector2f(u(l), v(z1))},
         {bottom, bottom, shade, shade});
  }

  void horizontal(int texture, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double z,
                  float shade) {
    const auto uv = [&](double x, double y) {
      return Eigen::Vector2f(static_cast<float>(x / tile_), static_cast<float>(y / tile_));
    };
    quad(texture,
         {Vec3(lo.x(), lo.y(), z), Vec3(hi.x(), lo.y(), z), Vec3(hi.x(), hi.y(), z),
          Vec3(lo.x(), hi.y(), z)},
         {uv(lo.x(), lo.y()), uv(hi.x(), lo.y()), uv(hi.x(), hi.y()), uv(lo.x(), hi.y())},
         {shade, shade, shade, shade});
  }

  void box(const Box& b) {
    const Vec3& lo = b.min;
    const Vec3& hi = b.max;
    wall(b.texture, {lo.x(), lo.y()}, {hi.x(), lo.y()}, lo.z(), hi.z(), {0, -1}, 0.8f);
    wall(b.texture, {lo.x(), hi.y()}, {hi.x(), hi.y()}, lo.z(), hi.z(), {0, 1}, 0.85f);
    wall(b.texture, {lo.x(), lo.y()}, {lo.x(), hi.y()}, lo.z(), hi.z(), {-1, 0}, 0.75f);
    wall(b.texture, {hi.x(), lo.y()}, {hi.x(), hi.y()}, lo.z(), hi.z(), {1, 0}, 0.9f);
    horizontal(b.texture, lo.head<2>(), hi.head<2>(), hi.z(), 1.0f);
  }

 private:
  TexturedMesh::Part& part_for(int texture) {
    for (auto& p : mesh_.parts) {
      if (p.texture == texture) return p;
    }
    mesh_.parts.push_back({texture, {}});
    return mesh_.parts.back();
  }

  TexturedMesh& mesh_;
  double tile_;
};

float wall_shade(int di, int dj) {
  if (di != 0) return di > 0 ? 0.92f : 0.8f;
  return dj > 0 ? 0.86f : 0.97f;
}

// Vertical faces, merged into runs along each grid line.
void add_walls(const FloorPlan& plan, MeshBuilder& mb) {
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  const double c = plan.cell;
  for (const auto& d : dirs) {
    const bool along_y = d[0] != 0;
    const int lines = along_y ? plan.nx : plan.ny;
    const int length = along_y ? plan.ny : plan.nx;
    for (int line = 0; line < lines; ++line) {
      struct Run {
        int start = -1;
        double z0 = 0, z1 = 0;
        int texture = -1;
      } run;
      const auto flush = [&](int end) {
        if (run.start < 0) return;
        Eigen::Vector2d a, b;
        if (along_y) {
          const double x = (line + 0.5 + 0.5 * d[0]) * c;
          a = {x, run.start * c};
          b = {x, end * c};
        } else {
          const double y = (line + 0.5 + 0.5 * d[1]) * c;
          a = {run.start * c, y};
          b = {end * c, y};
        }
        mb.wall(run.texture, a, b, run.z0, run.z1, {-d[0], -d[1]}, wall_shade(d[0], d[1]));
        run = {};
      };
      for (int k = 0; k <= length; ++k) {
        int texture = -1;
        double z0 = 0, z1 = 0;
        const int i = along_y ? line : k, j = along_y ? k : line;
        if (k < length && plan.free(i, j)) {
          const auto cell = static_cast<std::size_t>(plan.index(i, j));
          const double h = plan.ceiling[cell];
          const int ni = i + d[0], nj = j + d[1];
          const double nh =
              plan.free(ni, nj) ? plan.ceiling[static_cast<std::size_t>(plan.index(ni, nj))] : 0.0;
          if (nh < h - 1e-6) {
            texture = plan.rooms[static_cast<std::size_t>(plan.label[cell])].wall_texture;
            z0 = nh;
            z1 = h;
          }
        }
        if (run.start >= 0 && (texture != run.texture || z0 != run.z0 || z1 != run.z1)) flush(k);
        if (texture >= 0 && run.start < 0) run = {k, z0, z1, texture};
      }
    }
  }
}

// Floors and ceilings, merged into runs along rows.
void add_floors(const FloorPlan& plan, MeshBuilder& mb, int ceiling_texture) {
  const double c = plan.cell;
  for (int j = 0; j < plan.ny; ++j) {
    int start = -1;
    int key_room = -2;
    float key_h = 0;
    for (int i = 0; i <= plan.nx; ++i) {
      int room = -1;
      float h = 0;
      if (i < plan.nx && plan.free(i, j)) {
        room = plan.label[static_cast<std::size_t>(plan.index(i, j))];
        h = plan.ceiling[static_cast<std::size_t>(plan.index(i, j))];
      }
      if (start >= 0 && (room != key_room || h != key_h)) {
        const Eigen::Vector2d lo(start * c, j * c), hi(i * c, (j + 1) * c);
        mb.horizontal(plan.rooms[static_cast<std::size_t>(key_room)].floor_texture, lo, hi, 0.0,
                      0.8f);
        mb.horizontal(ceiling_texture, lo, hi, key_h, 0.98f);
        start = -1;
      }
      if (room >= 0 && start < 0) {
        start = i;
        key_room = room;
        key_h = h;
      }
    }
  }
}

void add_markers(const SceneOptions& o, const FloorPlan& plan, TexturedMesh& mesh, MeshBuilder& mb,
                 std::vector<MarkerTruth>& truth) {
  const int cells = marker_bits(o.dictionary) + 2;
  const double h = 0.5 * o.marker_size;
  const double outer = h * (cells + 2.0) / cells;  // one white module of margin
  for (const MarkerPlacement& m : plan.markers) {
    const int texture = static_cast<int>(mesh.textures.size());
    mesh.textures.push_back(make_marker_texture(o.dictionary, m.id, 24, 1));
    const Vec3 z = m.normal;
    const Vec3 up = Vec3::UnitZ();
    const Vec3 right = (-z).cross(up);
    Eigen::Matrix3d r;
    r << right, up, z;
    MarkerTruth t;
    t.id = m.id;
    t.size = o.marker_size;
    t.world_from_marker = SE3(SO3::from_matrix(r), m.centre);
    t.corners = {m.centre - h * right + h * up, m.centre + h * right + h * up,
                 m.centre + h * right - h * up, m.centre - h * right - h * up};
    truth.push_back(t);
    mb.quad(texture,
            {m.centre - outer * right - outer * up, m.centre + outer * right - outer * up,
             m.centre + outer * right + outer * up, m.centre - outer * right + outer * up},
            {Eigen::Vector2f(0, 1), Eigen::Vector2f(1, 1), Eigen::Vector2f(1, 0),
             Eigen::Vector2f(0, 0)},
            {1.0f, 1.0f, 1.0f, 1.0f});
  }
}

}  // namespace

void SceneOptions::check() const {
  if (!(marker_size > 0.01 && marker_size < 2.0)) {
    throw Error("marker_size must be in (0.01, 2) metres", {.field = "marker_size"});
  }
  if (texture_size < 64 || texture_size > 4096) {
    throw Error("texture_size must be in 64..4096", {.field = "texture_size"});
  }
  if (!(texture_tile > 0.1)) throw Error("texture_tile must be > 0.1 m", {.field = "texture_tile"});
  if (dictionary < cv::aruco::DICT_4X4_50 || dictionary > cv::aruco::DICT_APRILTAG_36h11) {
    throw Error("dictionary is not an OpenCV predefined dictionary id", {.field = "dictionary"});
  }
}

TwinScene build_scene(const SceneOptions& options, std::uint64_t seed) {
  options.check();
  TwinScene scene;
  scene.dictionary = options.dictionary;
  std::mt19937_64 rng(seed);
  FloorPlanOptions fo;
  fo.preset = options.preset;
  fo.marker_dictionary_size =
      cv::aruco::getPredefinedDictionary(options.dictionary)->bytesList.rows;
  fo.marker_size = options.marker_size;
  fo.wall_textures = kWallTextures;
  fo.floor_textures = kFloorTextures;
  fo.furniture_textures = kFurnitureTextures;
  scene.plan = make_floor_plan(fo, rng);
  if (options.moved_furniture > 0)
    scene.moved_furniture = move_furniture(scene.plan, options.moved_furniture, 0.8);

  // Texture ids: walls, floors, furniture, ceiling, then one per marker.
  const int n = options.texture_size;
  auto& tex = scene.mesh.textures;
  const TextureKind walls[kWallTextures] = {TextureKind::kPlaster, TextureKind::kBrick,
                                            TextureKind::kPlaster, TextureKind::kPlaster};
  for (int k = 0; k < kWallTextures; ++k)
    tex.push_back(make_texture(walls[k], n, seed * 31 + k));
  tex.push_back(make_texture(TextureKind::kWood, n, seed * 31 + 10));
  tex.push_back(make_texture(TextureKind::kCarpet, n, seed * 31 + 11));
  tex.push_back(make_texture(TextureKind::kWood, n / 2, seed * 31 + 20));
  tex.push_back(make_texture(TextureKind::kFabric, n / 2, seed * 31 + 21));
  tex.push_back(make_texture(TextureKind::kShelf, n / 2, seed * 31 + 22));
  const int ceiling = static_cast<int>(tex.size());
  tex.push_back(make_texture(TextureKind::kCeiling, n / 2, seed * 31 + 30));

  MeshBuilder mb(scene.mesh, options.texture_tile);
  add_walls(scene.plan, mb);
  add_floors(scene.plan, mb, ceiling);
  for (const Box& b : scene.plan.furniture)
    mb.box(b);
  add_markers(options, scene.plan, scene.mesh, mb, scene.markers);
  scene.mesh.check();
  return scene;
}

}  // namespace coloc::registration::twin
