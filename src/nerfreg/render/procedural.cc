#include "nerfreg/render/procedural.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/render/renderer.h"
#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

void AddQuadGrid(TriangleMesh* m, const Eigen::Vector3f& origin, const Eigen::Vector3f& du, const Eigen::Vector3f& dv,
                 int n, const Eigen::Vector3f& color) {
  const int base = static_cast<int>(m->vertices.size());
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      m->vertices.push_back(origin + du * (float(i) / n) + dv * (float(j) / n));
      m->vertex_colors.push_back(color);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = base + j * (n + 1) + i, b = a + 1, c = a + (n + 1), d = c + 1;
      m->triangles.push_back({a, b, d});
      m->triangles.push_back({a, d, c});
    }
}

Eigen::Vector3f HsvToRgb(float h, float s, float v) {
  const float c = v * s, x = c * (1 - std::abs(std::fmod(h * 6, 2.f) - 1)), m = v - c;
  Eigen::Vector3f rgb;
  const int sector = static_cast<int>(h * 6) % 6;
  switch (sector) {
    case 0:
      rgb = {c, x, 0};
      break;
    case 1:
      rgb = {x, c, 0};
      break;
    case 2:
      rgb = {0, c, x};
      break;
    case 3:
      rgb = {0, x, c};
      break;
    case 4:
      rgb = {x, 0, c};
      break;
    default:
      rgb = {c, 0, x};
  }
  return rgb + Eigen::Vector3f::Constant(m);
}

TriangleMesh RandomPrimitive(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0, 1);
  const Eigen::Vector3f color = HsvToRgb(u(rng), 0.45f + 0.5f * u(rng), 0.55f + 0.45f * u(rng));
  const int kind = std::uniform_int_distribution<int>(0, 3)(rng);
  const float size = 0.25f + 0.35f * u(rng);
  switch (kind) {
    case 0:
      return MakeBox({size * (0.5f + u(rng)), size * (0.5f + u(rng)), size * (0.5f + u(rng))}, color);
    case 1:
      return MakeSphere(size, color);
    case 2:
      return MakeCylinder(size * 0.6f, size * (1.0f + 1.5f * u(rng)), color);
    default:
      return MakeTorus(size, size * (0.2f + 0.2f * u(rng)), color);
  }
}

Eigen::Matrix3f RandomRotationMatrix(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  return RandomRotation(u(rng), u(rng), u(rng)).toRotationMatrix().cast<float>();
}

// Recolours a backdrop of MakeBackdrop(width, height, ...) for the material (see SceneMaterial):
// `tile` scales the repetitive tiles (1: 0.6 x 0.6 units with 0.1-wide grout, 6 x 6 cells of 0.1).
void ApplyBackdropMaterial(TriangleMesh* backdrop, SceneMaterial material, float width, float height, float tile) {
  if (material == SceneMaterial::kLowTexture) {
    for (auto& c : backdrop->vertex_colors) c = Eigen::Vector3f(0.75f, 0.73f, 0.70f);
  } else if (material == SceneMaterial::kRepetitive) {
    // A grid every tile of which looks the same.
    for (size_t k = 0; k < backdrop->vertices.size(); ++k) {
      const int i = static_cast<int>(std::lround((backdrop->vertices[k].x() + width / 2) * 10.f / tile));
      const int j = static_cast<int>(std::lround((backdrop->vertices[k].z() + height / 2) * 10.f / tile));
      const bool grout = i % 6 == 0 || j % 6 == 0;
      const bool dark = ((i / 6) + (j / 6)) % 2 == 1;
      backdrop->vertex_colors[k] = grout  ? Eigen::Vector3f(0.15f, 0.15f, 0.18f)
                                   : dark ? Eigen::Vector3f(0.55f, 0.35f, 0.25f)
                                          : Eigen::Vector3f(0.85f, 0.8f, 0.7f);
    }
  }
}

}  // namespace

