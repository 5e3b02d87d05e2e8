// Projection of 3D samples into source views and the per-view inputs of the IBRNet aggregation
// (spec dbarf.md 2, "Projection and aggregation"). Pure, differentiable tensor functions: in
// DBARF's joint stage the NeRF loss reaches the pose network through cam_from_world here.
//
// Conventions (project-wide, as in geometry/camera.h): pinhole K in pixels, OpenCV axes
// (+x right, +y down, +z forward), x_cam = R x_world + t. The pixel (col, row) has its centre at
// (col + 0.5, row + 0.5), so the image spans [0, W] x [0, H] in continuous coordinates and a
// continuous point (u, v) is sampled with grid_sample(align_corners = false) at
// (2u / W - 1, 2v / H - 1). This replaces the original's integer-pixel / align_corners = True
// convention. A feature map at 1/4 resolution covers the same extent, so the same normalised
// coordinates sample it.
//
// Tensors are float32; float64 throughout is accepted too (for finite-difference gradient checks).
#pragma once

#include <torch/torch.h>

namespace nerfreg {

struct ProjectedPoints {
  // [V, R, S, 2] float32: continuous pixel coordinates (u, v) in each view.
  torch::Tensor uv;
  // [V, R, S] bool: the point is in front of the camera (camera-frame z > 0).
  torch::Tensor in_front;
  // [V, R, S] bool: 0 <= u <= W and 0 <= v <= H.
  torch::Tensor in_bounds;
  // in_front & in_bounds: the sample/view pairs the aggregation uses.
  torch::Tensor Valid() const { return in_front & in_bounds; }
};

// Projects points [R, S, 3] float32 (world) into V views with intrinsics [V, 3, 3] and
// cam_from_world [V, 4, 4] (float32) of images of size height x width. Points behind a camera get
// finite but meaningless uv (their depth is clamped to 1e-6 before the division).
ProjectedPoints ProjectToViews(const torch::Tensor& points, const torch::Tensor& intrinsics,
                               const torch::Tensor& cam_from_world, int64_t height, int64_t width);

// Bilinearly samples maps [V, C, h, w] float32 (images or feature maps covering an image of size
// height x width) at uv [V, R, S, 2] (continuous pixel coordinates of that image); zero outside.
// Returns [V, R, S, C].
torch::Tensor SampleViews(const torch::Tensor& maps, const torch::Tensor& uv, int64_t height, int64_t width);

// Camera centres in the world, -R^T t, of cam_from_world [V, 4, 4] -> [V, 3].
torch::Tensor CameraCenters(const torch::Tensor& cam_from_world);

// IBRNet's ray-difference feature of points [R, S, 3] seen from the query (target) camera centre
// of each ray, query_centers [R, 3], and from source centres [V, 3]. With a = unit(query - x) and
// b = unit(source - x) (directions from the point to the cameras): the first three channels are
// unit(a - b) (zero when a == b), the fourth is dot(a, b) in [-1, 1]. Returns [V, R, S, 4].
torch::Tensor RayDifference(const torch::Tensor& points, const torch::Tensor& query_centers,
                            const torch::Tensor& source_centers);

}  // namespace nerfreg
