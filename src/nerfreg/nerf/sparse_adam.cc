#include "nerfreg/nerf/sparse_adam.h"

#include <cmath>

namespace nerfreg {

SparseAdam::SparseAdam(const torch::Tensor& param, const SparseAdamOptions& options)
    : param_(param), options_(options) {
  TORCH_CHECK(param.device().is_cpu() && param.scalar_type() == torch::kFloat32 && param.is_contiguous(),
              "SparseAdam: a contiguous float32 CPU tensor expected");
  m_ = torch::zeros_like(param, torch::TensorOptions().requires_grad(false));
  v_ = torch::zeros_like(m_);
  steps_ = torch::zeros(param.sizes(), torch::kInt32);
}

void SparseAdam::Step(double lr) {
  const torch::Tensor grad = param_.grad();
  if (!grad.defined()) return;
  TORCH_CHECK(grad.sizes() == param_.sizes() && grad.scalar_type() == torch::kFloat32, "SparseAdam: gradient shape");
  const auto g = grad.contiguous();
  torch::NoGradGuard no_grad;
  float* p = param_.data_ptr<float>();
  float* m = m_.data_ptr<float>();
  float* v = v_.data_ptr<float>();
  std::int32_t* steps = steps_.data_ptr<std::int32_t>();
  const float* gp = g.data_ptr<float>();
  const float b1 = static_cast<float>(options_.beta1), b2 = static_cast<float>(options_.beta2);
  const float eps = static_cast<float>(options_.eps);
  // Bias-corrected step sizes by an entry's own step count t (<= the calls so far): a table, so
  // the loop has no transcendental per entry.
  ++calls_;
  step_sizes_.resize(calls_ + 1);
  for (std::int64_t t = 1; t <= calls_; ++t) {
    step_sizes_[t] = static_cast<float>(lr * std::sqrt(1 - std::pow(options_.beta2, double(t))) /
                                        (1 - std::pow(options_.beta1, double(t))));
  }
  const float* step_size = step_sizes_.data();
  const std::int64_t n = param_.numel();
#pragma omp parallel for schedule(static, 1 << 14)
  for (std::int64_t i = 0; i < n; ++i) {
    const float gi = gp[i];
    if (gi == 0.f) continue;
    const float mi = m[i] = b1 * m[i] + (1 - b1) * gi;
    const float vi = v[i] = b2 * v[i] + (1 - b2) * gi * gi;
    p[i] -= step_size[++steps[i]] * mi / (std::sqrt(vi) + eps);
  }
}

void SparseAdam::Save(torch::serialize::OutputArchive& archive, const std::string& prefix) const {
  archive.write(prefix + "_m", m_);
  archive.write(prefix + "_v", v_);
  archive.write(prefix + "_steps", steps_);
  archive.write(prefix + "_calls", torch::tensor(calls_));
}

void SparseAdam::Load(torch::serialize::InputArchive& archive, const std::string& prefix) {
  torch::Tensor m, v, steps;
  archive.read(prefix + "_m", m);
  archive.read(prefix + "_v", v);
  archive.read(prefix + "_steps", steps);
  torch::Tensor calls;
  archive.read(prefix + "_calls", calls);
  calls_ = calls.item<std::int64_t>();
  TORCH_CHECK(m.sizes() == param_.sizes() && v.sizes() == param_.sizes() && steps.sizes() == param_.sizes(),
              "SparseAdam: saved state of another shape");
  m_ = m.to(torch::kFloat32).contiguous();
  v_ = v.to(torch::kFloat32).contiguous();
  steps_ = steps.to(torch::kInt32).contiguous();
}

}  // namespace nerfreg
