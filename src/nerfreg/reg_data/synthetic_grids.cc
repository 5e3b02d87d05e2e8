#include "nerfreg/reg_data/synthetic_grids.h"

#include <array>
#include <cmath>
#include <set>
#include <stdexcept>

#include "nerfreg/registration/scale_normalization.h"
#include "nerfreg/render/raycaster.h"
#include "nerfreg/render/renderer.h"
#include "nerfreg/render/trajectory.h"

namespace nerfreg {

void SyntheticPairOptions::Check() const {
  if (resolution < 8 || !(side > 0) || views < 4 || image_size < 8 || blocks < 2 || source_block < 0 ||
      target_block < 0 || source_block >= blocks || target_block >= blocks || source_block == target_block ||
      blur < 0 || blur > 1 || floaters < 0 || !(min_sigma > 0) || !(max_sigma >= min_sigma) ||
      !(max_relative_scale == 0 || (max_relative_scale >= 1 && max_relative_scale <= 100))) {
    throw std::invalid_argument("SyntheticPairOptions: out of range");
  }
  frames.Check();
}

namespace {

// The surface points the views `cams` see (world frame) and their colours.
struct SeenSurface {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3f> colours;
};

SeenSurface SeeSurface(const TriangleMesh& mesh, const RayCaster& caster, const std::vector<PosedCamera>& cams) {
  SeenSurface out;
  RenderOptions ro;
  ro.supersample = 1;
  for (const auto& pc : cams) {
    const RenderResult r = RenderView(caster, mesh, pc.camera, pc.cam_from_world, ro);
    const Rigid3d world_from_cam = pc.cam_from_world.Inverse();
    for (int y = 0; y < pc.camera.height; ++y) {
      for (int x = 0; x < pc.camera.width; ++x) {
        const float z = r.depth.at(x, y, 0);
        if (z <= 0 || r.rgba.at(x, y, 3) < 0.5f) continue;
        const Eigen::Vector3d x_cam = pc.camera.CamFromImg(Eigen::Vector2d(x + 0.5, y + 0.5)) * z;
        out.points.push_back(world_from_cam * x_cam);
        out.colours.emplace_back(r.rgba.at(x, y, 0), r.rgba.at(x, y, 1), r.rgba.at(x, y, 2));
      }
    }
  }
  return out;
}

// The register path's normalisation of a block whose seen surface is `seen`, in the frame
// block_from_world: one point per occupied cell of a fine lattice (a NeRF's occupied cells, not
// its ray hits, which crowd where many views look).
Sim3d BlockNormalization(const SeenSurface& seen, const Sim3d& block_from_world, double cell) {
  std::set<std::array<std::int64_t, 3>> cells;
  std::vector<Eigen::Vector3d> kept;
  for (const auto& w : seen.points) {
    const std::array<std::int64_t, 3> key = {std::int64_t(std::floor(w.x() / cell)),
                                             std::int64_t(std::floor(w.y() / cell)),
                                             std::int64_t(std::floor(w.z() / cell))};
    if (cells.insert(key).second) kept.push_back(block_from_world * w);
  }
  Eigen::Matrix3Xd points(3, kept.size());
  for (size_t i = 0; i < kept.size(); ++i) points.col(i) = kept[i];
  return NormalizationFor(points, "synthesised block");
}

// One block's grid from its seen surface, in the frame block_from_world.
RegGrid BlockGrid(const TriangleMesh& mesh, const SeenSurface& seen, const std::vector<PosedCamera>& cams,
                  const Sim3d& block_from_world, const SyntheticPairOptions& o, std::mt19937& rng) {
  const int d = o.resolution;
  const double cell = o.side / d;
  // The box is centred where the trainer centres the block's field: the object's box in the block frame.
  Eigen::Vector3d bmn = Eigen::Vector3d::Constant(INFINITY), bmx = -bmn;
  for (const auto& v : mesh.vertices) {
    const Eigen::Vector3d p = block_from_world * v.cast<double>();
    bmn = bmn.cwiseMin(p);
    bmx = bmx.cwiseMax(p);
  }
  RegGrid g;
  g.source = "mesh";
  g.variant = "surface";
  const Eigen::Vector3d centre = 0.5 * (bmn + bmx);
  g.aabb_min = centre - Eigen::Vector3d::Constant(0.5 * o.side);
  g.aabb_max = centre + Eigen::Vector3d::Constant(0.5 * o.side);
  const std::int64_t n = std::int64_t(d) * d * d;
  auto index = [&](const Eigen::Vector3d& p, std::int64_t* flat) {
    const Eigen::Vector3d u = (p - g.aabb_min) / cell;
    const int i = int(std::floor(u.x())), j = int(std::floor(u.y())), k = int(std::floor(u.z()));
    if (i < 0 || j < 0 || k < 0 || i >= d || j >= d || k >= d) return false;
    *flat = (std::int64_t(i) * d + j) * d + k;
    return true;
  };
  std::vector<float> count(n, 0.f), surface(n, 0.f), dense(n, 0.f);
  std::vector<Eigen::Vector3f> colour(n, Eigen::Vector3f::Zero());

  for (size_t q = 0; q < seen.points.size(); ++q) {
    std::int64_t f;
    if (!index(block_from_world * seen.points[q], &f)) continue;
    count[f] += 1;
    surface[f] = 1;
    colour[f] += seen.colours[q];
  }
  for (std::int64_t f = 0; f < n; ++f) {
    if (count[f] > 0) {
      dense[f] = 1;
      colour[f] /= count[f];
    }
  }
  std::uniform_real_distribution<double> uni(0, 1);
  // Blur: a surface voxel spreads to a 6-neighbour, half-seen.
  const int offs[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<float> dense_blur = dense, surface_blur = surface;
  std::vector<Eigen::Vector3f> colour_blur = colour;
  for (int i = 0; i < d; ++i) {
    for (int j = 0; j < d; ++j) {
      for (int k = 0; k < d; ++k) {
        const std::int64_t f = (std::int64_t(i) * d + j) * d + k;
        if (count[f] == 0) continue;
        for (const auto& o6 : offs) {
          const int a = i + o6[0], b = j + o6[1], c = k + o6[2];
          if (a < 0 || b < 0 || c < 0 || a >= d || b >= d || c >= d) continue;
          const std::int64_t h = (std::int64_t(a) * d + b) * d + c;
          if (dense_blur[h] > 0 || uni(rng) >= o.blur) continue;
          dense_blur[h] = 1;
          surface_blur[h] = static_cast<float>(0.2 + 0.5 * uni(rng));
          colour_blur[h] = colour[f];
        }
      }
    }
  }
  // Floaters: small clusters on the line of sight of a random camera, between it and the object.
  for (int fl = 0; fl < o.floaters && !cams.empty(); ++fl) {
    const auto& pc = cams[std::uniform_int_distribution<int>(0, int(cams.size()) - 1)(rng)];
    const Rigid3d world_from_cam = pc.cam_from_world.Inverse();
    const Eigen::Vector3d dir_cam =
        pc.camera.CamFromImg(Eigen::Vector2d(uni(rng) * pc.camera.width, uni(rng) * pc.camera.height)).normalized();
    const double t = 1.5 + 1.5 * uni(rng);  // the object's centre is ~4 away
    const Eigen::Vector3d p = block_from_world * (world_from_cam * (dir_cam * t));
    const Eigen::Vector3f c(float(uni(rng)), float(uni(rng)), float(uni(rng)));
    const int size = 1 + int(uni(rng) * 4);
    for (int s = 0; s < size; ++s) {
      const Eigen::Vector3d q = p + cell * Eigen::Vector3d(uni(rng) - 0.5, uni(rng) - 0.5, uni(rng) - 0.5) * 2;
      std::int64_t f;
      if (!index(q, &f) || dense_blur[f] > 0) continue;
      dense_blur[f] = 1;
      surface_blur[f] = static_cast<float>(0.5 + 0.5 * uni(rng));
      colour_blur[f] = c;
    }
  }
  // Tensors.
  const auto idx = torch::arange(d, torch::kFloat32);
  const auto ijk = torch::meshgrid({idx, idx, idx}, "ij");
  const auto mn = torch::tensor({float(g.aabb_min.x()), float(g.aabb_min.y()), float(g.aabb_min.z())});
  torch::Tensor jitter = torch::empty({d, d, d, 3});
  float* jp = jitter.data_ptr<float>();
  for (std::int64_t q = 0; q < n * 3; ++q) jp[q] = static_cast<float>(uni(rng));
  g.xyz = mn + (torch::stack({ijk[0], ijk[1], ijk[2]}, -1) + jitter) * float(cell);
  g.rgba = torch::zeros({4, d, d, d});
  float* rp = g.rgba.data_ptr<float>();
  const double log_lo = std::log(o.min_sigma), log_hi = std::log(o.max_sigma);
  for (std::int64_t f = 0; f < n; ++f) {
    if (dense_blur[f] == 0) continue;
    const double sigma = std::exp(log_lo + (log_hi - log_lo) * uni(rng));
    for (int c = 0; c < 3; ++c) rp[c * n + f] = colour_blur[f][c];
    rp[3 * n + f] = static_cast<float>(std::clamp(1 - std::exp(-0.01 * sigma), 0.0, 1.0));
  }
  g.surface = torch::from_blob(surface_blur.data(), {d, d, d}, torch::kFloat32).clone();
  const auto dense_t = torch::from_blob(dense_blur.data(), {d, d, d}, torch::kFloat32) > 0;
  g.mask = dense_t & (g.surface >= 0.5);
  g.Check();
  return g;
}

}  // namespace

GridPair SyntheticGridPair(const TriangleMesh& mesh, const SyntheticPairOptions& o, unsigned seed) {
  o.Check();
  torch::NoGradGuard no_grad;
  std::mt19937 rng(seed * 2654435761u + 17u);
  OrbitOptions orbit;
  orbit.num_views = o.views;
  orbit.width = orbit.height = o.image_size;
  const auto cams = OrbitTrajectory(orbit);
  std::vector<Eigen::Vector3d> centres;
  for (const auto& c : cams) centres.push_back(c.cam_from_world.Inverse().translation);
  const std::vector<int> label = KMeans(centres, o.blocks, seed);
  RayCaster caster(mesh);
  GridPair out;
  Sim3d from_world[2];
  const int which[2] = {o.source_block, o.target_block};
  for (int s = 0; s < 2; ++s) {
    std::vector<PosedCamera> block_cams;
    for (size_t i = 0; i < cams.size(); ++i)
      if (label[i] == which[s]) block_cams.push_back(cams[i]);
    from_world[s] = RandomBlockFrame(o.frames, rng);
    const SeenSurface seen = SeeSurface(mesh, caster, block_cams);
    if (o.max_relative_scale > 0) {
      const double log_max = std::log(o.max_relative_scale);
      const double relative = s == 0 ? std::exp(std::uniform_real_distribution<double>(-log_max, log_max)(rng)) : 1.0;
      from_world[s] = Sim3d(relative, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) * from_world[s];
      const Sim3d normalized = BlockNormalization(seen, from_world[s], 0.5 * o.side / o.resolution);
      from_world[s] = normalized * from_world[s];
      (s == 0 ? out.source_normalization : out.target_normalization) = normalized.scale * relative;
    }
    (s == 0 ? out.source : out.target) = BlockGrid(mesh, seen, block_cams, from_world[s], o, rng);
  }
  out.target_from_source = (from_world[1] * from_world[0].Inverse()).ToMatrix();
  out.overlap = GridOverlap(out.source, out.target, out.target_from_source);
  return out;
}

}  // namespace nerfreg