TriangleMesh MakeBox(const Eigen::Vector3f& e, const Eigen::Vector3f& color, int n) {
  TriangleMesh m;
  const float x = e.x(), y = e.y(), z = e.z();
  // Six faces, each an n x n grid, outward-facing (winding is irrelevant: rendering is two-sided).
  AddQuadGrid(&m, {-x, -y, -z}, {2 * x, 0, 0}, {0, 2 * y, 0}, n, color);
  AddQuadGrid(&m, {-x, -y, z}, {2 * x, 0, 0}, {0, 2 * y, 0}, n, color);
  AddQuadGrid(&m, {-x, -y, -z}, {2 * x, 0, 0}, {0, 0, 2 * z}, n, color);
  AddQuadGrid(&m, {-x, y, -z}, {2 * x, 0, 0}, {0, 0, 2 * z}, n, color);
  AddQuadGrid(&m, {-x, -y, -z}, {0, 2 * y, 0}, {0, 0, 2 * z}, n, color);
  AddQuadGrid(&m, {x, -y, -z}, {0, 2 * y, 0}, {0, 0, 2 * z}, n, color);
  return m;
}

TriangleMesh MakeSphere(float r, const Eigen::Vector3f& color, int rings, int segments) {
  TriangleMesh m;
  for (int i = 0; i <= rings; ++i) {
    const float th = float(M_PI) * i / rings;
    for (int j = 0; j < segments; ++j) {
      const float ph = 2 * float(M_PI) * j / segments;
      m.vertices.push_back(r * Eigen::Vector3f(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)));
      m.vertex_colors.push_back(color);
    }
  }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const int a = i * segments + j, b = i * segments + (j + 1) % segments;
      const int c = a + segments, d = b + segments;
      m.triangles.push_back({a, c, b});
      m.triangles.push_back({b, c, d});
    }
  return m;
}

TriangleMesh MakeCylinder(float r, float h, const Eigen::Vector3f& color, int segments) {
  TriangleMesh m;
  const int rows = 4;
  for (int i = 0; i <= rows; ++i)
    for (int j = 0; j < segments; ++j) {
      const float ph = 2 * float(M_PI) * j / segments;
      m.vertices.push_back({r * std::cos(ph), r * std::sin(ph), -h / 2 + h * i / rows});
      m.vertex_colors.push_back(color);
    }
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < segments; ++j) {
      const int a = i * segments + j, b = i * segments + (j + 1) % segments;
      m.triangles.push_back({a, b, a + segments});
      m.triangles.push_back({b, b + segments, a + segments});
    }
  for (int cap = 0; cap < 2; ++cap) {  // fans closing both ends
    const int centre = static_cast<int>(m.vertices.size());
    m.vertices.push_back({0, 0, cap ? h / 2 : -h / 2});
    m.vertex_colors.push_back(color);
    const int ring = cap ? rows * segments : 0;
    for (int j = 0; j < segments; ++j) m.triangles.push_back({centre, ring + j, ring + (j + 1) % segments});
  }
  return m;
}

TriangleMesh MakeTorus(float R, float r, const Eigen::Vector3f& color, int rings, int segments) {
  TriangleMesh m;
  for (int i = 0; i < rings; ++i) {
    const float u = 2 * float(M_PI) * i / rings;
    for (int j = 0; j < segments; ++j) {
      const float v = 2 * float(M_PI) * j / segments;
      m.vertices.push_back({(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v)});
      m.vertex_colors.push_back(color);
    }
  }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const int a = i * segments + j, b = i * segments + (j + 1) % segments;
      const int c = ((i + 1) % rings) * segments + j, d = ((i + 1) % rings) * segments + (j + 1) % segments;
      m.triangles.push_back({a, c, b});
      m.triangles.push_back({b, c, d});
    }
  return m;
}

