#include "nerfreg/dbarf/projection.h"

namespace nerfreg {
namespace {

void CheckCameras(const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, torch::ScalarType dtype) {
  TORCH_CHECK(intrinsics.dim() == 3 && intrinsics.size(1) == 3 && intrinsics.size(2) == 3,
              "intrinsics must be [V,3,3], got ", intrinsics.sizes());
  TORCH_CHECK(cam_from_world.dim() == 3 && cam_from_world.size(1) == 4 && cam_from_world.size(2) == 4 &&
                  cam_from_world.size(0) == intrinsics.size(0),
              "cam_from_world must be [V,4,4] with V = ", intrinsics.size(0), ", got ", cam_from_world.sizes());
  TORCH_CHECK(intrinsics.scalar_type() == dtype && cam_from_world.scalar_type() == dtype,
              "cameras must have the points' dtype ", dtype);
}

void CheckPoints(const torch::Tensor& points) {
  TORCH_CHECK(points.dim() == 3 && points.size(2) == 3, "points must be [R,S,3], got ", points.sizes());
  TORCH_CHECK(points.scalar_type() == torch::kFloat || points.scalar_type() == torch::kDouble,
              "points must be float32 (or float64)");
}

torch::Tensor Unit(const torch::Tensor& v, double eps) { return v / (v.norm(2, -1, true) + eps); }

}  // namespace

ProjectedPoints ProjectToViews(const torch::Tensor& points, const torch::Tensor& intrinsics,
                               const torch::Tensor& cam_from_world, int64_t height, int64_t width) {
  CheckPoints(points);
  CheckCameras(intrinsics, cam_from_world, points.scalar_type());
  TORCH_CHECK(height > 0 && width > 0, "image size must be positive");
  const int64_t v = intrinsics.size(0), r = points.size(0), s = points.size(1);
  const torch::Tensor x = points.reshape({1, r * s, 3});
  const torch::Tensor rot = cam_from_world.narrow(1, 0, 3).narrow(2, 0, 3);  // [V,3,3]
  const torch::Tensor t = cam_from_world.narrow(1, 0, 3).select(2, 3);       // [V,3]
  // x_cam = R x + t, then pixel = K x_cam, all as row vectors: [V, RS, 3].
  const torch::Tensor x_cam = torch::matmul(x, rot.transpose(1, 2)) + t.unsqueeze(1);
  const torch::Tensor pix = torch::matmul(x_cam, intrinsics.transpose(1, 2));
  const torch::Tensor z = x_cam.select(2, 2);
  ProjectedPoints out;
  out.uv = (pix.narrow(2, 0, 2) / pix.select(2, 2).clamp_min(1e-6).unsqueeze(2)).reshape({v, r, s, 2});
  out.in_front = (z > 0).reshape({v, r, s});
  const torch::Tensor u = out.uv.select(3, 0), vv = out.uv.select(3, 1);
  out.in_bounds = (u >= 0) & (u <= width) & (vv >= 0) & (vv <= height);
  return out;
}

torch::Tensor SampleViews(const torch::Tensor& maps, const torch::Tensor& uv, int64_t height, int64_t width) {
  TORCH_CHECK(maps.dim() == 4 && (maps.scalar_type() == torch::kFloat || maps.scalar_type() == torch::kDouble),
              "maps must be float32 (or float64) [V,C,h,w], got ", maps.sizes());
  TORCH_CHECK(uv.scalar_type() == maps.scalar_type(), "uv must have the maps' dtype");
  TORCH_CHECK(uv.dim() == 4 && uv.size(0) == maps.size(0) && uv.size(3) == 2,
              "uv must be [V,R,S,2] with V = ", maps.size(0), ", got ", uv.sizes());
  const torch::Tensor scale = torch::tensor({2.0 / width, 2.0 / height}, uv.options());
  const torch::Tensor grid = uv * scale - 1.0;  // [V,R,S,2] as an [N,H_out,W_out,2] grid
  const torch::Tensor sampled = torch::nn::functional::grid_sample(maps, grid,
                                                                   torch::nn::functional::GridSampleFuncOptions()
                                                                       .mode(torch::kBilinear)
                                                                       .padding_mode(torch::kZeros)
                                                                       .align_corners(false));  // [V,C,R,S]
  return sampled.permute({0, 2, 3, 1});
}

torch::Tensor CameraCenters(const torch::Tensor& cam_from_world) {
  TORCH_CHECK(cam_from_world.dim() == 3 && cam_from_world.size(1) == 4 && cam_from_world.size(2) == 4,
              "cam_from_world must be [V,4,4], got ", cam_from_world.sizes());
  const torch::Tensor rot = cam_from_world.narrow(1, 0, 3).narrow(2, 0, 3);
  const torch::Tensor t = cam_from_world.narrow(1, 0, 3).narrow(2, 3, 1);  // [V,3,1]
  return -torch::matmul(rot.transpose(1, 2), t).squeeze(2);
}

torch::Tensor RayDifference(const torch::Tensor& points, const torch::Tensor& query_centers,
                            const torch::Tensor& source_centers) {
  CheckPoints(points);
  TORCH_CHECK(query_centers.dim() == 2 && query_centers.size(0) == points.size(0) && query_centers.size(1) == 3,
              "query_centers must be [R,3] with R = ", points.size(0), ", got ", query_centers.sizes());
  TORCH_CHECK(source_centers.dim() == 2 && source_centers.size(1) == 3, "source_centers must be [V,3], got ",
              source_centers.sizes());
  const torch::Tensor to_query = Unit(query_centers.unsqueeze(1) - points, 1e-6).unsqueeze(0);
  const torch::Tensor to_source = Unit(source_centers.view({-1, 1, 1, 3}) - points.unsqueeze(0), 1e-6);  // [V,R,S,3]
  const torch::Tensor diff = to_query - to_source;
  const torch::Tensor direction = diff / diff.norm(2, -1, true).clamp_min(1e-6);
  const torch::Tensor dot = (to_query * to_source).sum(-1, true);
  return torch::cat({direction, dot}, -1);
}

}  // namespace nerfreg
