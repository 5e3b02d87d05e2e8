#include "nerfreg/nerf/occupancy_grid.h"

#include <stdexcept>

namespace nerfreg {

void OccupancyGridOptions::Check() const {
  if (resolution < 4 || resolution > 512 || update_every < 1 || warmup_steps < 0 || !(ema_decay > 0 && ema_decay < 1) ||
      !(threshold > 0)) {
    throw std::invalid_argument("OccupancyGridOptions: out of range");
  }
}

OccupancyGrid::OccupancyGrid(const OccupancyGridOptions& options, const std::vector<double>& aabb_min,
                             const std::vector<double>& aabb_max)
    : options_(options), aabb_min_(aabb_min), aabb_max_(aabb_max) {
  options_.Check();
  const int g = options_.resolution;
  density_ = torch::zeros({g, g, g});
  occupied_ = torch::ones({g, g, g}, torch::kBool);  // everything is occupied until measured
}

torch::Tensor OccupancyGrid::CellCenters() const {
  const int g = options_.resolution;
  const auto idx = torch::arange(g, torch::kFloat32);
  const auto grid = torch::meshgrid({idx, idx, idx}, "ij");  // (i, j, k) = (x, y, z) cell
  auto unit = (torch::stack({grid[0], grid[1], grid[2]}, -1).reshape({-1, 3}) + 0.5) / g;
  const auto mn = torch::tensor(aabb_min_, torch::kFloat32), mx = torch::tensor(aabb_max_, torch::kFloat32);
  return (mn + unit * (mx - mn)).to(device());
}

void OccupancyGrid::To(const torch::Device& device) {
  density_ = density_.to(device);
  occupied_ = occupied_.to(device);
}

void OccupancyGrid::Update(int step, double step_size,
                           const std::function<torch::Tensor(const torch::Tensor&)>& density_fn, torch::Generator gen) {
  if (step % options_.update_every != 0) return;
  torch::NoGradGuard no_grad;
  const int g = options_.resolution;
  const std::int64_t n = std::int64_t(g) * g * g;
  const torch::Device device = density_.device();
  const auto i64 = torch::TensorOptions(torch::kInt64).device(device);
  torch::Tensor cells;  // [M] int64 flat cell indices, on the grid's device
  if (step < options_.warmup_steps) {
    cells = torch::arange(n, i64);
  } else {
    // A quarter of the cells at random plus a quarter of the occupied ones (instant-NGP).
    const auto random = torch::randint(n, {n / 4}, gen, torch::kInt64).to(device);
    const auto occ = occupied_.reshape(-1).nonzero().squeeze(1);  // ascending on every device
    const auto pick =
        occ.numel() > 0 ? occ.index_select(0, torch::randint(occ.numel(), {std::min<std::int64_t>(n / 4, occ.numel())},
                                                             gen, torch::kInt64)
                                                  .to(device))
                        : torch::empty({0}, i64);
    cells = torch::cat({random, pick});
  }
  const auto f32 = torch::TensorOptions(torch::kFloat32).device(device);
  const auto mn = torch::tensor(aabb_min_, torch::kFloat32).to(device),
             mx = torch::tensor(aabb_max_, torch::kFloat32).to(device);
  const auto i = cells.div(std::int64_t(g) * g, "floor"), j = cells.div(g, "floor").remainder(g),
             k = cells.remainder(g);
  const auto jitter = torch::rand({cells.numel(), 3}, gen).to(device);  // [M, 3]
  const auto unit = (torch::stack({i, j, k}, 1).to(f32) + jitter) / g;
  const auto pos = mn + unit * (mx - mn);  // [M, 3] world
  std::vector<torch::Tensor> sig;
  for (std::int64_t s = 0; s < pos.size(0); s += 1 << 18) sig.push_back(density_fn(pos.slice(0, s, s + (1 << 18))));
  const auto sigma = torch::cat(sig).to(device, torch::kFloat32);  // [M]
  auto flat = density_.view(-1);
  const auto old = flat.index_select(0, cells);
  flat.index_put_({cells}, torch::maximum(old * options_.ema_decay, sigma));
  Threshold(step_size);
}

void OccupancyGrid::Threshold(double step_size) {
  const auto opacity = density_ * step_size;
  const double thr = std::min(opacity.mean().item<double>(), options_.threshold);
  occupied_ = opacity > thr;
}

double OccupancyGrid::OccupiedFraction() const { return occupied_.to(torch::kFloat32).mean().item<double>(); }

void OccupancyGrid::SetState(const torch::Tensor& density, const torch::Tensor& occupied) {
  const int g = options_.resolution;
  TORCH_CHECK(density.sizes() == torch::IntArrayRef({g, g, g}) && occupied.sizes() == torch::IntArrayRef({g, g, g}),
              "OccupancyGrid::SetState: wrong grid size");
  density_ = density.to(device(), torch::kFloat32).contiguous();
  occupied_ = occupied.to(device(), torch::kBool).contiguous();
}

}  // namespace nerfreg
