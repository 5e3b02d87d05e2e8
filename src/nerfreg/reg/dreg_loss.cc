#include "nerfreg/reg/dreg_loss.h"

#include <cmath>
#include <limits>

#include "nerfreg/util/logging.h"

namespace nerfreg {
namespace {

using torch::indexing::Slice;

// x [N, 3] -> A x + b with a [4, 4] affine transform.
torch::Tensor Apply(const torch::Tensor& transform, const torch::Tensor& x) {
  return torch::matmul(x, transform.index({Slice(0, 3), Slice(0, 3)}).t()) + transform.index({Slice(0, 3), 3});
}

// One direction of InfoNCE: anchors [N, d] at xyz_anchor [N, 3] (already in the positives'
// frame), candidates [M, d] at xyz_cand [M, 3]; w_sym [d, d]. Returns (sum of losses, count).
std::pair<torch::Tensor, int64_t> InfoNce(const torch::Tensor& anchor, const torch::Tensor& cand,
                                          const torch::Tensor& xyz_anchor, const torch::Tensor& xyz_cand,
                                          const torch::Tensor& w_sym, double r_p, double r_n) {
  const torch::Tensor logits = torch::matmul(torch::matmul(anchor, w_sym), cand.t());  // [N, M]
  torch::Tensor dist, nearest, valid, ignore;
  {
    torch::NoGradGuard no_grad;
    dist = torch::cdist(xyz_anchor, xyz_cand);  // [N, M]
    std::tie(dist, nearest) = dist.min(1, /*keepdim=*/true);
    valid = dist.squeeze(1) < r_p;
    ignore = torch::cdist(xyz_anchor, xyz_cand) < r_n;
    ignore.scatter_(1, nearest, false);
  }
  const int64_t count = valid.sum().item<int64_t>();
  if (count == 0) return {logits.sum() * 0.0, 0};
  const torch::Tensor masked = logits.masked_fill(ignore, -std::numeric_limits<float>::infinity());
  const torch::Tensor per = torch::logsumexp(masked, 1) - logits.gather(1, nearest).squeeze(1);
  return {per.masked_select(valid).sum(), count};
}

}  // namespace

bool DregLossOptions::Check() const {
  if (confidence_weight < 0 || surface_weight < 0 || feature_weight < 0 || correspondence_weight < 0) {
    LOG_ERROR("DregLossOptions: weights must be >= 0");
    return false;
  }
  if (!(positive_radius > 0) || negative_radius < positive_radius) {
    LOG_ERROR("DregLossOptions: need 0 < positive_radius <= negative_radius");
    return false;
  }
  if (!(barron_c > 0) || !std::isfinite(barron_alpha)) {
    LOG_ERROR("DregLossOptions: barron_c must be > 0 and barron_alpha finite");
    return false;
  }
  return true;
}

torch::Tensor BarronLoss(const torch::Tensor& x, double alpha, double c) {
  const torch::Tensor z2 = (x / c).square();
  if (std::abs(alpha - 2.0) < 1e-9) return 0.5 * z2;
  if (std::abs(alpha) < 1e-9) return torch::log1p(0.5 * z2);
  const double b = std::abs(alpha - 2.0);
  return (b / alpha) * (torch::pow(z2 / b + 1.0, alpha / 2.0) - 1.0);
}

namespace {

// Trilinear sample of volume [D, D, D] over grid's box at points [N, 3] -> [N].
torch::Tensor SampleVolume(const RegGrid& grid, const torch::Tensor& surface, const torch::Tensor& points) {
  TORCH_CHECK(points.dim() == 2 && points.size(1) == 3, "SampleSurface: points must be [N, 3]");
  const int64_t d = surface.size(0);
  TORCH_CHECK(surface.sizes() == torch::IntArrayRef({d, d, d}), "SampleSurface: surface must be [D, D, D]");
  const auto f = torch::TensorOptions().dtype(points.dtype()).device(points.device());
  const torch::Tensor lo = torch::tensor({grid.aabb_min.x(), grid.aabb_min.y(), grid.aabb_min.z()}, f);
  const torch::Tensor hi = torch::tensor({grid.aabb_max.x(), grid.aabb_max.y(), grid.aabb_max.z()}, f);
  // align_corners = false: -1 and +1 are the outer faces of the first and last voxels, so voxel i's
  // centre aabb_min + (i + 0.5) cell maps to its sample. grid_sample's last coordinate indexes the
  // input's last dim (k = z): pass (z, y, x).
  const torch::Tensor normalised = (2.0 * (points - lo) / (hi - lo) - 1.0).flip({1});
  const torch::Tensor volume = surface.to(points.device(), points.scalar_type()).view({1, 1, d, d, d});
  namespace F = torch::nn::functional;
  const torch::Tensor s = F::grid_sample(
      volume, normalised.view({1, -1, 1, 1, 3}),
      F::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kZeros).align_corners(false));
  return s.view({-1});
}

}  // namespace

