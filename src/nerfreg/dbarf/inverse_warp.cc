#include "nerfreg/util/torch_device.h"  // torch::linalg under LibTorch 2.x
#include "nerfreg/dbarf/inverse_warp.h"

#include "nerfreg/dbarf/se3.h"

namespace nerfreg {
namespace {

namespace F = torch::nn::functional;

constexpr double kMinDepth = 1e-4;
// Rounding slack (pixels) on the valid region, so that an identity warp is valid everywhere.
constexpr double kHullSlack = 1e-3;

void CheckIntrinsics(const torch::Tensor& k, const char* name) {
  TORCH_CHECK((k.dim() == 2 || k.dim() == 3) && k.size(-1) == 3 && k.size(-2) == 3, name,
              ": intrinsics must be [3, 3] or [N, 3, 3], got ", k.sizes());
  TORCH_CHECK(k.is_floating_point(), name, ": intrinsics must be floating point");
}

}  // namespace

torch::Tensor ScaleIntrinsics(const torch::Tensor& intrinsics, double scale) {
  return ResizeIntrinsics(intrinsics, scale, scale);
}

torch::Tensor ResizeIntrinsics(const torch::Tensor& intrinsics, double sx, double sy) {
  CheckIntrinsics(intrinsics, "ResizeIntrinsics");
  torch::Tensor s = torch::ones({3, 1}, intrinsics.options());
  s[0] = sx;
  s[1] = sy;
  return intrinsics * s;  // a new tensor; rows 0, 1 scaled
}

torch::Tensor AreaDownsample(const torch::Tensor& x, int64_t h, int64_t w) {
  if (x.size(2) == h && x.size(3) == w) return x;
  return F::interpolate(x, F::InterpolateFuncOptions().size(std::vector<int64_t>{h, w}).mode(torch::kArea));
}

torch::Tensor PixelCentres(int64_t height, int64_t width, const torch::TensorOptions& options) {
  const torch::Tensor rows = torch::arange(height, options) + 0.5;
  const torch::Tensor cols = torch::arange(width, options) + 0.5;
  const auto mesh = torch::meshgrid({rows, cols}, "ij");
  return torch::stack({mesh[1].reshape(-1), mesh[0].reshape(-1), torch::ones({height * width}, options)}, -1);
}

torch::Tensor BackProject(const torch::Tensor& tgt_inv_depth, const torch::Tensor& intrinsics) {
  TORCH_CHECK(tgt_inv_depth.dim() == 4 && tgt_inv_depth.size(1) == 1,
              "BackProject: inverse depth must be [B, 1, H, W], got ", tgt_inv_depth.sizes());
  CheckIntrinsics(intrinsics, "BackProject");
  const int64_t b = tgt_inv_depth.size(0), h = tgt_inv_depth.size(2), w = tgt_inv_depth.size(3);
  const torch::Tensor pix = PixelCentres(h, w, tgt_inv_depth.options());  // [HW, 3]
  const torch::Tensor k_inv = torch::linalg::inv(intrinsics.to(tgt_inv_depth.scalar_type()));
  const torch::Tensor rays = torch::matmul(pix, k_inv.transpose(-1, -2));  // [(B,) HW, 3]
  const torch::Tensor depth = 1.0 / tgt_inv_depth.reshape({b, h * w, 1});
  return rays.expand({b, h * w, 3}) * depth;
}

InverseWarpResult InverseWarp(const torch::Tensor& source, const torch::Tensor& tgt_inv_depth,
                              const torch::Tensor& src_from_tgt, const torch::Tensor& tgt_intrinsics,
                              const torch::Tensor& src_intrinsics) {
  TORCH_CHECK(source.dim() == 4, "InverseWarp: source must be [N, C, Hs, Ws], got ", source.sizes());
  const int64_t n = source.size(0), hs = source.size(2), ws = source.size(3);
  TORCH_CHECK(tgt_inv_depth.dim() == 4 && tgt_inv_depth.size(1) == 1 &&
                  (tgt_inv_depth.size(0) == 1 || tgt_inv_depth.size(0) == n),
              "InverseWarp: inverse depth must be [1 or N, 1, H, W], got ", tgt_inv_depth.sizes());
  TORCH_CHECK(
      src_from_tgt.dim() == 3 && src_from_tgt.size(0) == n && src_from_tgt.size(1) == 4 && src_from_tgt.size(2) == 4,
      "InverseWarp: src_from_tgt must be [N, 4, 4], got ", src_from_tgt.sizes());
  CheckIntrinsics(src_intrinsics, "InverseWarp");
  const int64_t h = tgt_inv_depth.size(2), w = tgt_inv_depth.size(3);
  const auto dtype = source.scalar_type();

  CheckIntrinsics(tgt_intrinsics, "InverseWarp");
  torch::Tensor inv_depth = tgt_inv_depth.to(dtype);
  if (tgt_intrinsics.dim() == 3) inv_depth = inv_depth.expand({n, 1, h, w});
  torch::Tensor x_in_tgt = BackProject(inv_depth, tgt_intrinsics);  // [1|N, HW, 3]
  x_in_tgt = x_in_tgt.expand({n, h * w, 3});
  const torch::Tensor x_in_src = Se3Apply(src_from_tgt.to(dtype), x_in_tgt);  // [N, HW, 3]
  const torch::Tensor uvw = torch::matmul(x_in_src, src_intrinsics.to(dtype).transpose(-1, -2));
  const torch::Tensor z = uvw.select(-1, 2);
  const torch::Tensor in_front = z > kMinDepth;
  const torch::Tensor z_safe = torch::where(in_front, z, torch::full_like(z, kMinDepth));
  const torch::Tensor u = uvw.select(-1, 0) / z_safe, v = uvw.select(-1, 1) / z_safe;
  // Inside the hull of the source pixel centres, where bilinear sampling reads no padding.
  const double lo = 0.5 - kHullSlack;
  const torch::Tensor inside =
      in_front & (u >= lo) & (u <= static_cast<double>(ws) - lo) & (v >= lo) & (v <= static_cast<double>(hs) - lo);
  // Far outside points are clamped so that grid_sample stays well-conditioned (they are invalid).
  const torch::Tensor gx = (2.0 * u / static_cast<double>(ws) - 1.0).clamp(-2.0, 2.0);
  const torch::Tensor gy = (2.0 * v / static_cast<double>(hs) - 1.0).clamp(-2.0, 2.0);
  InverseWarpResult result;
  result.grid = torch::stack({gx, gy}, -1).view({n, h, w, 2});
  result.warped = F::grid_sample(
      source, result.grid,
      F::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kBorder).align_corners(false));
  result.valid = inside.to(dtype).view({n, 1, h, w});
  return result;
}

InverseWarpResult InverseWarp(const torch::Tensor& source, const torch::Tensor& tgt_inv_depth,
                              const torch::Tensor& src_from_tgt, const torch::Tensor& intrinsics) {
  return InverseWarp(source, tgt_inv_depth, src_from_tgt, intrinsics, intrinsics);
}

}  // namespace nerfreg