TriangleMesh MakeBackdrop(float width, float height, int cx, int cz, float pattern_scale) {
  TriangleMesh m;
  for (int j = 0; j <= cz; ++j)
    for (int i = 0; i <= cx; ++i) {
      const Eigen::Vector3f p(-width / 2 + width * i / cx, 0, -height / 2 + height * j / cz);
      m.vertices.push_back(p);
      m.vertex_colors.push_back(ProceduralAlbedo(p, pattern_scale));
    }
  for (int j = 0; j < cz; ++j)
    for (int i = 0; i < cx; ++i) {
      const int a = j * (cx + 1) + i, b = a + 1, c = a + (cx + 1), d = c + 1;
      m.triangles.push_back({a, b, d});
      m.triangles.push_back({a, d, c});
    }
  return m;
}

void TransformMesh(TriangleMesh* mesh, const Eigen::Matrix3f& rotation, const Eigen::Vector3f& t, float scale) {
  for (auto& v : mesh->vertices) v = scale * (rotation * v) + t;
}

TriangleMesh ProceduralObject(unsigned seed) {
  std::mt19937 rng(seed * 2654435761u + 17u);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  const int count = std::uniform_int_distribution<int>(3, 8)(rng);
  TriangleMesh object;
  for (int k = 0; k < count; ++k) {
    TriangleMesh p = RandomPrimitive(rng);
    TransformMesh(&p, RandomRotationMatrix(rng), {u(rng), u(rng), u(rng)});
    object.Append(p);
  }
  NormalizeMesh(&object, 2.5f);
  return object;
}

TriangleMesh WithBackdrop(const TriangleMesh& mesh, float backdrop_y) {
  TriangleMesh scene = MakeBackdrop(12.f, 9.f, 120, 90, 2.0f);
  TransformMesh(&scene, Eigen::Matrix3f::Identity(), {0, backdrop_y, 0});
  TriangleMesh object = mesh;
  if (!object.HasColors()) {
    // Bake the procedural albedo into vertex colours so the union keeps a texture-like pattern.
    object.vertex_colors.clear();
    for (const auto& v : object.vertices) object.vertex_colors.push_back(ProceduralAlbedo(v, 4.0f));
  }
  scene.Append(object);
  return scene;
}

SceneMaterial ParseSceneMaterial(const std::string& name) {
  if (name == "textured") return SceneMaterial::kTextured;
  if (name == "low-texture") return SceneMaterial::kLowTexture;
  if (name == "repetitive") return SceneMaterial::kRepetitive;
  ThrowInputError("--material", "", "textured, low-texture or repetitive, got \"" + name + "\"");
}

float MaterialTextureModulation(SceneMaterial material) {
  switch (material) {
    case SceneMaterial::kLowTexture:
      return 0.03f;
    case SceneMaterial::kRepetitive:
      return 0.0f;
    default:
      return RenderOptions().texture_modulation;
  }
}

TriangleMesh ProceduralForwardScene(unsigned seed, float backdrop_y, SceneMaterial material) {
  std::mt19937 rng(seed * 2654435761u + 91u);
  std::uniform_real_distribution<float> u(0, 1);
  TriangleMesh scene = MakeBackdrop(12.f, 9.f, 120, 90, 1.5f + u(rng));
  ApplyBackdropMaterial(&scene, material, 12.f, 9.f, 1.f);
  TransformMesh(&scene, Eigen::Matrix3f::Identity(), {0, backdrop_y, 0});
  const int count = std::uniform_int_distribution<int>(3, 6)(rng);
  for (int k = 0; k < count; ++k) {
    TriangleMesh p = RandomPrimitive(rng);
    TransformMesh(&p, RandomRotationMatrix(rng), {-1.4f + 2.8f * u(rng), -1.5f + 2.7f * u(rng), -0.9f + 1.8f * u(rng)},
                  1.0f + 0.8f * u(rng));
    scene.Append(p);
  }
  return scene;
}

void LayeredSceneOptions::Check() const {
  if (!(near_depth > 0) || !(backdrop_depth > 2 * near_depth) || !(tan_half_fov_x > 0) || !(aspect > 0)) {
    throw std::invalid_argument("LayeredSceneOptions: out of range");
  }
}

