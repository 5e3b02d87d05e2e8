#pragma once
// Occupancy grid for empty-space skipping (instant-NGP): a G^3 grid over the AABB holding an EMA
// of density; a cell is occupied when density * step_size exceeds min(mean, threshold). Updated
// every few training steps from the field itself.
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

  // density_fn: positions [N, 3] world -> sigma [N] (called without grad, in chunks).
  void Update(int step, double step_size, const std::function<torch::Tensor(const torch::Tensor&)>& density_fn,
              torch::Generator gen = {});

  const torch::Tensor& density() const { return density_; }    // [G, G, G] float EMA
  const torch::Tensor& occupied() const { return occupied_; }  // [G, G, G] bool
  double OccupiedFraction() const;
  int resolution() const { return options_.resolution; }
  const std::vector<double>& aabb_min() const { return aabb_min_; }
  const std::vector<double>& aabb_max() const { return aabb_max_; }
  // Cell centres [G^3, 3] in world units, z-major order matching density().view(-1).
  torch::Tensor CellCenters() const;

  // For checkpoints.
  void SetState(const torch::Tensor& density, const torch::Tensor& occupied);

 private:
  void Threshold(double step_size);

  OccupancyGridOptions options_;
  std::vector<double> aabb_min_, aabb_max_;
  torch::Tensor density_, occupied_;
};

}  // namespace nerfreg
