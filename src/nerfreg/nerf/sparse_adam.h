#pragma once
// Adam for the hash table as tiny-cuda-nn applies it to instant-NGP's encoding: entries whose
// gradient is exactly zero (not touched by any sample of the batch) are skipped, and each entry
// keeps its own step count for the bias correction. Besides following the paper's optimizer,
// this is one fused pass over the table instead of torch Adam's several (compare
// BM_AdamTableStep and BM_SparseAdamTableStep in bench/nerf_bench.cc).
#include <torch/torch.h>

#include <vector>

namespace nerfreg {

struct SparseAdamOptions {
  double beta1 = 0.9;
  double beta2 = 0.99;  // instant-NGP's
  double eps = 1e-15;
};

class SparseAdam {
 public:
  // param: float32 contiguous CPU tensor (the hash table), updated in place.
  SparseAdam(const torch::Tensor& param, const SparseAdamOptions& options);

  // One step with learning rate lr from param.grad(); entries with a zero gradient are left alone.
  void Step(double lr);

  // State for checkpoints: first and second moments (like param) and per-entry steps (int32).
  void Save(torch::serialize::OutputArchive& archive, const std::string& prefix) const;
  void Load(torch::serialize::InputArchive& archive, const std::string& prefix);

 private:
  torch::Tensor param_, m_, v_, steps_;
  SparseAdamOptions options_;
  std::int64_t calls_ = 0;         // Step() calls so far: the largest step count an entry can have
  std::vector<float> step_sizes_;  // [t] the bias-corrected step size after t steps of an entry
};

}  // namespace nerfreg