torch::Tensor SampleSurface(const RegGrid& grid, const torch::Tensor& points) {
  return SampleVolume(grid, grid.surface, points);
}

torch::Tensor SampleSeenSurface(const RegGrid& grid, const torch::Tensor& points) {
  torch::NoGradGuard no_grad;
  const int64_t d = grid.surface.size(0);
  TORCH_CHECK(grid.surface.sizes() == torch::IntArrayRef({d, d, d}), "SampleSeenSurface: surface must be [D, D, D]");
  const torch::Tensor dilated =
      torch::max_pool3d(grid.surface.to(torch::kFloat).view({1, 1, d, d, d}), {3, 3, 3}, {1, 1, 1}, {1, 1, 1})
          .view({d, d, d});
  return SampleVolume(grid, dilated, points.detach()).clamp(0.0, 1.0);
}

DregLossTerms DregLoss(const DregOutput& out, const RegGrid& src, const RegGrid& tgt,
                       const torch::Tensor& target_from_source, const DregLossOptions& options) {
  TORCH_CHECK(options.Check(), "DregLoss: invalid options");
  TORCH_CHECK(out.num_layers() >= 1, "DregLoss: empty output");
  TORCH_CHECK(target_from_source.sizes() == torch::IntArrayRef({4, 4}), "DregLoss: target_from_source must be [4, 4]");
  const torch::Tensor tgt_from_src = target_from_source.to(out.src_xyz.device(), torch::kFloat);
  const torch::Tensor src_from_tgt = torch::inverse(tgt_from_src);
  // Ground truth positions of each keypoint in the other frame: [Ks, 3], [Kt, 3].
  const torch::Tensor src_in_tgt = Apply(tgt_from_src, out.src_xyz);
  const torch::Tensor tgt_in_src = Apply(src_from_tgt, out.tgt_xyz);
  torch::Tensor labels = torch::cat({out.src_surface, out.tgt_surface});  // [Ks + Kt]
  // O: the other block's seen surface at each keypoint's true position (overlap_labels); ones otherwise.
  torch::Tensor overlap = torch::ones_like(labels);
  if (options.overlap_labels) {
    overlap = torch::cat({SampleSeenSurface(tgt, src_in_tgt), SampleSeenSurface(src, tgt_in_src)}).to(labels.dtype());
    labels = labels * overlap;
  }
  const torch::Tensor label_sum = labels.sum().clamp_min(1e-6);
  const torch::Tensor overlap_sum = overlap.sum().clamp_min(1e-6);
  const torch::Tensor w = out.feature_w;
  const torch::Tensor w_sym = 0.5 * (w + w.t());

  DregLossTerms terms;
  const auto zero = torch::zeros({}, out.src_xyz.options());
  terms.confidence = terms.surface = terms.correspondence = terms.feature = zero;
  const int64_t first = options.all_layers ? 0 : out.num_layers() - 1;
  for (int64_t l = first; l < out.num_layers(); ++l) {
    const torch::Tensor logits = torch::cat({out.src_conf_logits[l], out.tgt_conf_logits[l]});
    terms.confidence = terms.confidence + torch::binary_cross_entropy_with_logits(logits, labels);

    const torch::Tensor sampled =
        torch::cat({SampleSurface(tgt, out.src_corr[l]), SampleSurface(src, out.tgt_corr[l])});
    const torch::Tensor own = torch::cat({out.src_surface, out.tgt_surface});
    terms.surface = terms.surface + (overlap * (sampled - own).square()).sum() / overlap_sum;

    const torch::Tensor err = torch::cat({out.src_corr[l] - src_in_tgt, out.tgt_corr[l] - tgt_in_src});
    const torch::Tensor rho = BarronLoss(err, options.barron_alpha, options.barron_c).sum(1);  // [Ks + Kt]
    terms.correspondence = terms.correspondence + (labels * rho).sum() / label_sum;

    const auto [sum_st, n_st] = InfoNce(out.src_features[l], out.tgt_features[l], src_in_tgt, out.tgt_xyz, w_sym,
                                        options.positive_radius, options.negative_radius);
    const auto [sum_ts, n_ts] = InfoNce(out.tgt_features[l], out.src_features[l], tgt_in_src, out.src_xyz, w_sym,
                                        options.positive_radius, options.negative_radius);
    if (n_st + n_ts > 0) terms.feature = terms.feature + (sum_st + sum_ts) / static_cast<double>(n_st + n_ts);
  }
  terms.total = options.confidence_weight * terms.confidence + options.surface_weight * terms.surface +
                options.correspondence_weight * terms.correspondence + options.feature_weight * terms.feature;
  return terms;
}

}  // namespace nerfreg
