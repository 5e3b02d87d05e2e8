#include "nerfreg/render/renderer.h"

#include <cmath>
#include <stdexcept>

namespace nerfreg {

void RenderOptions::Check() const {
  if (supersample < 1 || supersample > 8 || ambient < 0 || ambient > 1 || texture_modulation < 0 ||
      texture_modulation > 1 || !(pattern_scale > 0)) {
    throw std::invalid_argument("RenderOptions: out of range");
  }
}

namespace {

float Lattice(int x, int y, int z, int seed) {
  unsigned h = static_cast<unsigned>(x) * 73856093u ^ static_cast<unsigned>(y) * 19349663u ^
               static_cast<unsigned>(z) * 83492791u ^ static_cast<unsigned>(seed) * 2654435761u;
  h = (h ^ (h >> 13)) * 1274126177u;
  return ((h ^ (h >> 16)) & 0xffff) / 65535.f;
}

float ValueNoise3(const Eigen::Vector3f& p, int seed) {
  const int x0 = static_cast<int>(std::floor(p.x())), y0 = static_cast<int>(std::floor(p.y())),
            z0 = static_cast<int>(std::floor(p.z()));
  const float fx = p.x() - x0, fy = p.y() - y0, fz = p.z() - z0;
  auto s = [](float t) { return t * t * (3 - 2 * t); };
  const float sx = s(fx), sy = s(fy), sz = s(fz);
  float v = 0;
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const float w = (dx ? sx : 1 - sx) * (dy ? sy : 1 - sy) * (dz ? sz : 1 - sz);
        v += w * Lattice(x0 + dx, y0 + dy, z0 + dz, seed);
      }
  return v;
}

Eigen::Vector3f SampleTexture(const Image& tex, float u, float v) {
  // Wrap, then bilinear; v = 0 is the bottom row (OpenGL / glTF-in-Open3D convention: flip).
  u -= std::floor(u);
  v -= std::floor(v);
  const float x = u * tex.width - 0.5f, y = (1 - v) * tex.height - 0.5f;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - x0, fy = y - y0;
  Eigen::Vector3f out = Eigen::Vector3f::Zero();
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int xi = ((x0 + dx) % tex.width + tex.width) % tex.width;
      const int yi = ((y0 + dy) % tex.height + tex.height) % tex.height;
      const float w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      for (int c = 0; c < 3; ++c) out(c) += w * tex.at(xi, yi, c);
    }
  return out;
}

}  // namespace

float ProceduralPattern(const Eigen::Vector3f& p, float scale) {
  return 0.6f * ValueNoise3(p * scale, 1) + 0.4f * ValueNoise3(p * (scale * 3.1f), 2);
}

Eigen::Vector3f ProceduralAlbedo(const Eigen::Vector3f& p, float scale) {
  static const Eigen::Vector3f kPalette[] = {{0.85f, 0.25f, 0.2f}, {0.95f, 0.75f, 0.2f}, {0.2f, 0.6f, 0.3f},
                                             {0.2f, 0.4f, 0.85f},  {0.6f, 0.3f, 0.7f},   {0.9f, 0.9f, 0.85f}};
  const float a = ValueNoise3(p * scale, 11) * 5.999f;
  const int i = static_cast<int>(a);
  const float f = a - i;
  const Eigen::Vector3f base = (1 - f) * kPalette[i] + f * kPalette[std::min(i + 1, 5)];
  return base * (0.7f + 0.3f * ValueNoise3(p * (scale * 4.f), 12));
}