TriangleMesh ProceduralLayeredScene(unsigned seed, SceneMaterial material, const LayeredSceneOptions& o) {
  o.Check();
  std::mt19937 rng(seed * 2654435761u + 53u);
  std::uniform_real_distribution<float> u(0, 1);
  // The backdrop fills the views with a margin for the path's extent and the wobble: the forward
  // scenes' backdrop (12 x 9 at 6 units) scaled with depth, its pattern (and tiles) alike.
  const float zoom = o.backdrop_depth / 6.f, cell = 0.1f * zoom;
  const float half_w = o.backdrop_depth * o.tan_half_fov_x * 1.35f + 1.f;
  const float half_h = o.backdrop_depth * o.tan_half_fov_x * o.aspect * 1.35f + 1.f;
  const int cells_x = static_cast<int>(std::ceil(2 * half_w / cell)),
            cells_z = static_cast<int>(std::ceil(2 * half_h / cell));
  TriangleMesh scene = MakeBackdrop(cells_x * cell, cells_z * cell, cells_x, cells_z, (1.5f + u(rng)) / zoom);
  ApplyBackdropMaterial(&scene, material, cells_x * cell, cells_z * cell, zoom);
  TransformMesh(&scene, Eigen::Matrix3f::Identity(), {0, o.camera_y + o.backdrop_depth, 0});
  const int count = std::uniform_int_distribution<int>(5, 9)(rng);
  const float log_near = std::log(o.near_depth), log_far = std::log(0.5f * o.backdrop_depth);
  for (int k = 0; k < count; ++k) {
    // The first object in the nearest layer, so the views' near / far ratio is the scene's.
    const float depth =
        k == 0 ? o.near_depth * (1.f + 0.3f * u(rng)) : std::exp(log_near + (log_far - log_near) * u(rng));
    const float half_x = depth * o.tan_half_fov_x, half_z = half_x * o.aspect;
    TriangleMesh p = RandomPrimitive(rng);
    // RandomPrimitive's sizes are 0.25-0.6 (up to 1 along a cylinder): at this scale an object
    // spans a tenth to a half of the view's width.
    const float scale = half_x * (0.45f + 0.35f * u(rng));
    // Within 70 % of the view's half-width at its depth (the nearest object 50 %: the path moves
    // the view by a good part of its width there).
    const float lateral = k == 0 ? 0.5f : 0.7f;
    const float x = lateral * (2 * u(rng) - 1) * half_x;  // one draw a statement: a fixed order
    const float z = lateral * (2 * u(rng) - 1) * half_z;
    const Eigen::Vector3f centre(x, o.camera_y + depth, z);
    TransformMesh(&p, RandomRotationMatrix(rng), centre, scale);
    scene.Append(p);
  }
  return scene;
}

void RoomOptions::Check() const {
  if (!(walk_radius_x > 0.5f) || !(walk_radius_y > 0.5f) || !(width > 2 * walk_radius_x + 1.f) ||
      !(depth > 2 * walk_radius_y + 1.f) || !(height > 1.8f)) {
    throw std::invalid_argument("RoomOptions: out of range");
  }
}

