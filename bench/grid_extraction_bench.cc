// Grid extraction's stages on a trained block, timed one by one (what `reg register` spends its
// grid_seconds on): the jittered density samples, the view-averaged colour of the dense points,
// the surface field marched from the block's cameras, and the occupied points of the block
// (ExtractOccupiedPoints). Optionally writes the grid and the occupied points, so two builds'
// outputs can be compared (scripts or a second run with --compare).
//   build/bench/nerfreg_grid_extraction_bench BLOCK.ckpt [--threads N] [--repeat K]
//       [--save PREFIX] [--compare PREFIX] [--min-transmittance T]
#include <torch/torch.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/reg/grid_extraction.h"
#include "nerfreg/reg/reg_grid.h"

namespace nerfreg {
namespace {

double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

double MaxAbs(const torch::Tensor& a, const torch::Tensor& b) {
  if (a.sizes() != b.sizes()) return -1;
  if (a.numel() == 0) return 0;
  return (a.to(torch::kDouble) - b.to(torch::kDouble)).abs().max().item<double>();
}

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(
        stderr,
        "usage: %s BLOCK.ckpt [--threads N] [--repeat K] [--save PREFIX] [--compare PREFIX] [--min-transmittance T]\n",
        argv[0]);
    return 2;
  }
  const std::string ckpt = argv[1];
  int threads = 0, repeat = 1;
  std::string save, compare;
  double min_transmittance = -1;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--threads") threads = std::atoi(argv[i + 1]);
    if (a == "--repeat") repeat = std::atoi(argv[i + 1]);
    if (a == "--save") save = argv[i + 1];
    if (a == "--compare") compare = argv[i + 1];
    if (a == "--min-transmittance") min_transmittance = std::atof(argv[i + 1]);
  }
  if (threads > 0) torch::set_num_threads(threads);
  NerfBlock block = LoadNerfBlock(ckpt);
  GridExtractionOptions options;
  SurfaceFieldOptions surface = options.ResolvedSurface();
  if (min_transmittance >= 0) surface.min_transmittance = min_transmittance;
  RegGrid grid;
  BlockPoints points;
  for (int r = 0; r < repeat; ++r) {
    double t_density = 0, t_color = 0, t_surface = 0;
    std::int64_t n_density = 0, n_color = 0, n_surface = 0;
    GridFieldQueries q;
    q.density = [&](const torch::Tensor& x) {
      const double t = Now();
      auto s = QueryDensity(block, x);
      t_density += Now() - t, n_density += x.size(0);
      return s;
    };
    q.color = [&](const torch::Tensor& x) {
      const double t = Now();
      auto c = ViewAveragedColor(block, x);
      t_color += Now() - t, n_color += x.size(0);
      return c;
    };
    q.surface = [&](const torch::Tensor& x) {
      const double t = Now();
      auto s = SurfaceField(block, x, surface);
      t_surface += Now() - t, n_surface += x.size(0);
      return s;
    };
    const auto& fmin = block.field_options.aabb_min;
    const auto& fmax = block.field_options.aabb_max;
    const Eigen::Vector3d centre(0.5 * (fmin[0] + fmax[0]), 0.5 * (fmin[1] + fmax[1]), 0.5 * (fmin[2] + fmax[2]));
    const double t0 = Now();
    grid = ExtractRegGridFromField(q, centre, options);
    const double t_grid = Now() - t0;
    const double t1 = Now();
    points = ExtractOccupiedPoints(block, 5.0, 0, false);
    const double t_points = Now() - t1;
    std::printf(
        "threads %d  grid %.3f s (density %.3f s / %lld pts, colour %.3f s / %lld, surface %.3f s / %lld)  "
        "occupied points %.3f s / %lld\n",
        torch::get_num_threads(), t_grid, t_density, static_cast<long long>(n_density), t_color,
        static_cast<long long>(n_color), t_surface, static_cast<long long>(n_surface), t_points,
        static_cast<long long>(points.xyz.size(0)));
  }
  if (!save.empty()) {
    SaveRegGrid(grid, save + ".grid");
    torch::save(std::vector<torch::Tensor>{points.xyz, points.rgb, points.sigma, points.alpha}, save + ".points.pt");
  }
  if (!compare.empty()) {
    const RegGrid other = LoadRegGrid(compare + ".grid");
    std::vector<torch::Tensor> p;
    torch::load(p, compare + ".points.pt");
    std::printf("grid max |diff|: xyz %.3g rgba %.3g surface %.3g; mask differs in %lld of %lld\n",
                MaxAbs(grid.xyz, other.xyz), MaxAbs(grid.rgba, other.rgba), MaxAbs(grid.surface, other.surface),
                static_cast<long long>((grid.mask != other.mask).sum().item<std::int64_t>()),
                static_cast<long long>(grid.mask.numel()));
    std::printf("rgb (dense voxels) max |diff| %.3g; surface max |diff| %.3g\n",
                MaxAbs(grid.rgba.slice(0, 0, 3), other.rgba.slice(0, 0, 3)), MaxAbs(grid.surface, other.surface));
    std::printf("occupied points max |diff|: xyz %.3g rgb %.3g sigma %.3g alpha %.3g\n", MaxAbs(points.xyz, p[0]),
                MaxAbs(points.rgb, p[1]), MaxAbs(points.sigma, p[2]), MaxAbs(points.alpha, p[3]));
  }
  return 0;
}

}  // namespace
}  // namespace nerfreg

int main(int argc, char** argv) { return nerfreg::Main(argc, argv); }