RenderResult RenderView(const RayCaster& caster, const TriangleMesh& mesh, const Camera& camera,
                        const Rigid3d& cam_from_world, const RenderOptions& options) {
  options.Check();
  camera.Check();
  const int w = camera.width, h = camera.height, ss = options.supersample;
  RenderResult out;
  out.rgba = Image(w, h, 4);
  out.depth = Image(w, h, 1);
  const Eigen::Matrix3d world_from_cam = cam_from_world.RotationMatrix().transpose();
  const Eigen::Vector3f origin = (-(world_from_cam * cam_from_world.translation)).cast<float>();
  const Eigen::Vector3f light1 = Eigen::Vector3f(0.4f, 0.3f, 0.85f).normalized();
  const Eigen::Vector3f light2 = Eigen::Vector3f(-0.6f, -0.4f, 0.3f).normalized();
  const bool with_materials = mesh.HasMaterials();
  const bool with_uvs = mesh.triangle_uvs.size() == 3 * mesh.triangles.size();
  const bool textured = mesh.HasTexture(), colored = mesh.HasColors();

#pragma omp parallel for schedule(dynamic, 1)
  for (int row = 0; row < h; ++row) {
    for (int col = 0; col < w; ++col) {
      {
        // Depth from the ray through the pixel centre (the ray a NeRF renders for this pixel).
        const Eigen::Vector3d d_cam = camera.CamFromImg({col + 0.5, row + 0.5}).normalized();
        const RayHit hit = caster.Cast(origin, (world_from_cam * d_cam).cast<float>());
        if (hit.hit()) out.depth.at(col, row, 0) = static_cast<float>(hit.t * d_cam.z());
      }
      Eigen::Vector3f rgb_sum = Eigen::Vector3f::Zero();
      float alpha_sum = 0;
      for (int sy = 0; sy < ss; ++sy) {
        for (int sx = 0; sx < ss; ++sx) {
          const Eigen::Vector2d uv(col + (sx + 0.5) / ss, row + (sy + 0.5) / ss);
          const Eigen::Vector3d d_cam = camera.CamFromImg(uv).normalized();
          const Eigen::Vector3f dir = (world_from_cam * d_cam).cast<float>();
          const RayHit hit = caster.Cast(origin, dir);
          if (!hit.hit()) continue;
          const Eigen::Vector3i& tri = mesh.triangles[hit.triangle];
          const float b0 = 1 - hit.u - hit.v;
          const Eigen::Vector3f p = origin + hit.t * dir;
          Eigen::Vector3f albedo;
          const auto interpolated_uv = [&] {
            return Eigen::Vector2f(b0 * mesh.triangle_uvs[3 * hit.triangle] +
                                   hit.u * mesh.triangle_uvs[3 * hit.triangle + 1] +
                                   hit.v * mesh.triangle_uvs[3 * hit.triangle + 2]);
          };
          if (with_materials) {
            const MeshMaterial& m = mesh.materials[mesh.triangle_materials[hit.triangle]];
            if (!m.texture.empty() && with_uvs) {
              const Eigen::Vector2f t = interpolated_uv();
              albedo = SampleTexture(m.texture, t.x(), t.y());
            } else {
              // A flat material colour gets the vertex colours' pattern: features for a NeRF to fit.
              albedo = m.diffuse * ((1 - options.texture_modulation) +
                                    options.texture_modulation * 2.f * ProceduralPattern(p, options.pattern_scale));
            }
          } else if (textured) {
            const Eigen::Vector2f t = interpolated_uv();
            albedo = SampleTexture(mesh.texture, t.x(), t.y());
          } else if (colored) {
            albedo = b0 * mesh.vertex_colors[tri(0)] + hit.u * mesh.vertex_colors[tri(1)] +
                     hit.v * mesh.vertex_colors[tri(2)];
            albedo *= (1 - options.texture_modulation) +
                      options.texture_modulation * 2.f * ProceduralPattern(p, options.pattern_scale);
          } else {
            albedo = ProceduralAlbedo(p, options.pattern_scale);
          }
          Eigen::Vector3f n = hit.normal;
          if (n.dot(dir) > 0) n = -n;  // two-sided
          const float shade = options.ambient + 0.45f * std::max(0.f, n.dot(light1)) +
                              0.2f * std::max(0.f, n.dot(light2)) + 0.2f * std::max(0.f, -n.dot(dir));
          rgb_sum += (albedo * shade).cwiseMin(1.f).cwiseMax(0.f);
          alpha_sum += 1;
        }
      }
      const float n_samples = static_cast<float>(ss * ss);
      const float alpha = alpha_sum / n_samples;
      // Store colour un-premultiplied so that compositing over any background is exact.
      const Eigen::Vector3f rgb = alpha_sum > 0 ? Eigen::Vector3f(rgb_sum / alpha_sum) : Eigen::Vector3f::Zero();
      for (int c = 0; c < 3; ++c) out.rgba.at(col, row, c) = rgb(c);
      out.rgba.at(col, row, 3) = alpha;
    }
  }
  return out;
}

}  // namespace nerfreg