TriangleMesh ProceduralRoom(unsigned seed, SceneMaterial material, const RoomOptions& o) {
  o.Check();
  if (material == SceneMaterial::kRepetitive) ThrowInputError("--material", "", "textured or low-texture for rooms");
  std::mt19937 rng(seed * 2654435761u + 71u);
  std::uniform_real_distribution<float> u(0, 1);
  const float w = o.width, d = o.depth, h = o.height;
  // A surface: MakeBackdrop's plane (x-z, normal -y) of size a x b, placed by rotation and
  // translation, its albedo baked in room coordinates so that no two surfaces repeat.
  TriangleMesh room;
  const auto add_surface = [&](float a, float b, const Eigen::Matrix3f& rotation, const Eigen::Vector3f& t) {
    const int cells_a = static_cast<int>(std::ceil(a / 0.1f)), cells_b = static_cast<int>(std::ceil(b / 0.1f));
    TriangleMesh s = MakeBackdrop(a, b, cells_a, cells_b, 1.f);
    TransformMesh(&s, rotation, t);
    const float scale = 1.5f + u(rng);
    for (size_t k = 0; k < s.vertices.size(); ++k) s.vertex_colors[k] = ProceduralAlbedo(s.vertices[k], scale);
    if (material == SceneMaterial::kLowTexture)
      for (auto& c : s.vertex_colors) c = Eigen::Vector3f(0.75f, 0.73f, 0.70f);
    room.Append(s);
  };
  const Eigen::Matrix3f rz90 = Eigen::AngleAxisf(float(M_PI / 2), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3f rx90 = Eigen::AngleAxisf(float(M_PI / 2), Eigen::Vector3f::UnitX()).toRotationMatrix();
  add_surface(w, h, Eigen::Matrix3f::Identity(), {0, d / 2, h / 2});   // back wall
  add_surface(w, h, Eigen::Matrix3f::Identity(), {0, -d / 2, h / 2});  // front wall
  add_surface(d, h, rz90, {w / 2, 0, h / 2});                          // right wall
  add_surface(d, h, rz90, {-w / 2, 0, h / 2});                         // left wall
  add_surface(w, d, rx90, {0, 0, 0});                                  // floor
  add_surface(w, d, rx90, {0, 0, h});                                  // ceiling
  // Furniture: 1-3 pieces in the middle (inside the walk), 4-7 along the walls (outside it), each
  // in its own box of the floor clear of the walk's ellipse by `clear`, shrunk to fit the box and
  // a height below the ceiling, stood on the floor.
  const float clear = 0.35f, rx = o.walk_radius_x, ry = o.walk_radius_y;
  const int middle = std::uniform_int_distribution<int>(1, 3)(rng);
  const int along = std::uniform_int_distribution<int>(4, 7)(rng);
  for (int k = 0; k < middle + along; ++k) {
    TriangleMesh p = RandomPrimitive(rng);
    TransformMesh(&p, RandomRotationMatrix(rng), Eigen::Vector3f::Zero(), 1.0f + 0.8f * u(rng));
    const int wall = k < middle ? -1 : std::uniform_int_distribution<int>(0, 3)(rng);
    Eigen::Vector2f lo, hi;  // the floor box, x and y
    if (wall < 0) {          // the box inscribed in the ellipse shrunk by `clear`
      lo = {-(rx - clear) / std::sqrt(2.f), -(ry - clear) / std::sqrt(2.f)};
    } else if (wall < 2) {  // back (+y) or front (-y) wall
      lo = {-w / 2 + 0.05f, ry + clear};
    } else {  // right (+x) or left (-x) wall
      lo = {rx + clear, -d / 2 + 0.05f};
    }
    hi = wall < 0 ? Eigen::Vector2f(-lo) : Eigen::Vector2f(w / 2 - 0.05f, d / 2 - 0.05f);
    if (wall == 1 || wall == 3) {  // the mirror images
      const Eigen::Vector2f m = wall == 1 ? Eigen::Vector2f(1, -1) : Eigen::Vector2f(-1, 1);
      const Eigen::Vector2f a = lo.cwiseProduct(m), b = hi.cwiseProduct(m);
      lo = a.cwiseMin(b), hi = a.cwiseMax(b);
    }
    Eigen::Vector3f mn, mx;
    p.Bounds(&mn, &mx);
    const Eigen::Vector3f size = mx - mn;
    const float fit =
        std::min({1.f, (hi.x() - lo.x()) / size.x(), (hi.y() - lo.y()) / size.y(), (h - 0.4f) / size.z()});
    const float fx = u(rng), fy = u(rng);
    const Eigen::Vector2f corner(lo.x() + fx * (hi.x() - lo.x() - fit * size.x()),
                                 lo.y() + fy * (hi.y() - lo.y() - fit * size.y()));
    TransformMesh(&p, Eigen::Matrix3f::Identity(), Eigen::Vector3f(corner.x(), corner.y(), 0) - fit * mn, fit);
    room.Append(p);
  }
  return room;
}

}  // namespace nerfreg
