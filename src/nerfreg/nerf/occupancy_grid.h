#pragma once
// Occupancy grid for empty-space skipping (instant-NGP): a G^3 grid over the AABB holding an EMA
// of density; a cell is occupied when density * step_size exceeds min(mean, threshold). Updated
// every few training steps from the field itself.
//
// The grid's state lives on one device (the CPU unless moved with To()). The update is torch ops
// (index_select, maximum, index_put_, a mean and a comparison), so it runs wherever the state is;
// there is no hand-written kernel for it.
#include <torch/torch.h>

#include <functional>

namespace nerfreg {

struct OccupancyGridOptions {
  int resolution = 128;    // G
  int update_every = 16;   // training steps between updates
  int warmup_steps = 256;  // all cells are updated during warm-up, a quarter afterwards
  double ema_decay = 0.95;
  double threshold = 0.01;  // on density * step_size (the sample's opacity scale)
  void Check() const;
};

class OccupancyGrid {
 public:
  OccupancyGrid(const OccupancyGridOptions& options, const std::vector<double>& aabb_min,
                const std::vector<double>& aabb_max);

  // density_fn: positions [N, 3] world, on the grid's device -> sigma [N] (called without grad,
  // in chunks; any device). The cells and jitter are drawn from `gen` on the CPU whatever the
  // grid's device, so a grid on a GPU is updated at the points a CPU one is.
  void Update(int step, double step_size, const std::function<torch::Tensor(const torch::Tensor&)>& density_fn,
              torch::Generator gen = {});

  const torch::Tensor& density() const { return density_; }    // [G, G, G] float EMA, on device()
  const torch::Tensor& occupied() const { return occupied_; }  // [G, G, G] bool, on device()
  torch::Device device() const { return density_.device(); }
  // Moves the state to `device`; later updates and marching read it there.
  void To(const torch::Device& device);
  double OccupiedFraction() const;
  int resolution() const { return options_.resolution; }
  const std::vector<double>& aabb_min() const { return aabb_min_; }
  const std::vector<double>& aabb_max() const { return aabb_max_; }
  // Cell centres [G^3, 3] in world units, on device(), z-major order matching density().view(-1).
  torch::Tensor CellCenters() const;

  // For checkpoints: density [G, G, G], occupied [G, G, G], moved to device().
  void SetState(const torch::Tensor& density, const torch::Tensor& occupied);

 private:
  void Threshold(double step_size);

  OccupancyGridOptions options_;
  std::vector<double> aabb_min_, aabb_max_;
  torch::Tensor density_, occupied_;
};

}  // namespace nerfreg
