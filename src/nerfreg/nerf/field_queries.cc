#include "nerfreg/nerf/field_queries.h"

#include <stdexcept>

#include "nerfreg/geometry/conventions.h"

namespace nerfreg {

void SurfaceFieldOptions::Check() const {
  if (max_cameras < 1 || step_size < 0 || stop_before < 0)
    throw std::invalid_argument("SurfaceFieldOptions: out of range");
  if (mode != "max_weight" && mode != "opacity" && mode != "window") {
    throw std::invalid_argument("SurfaceFieldOptions: mode must be max_weight, opacity or window");
  }
  if (!(min_transmittance >= 0 && min_transmittance < 1))
    throw std::invalid_argument("SurfaceFieldOptions: min_transmittance must be in [0, 1)");
  if (mode == "window" && !(window > 0))
    throw std::invalid_argument("SurfaceFieldOptions: mode window needs window > 0");
}

torch::Tensor QueryDensity(NerfBlock& block, const torch::Tensor& positions) { return BlockDensity(block, positions); }

namespace {

// Rays from cameras to points, in the field's frame: each from origin [R, 3] along unit dir
// [R, 3], entering the field's box at `enter` [R] and reaching its point at `dist` [R].
struct SurfaceRays {
  torch::Tensor origin, dir, enter, dist;
};

// Each ray's measure (SurfaceFieldOptions::mode) [R]. The rays are marched together, a few steps
// at a time: a ray leaves the march at its end (X, or half a window past it) or once its
// transmittance is below options.min_transmittance, so no ray is padded to the longest one's
// steps and the field is not queried behind a surface the ray has already ended on.
torch::Tensor MarchSurfaceRays(NerfBlock& block, const SurfaceRays& r, const SurfaceFieldOptions& options, double step,
                               const torch::Tensor& occupied) {
  const torch::Device device = r.origin.device();
  const auto f32 = torch::TensorOptions(torch::kFloat32).device(device);
  const bool window_mode = options.mode == "window";
  const auto aabb_min = torch::tensor(block.field_options.aabb_min, torch::kFloat32).to(device);  // [3]
  const auto aabb_max = torch::tensor(block.field_options.aabb_max, torch::kFloat32).to(device);  // [3]
  const std::int64_t g = block.grid->resolution();
  const std::int64_t rays = r.origin.size(0);
  // Window mode marches on to half a window past X (its weight counts from half a window before
  // X); the others stop at X.
  const auto end = window_mode ? r.dist + 0.5 * options.window : r.dist - options.stop_before;  // [R]
  const auto window_start = r.dist - 0.5 * options.window;                                      // [R]
  auto score = torch::zeros({rays}, f32);                                                 // the ray's measure so far
  auto transmit = torch::ones({rays}, f32);                                               // T before the next step
  auto active = torch::arange(rays, torch::TensorOptions(torch::kInt64).device(device));  // rays still marching
  constexpr std::int64_t kSteps = 16;                                                     // steps per round
  for (std::int64_t k0 = 0; active.numel() > 0; k0 += kSteps) {
    const std::int64_t m = active.numel();
    const auto t0 = r.enter.index_select(0, active), d_end = end.index_select(0, active);
    const auto ts = t0.unsqueeze(1) + (torch::arange(k0, k0 + kSteps, f32) + 0.5) * step;  // [m, K]
    const auto valid = ts <= d_end.unsqueeze(1);                                           // [m, K]
    const auto pos = r.origin.index_select(0, active).unsqueeze(1) +
                     r.dir.index_select(0, active).unsqueeze(1) * ts.unsqueeze(2);  // [m, K, 3]
    // Density only where the sample is valid and its occupancy cell is occupied.
    const auto cell = ((pos - aabb_min) / (aabb_max - aabb_min) * g).floor().to(torch::kInt64);  // [m, K, 3]
    const auto in_box = ((cell >= 0) & (cell < g)).all(2);
    const auto cc = cell.clamp(0, g - 1);
    const auto occ = occupied.index({cc.select(2, 0), cc.select(2, 1), cc.select(2, 2)});
    const auto query = (valid & in_box & occ).reshape(-1).nonzero().squeeze(1);
    auto sigma = torch::zeros({m * kSteps}, f32);
    if (query.numel() > 0) {
      const auto q = pos.reshape({-1, 3}).index_select(0, query);
      std::vector<torch::Tensor> parts;
      for (std::int64_t k = 0; k < q.size(0); k += 1 << 17)
        parts.push_back(block.field->Density(q.slice(0, k, k + (1 << 17))));
      sigma.index_copy_(0, query, torch::cat(parts));
    }
    sigma = sigma.view({m, kSteps});
    const auto alpha = 1 - torch::exp(-sigma * step);
    const auto kept = torch::cumprod(1 - alpha, 1);  // [m, K] T after each step, relative to the round's start
    const auto t_in = transmit.index_select(0, active);
    const auto trans = torch::cat({torch::ones({m, 1}, f32), kept.slice(1, 0, -1)}, 1) * t_in.unsqueeze(1);
    const auto weight = alpha * trans * valid;  // [m, K]
    const auto s_in = score.index_select(0, active);
    torch::Tensor s_out;
    if (window_mode) {
      s_out = s_in + (weight * (ts >= window_start.index_select(0, active).unsqueeze(1))).sum(1);
    } else {
      s_out = options.mode == "opacity" ? s_in + weight.sum(1) : torch::maximum(s_in, weight.amax(1));
    }
    const auto t_out = t_in * kept.select(1, kSteps - 1);
    score.index_copy_(0, active, s_out);
    transmit.index_copy_(0, active, t_out);
    // On while this round's last step was valid (the steps are in order: the next may be too) and
    // the ray has not ended.
    active = active.index({valid.select(1, kSteps - 1) & (t_out >= options.min_transmittance)});
  }
  return score;
}

// SurfaceField in the field's frame: `points` [N, 3] and `cameras` there, lengths in its units.
// Runs on the points' device (SurfaceField moves them to the block's); the result [N] is there.
torch::Tensor SurfaceFieldInFieldFrame(NerfBlock& block, const Dataset& cameras, const torch::Tensor& points,
                                       const SurfaceFieldOptions& options) {
  const torch::Device device = points.device();
  const auto f32 = torch::TensorOptions(torch::kFloat32).device(device);
  const auto train = cameras.IndicesOfSplit("train");
  const std::int64_t n = points.size(0);
  auto best = torch::zeros({n}, f32);
  if (train.empty() || n == 0) return best;
  // Cameras spread over the trajectory: at most max_cameras training cameras, evenly spaced. (A
  // stride of size / max_cameras, rounded down, took all 22 of a 22-camera block.)
  const std::int64_t num_cameras = std::min<std::int64_t>(static_cast<std::int64_t>(train.size()), options.max_cameras);
  const double step = options.step_size > 0 ? options.step_size : block.march.step_size;
  const auto aabb_min = torch::tensor(block.field_options.aabb_min, torch::kFloat32).to(device);  // [3]
  const auto aabb_max = torch::tensor(block.field_options.aabb_max, torch::kFloat32).to(device);  // [3]
  // [G, G, G] bool; no copy where the grid lives on the block's device (LoadNerfBlock puts it there).
  const torch::Tensor occupied = block.grid->occupied().to(device);
  // Rays of several cameras are marched together, up to kBatch at a time (bounded memory); each
  // point's S is the maximum over the cameras, taken one camera's piece (distinct points) at a time.
  constexpr std::int64_t kBatch = 1 << 16;
  std::vector<torch::Tensor> piece_point;
  std::vector<SurfaceRays> pieces;
  std::int64_t pending = 0;
  const auto flush = [&]() {
    if (pieces.empty()) return;
    SurfaceRays all;
    std::vector<torch::Tensor> o, d, e, l;
    for (const SurfaceRays& p : pieces)
      o.push_back(p.origin), d.push_back(p.dir), e.push_back(p.enter), l.push_back(p.dist);
    all.origin = torch::cat(o), all.dir = torch::cat(d), all.enter = torch::cat(e), all.dist = torch::cat(l);
    const torch::Tensor score = MarchSurfaceRays(block, all, options, step, occupied);  // [R]
    std::int64_t first = 0;
    for (const torch::Tensor& idx : piece_point) {
      const std::int64_t count = idx.numel();
      best.index_put_({idx}, torch::maximum(best.index_select(0, idx), score.slice(0, first, first + count)));
      first += count;
    }
    pieces.clear(), piece_point.clear(), pending = 0;
  };
  for (std::int64_t k = 0; k < num_cameras; ++k) {
    const Frame& f = cameras.frames[train[k * static_cast<std::int64_t>(train.size()) / num_cameras]];
    // Which points this camera sees (in front, inside the image).
    const Eigen::Matrix3f r = f.cam_from_world.RotationMatrix().cast<float>();
    const Eigen::Vector3f t = f.cam_from_world.translation.cast<float>();
    const auto R =
        torch::from_blob(const_cast<float*>(r.data()), {3, 3}, torch::kFloat32).t().clone().to(device);  // row-major
    const auto T = torch::tensor({t.x(), t.y(), t.z()}).to(device);                                      // [3]
    const auto pc = points.matmul(R.t()) + T;
    const auto z = pc.select(1, 2);
    const auto u = f.camera.fx * pc.select(1, 0) / z + f.camera.cx, v = f.camera.fy * pc.select(1, 1) / z + f.camera.cy;
    const auto visible = (z > 0.05) & (u >= 0) & (u < f.camera.width) & (v >= 0) & (v < f.camera.height);
    const auto idx = visible.nonzero().squeeze(1);
    if (idx.numel() == 0) continue;
    const Eigen::Vector3d centre = CameraCenter(f.cam_from_world);
    const auto o = torch::tensor({float(centre.x()), float(centre.y()), float(centre.z())}).to(device);  // [3]
    const auto x = points.index_select(0, idx);
    const auto dist = (x - o).norm(2, 1);          // [M]
    const auto dir = (x - o) / dist.unsqueeze(1);  // [M, 3]
    // Each ray starts where it enters the field's box (density is zero outside it), so only the
    // stretch inside the box is marched.
    const auto inv = 1.0 / torch::where(dir.abs() < 1e-9, torch::full_like(dir, 1e-9), dir);
    const auto t_a = (aabb_min - o) * inv, t_b = (aabb_max - o) * inv;
    const auto t_enter = torch::clamp_min(torch::minimum(t_a, t_b).amax(1), 0.0);  // [M]
    for (std::int64_t s = 0; s < idx.numel(); s += kBatch) {
      const auto piece = idx.slice(0, s, s + kBatch);
      const std::int64_t count = piece.numel();
      pieces.push_back({o.expand({count, 3}), dir.slice(0, s, s + kBatch), t_enter.slice(0, s, s + kBatch),
                        dist.slice(0, s, s + kBatch)});
      piece_point.push_back(piece);
      pending += count;
      if (pending >= kBatch) flush();
    }
  }
  flush();
  return best;
}

}  // namespace

torch::Tensor SurfaceField(NerfBlock& block, const torch::Tensor& points, const SurfaceFieldOptions& options) {
  options.Check();
  TORCH_CHECK(points.dim() == 2 && points.size(1) == 3, "SurfaceField: points must be [N, 3]");
  torch::NoGradGuard no_grad;
  // Computed on the block's device (the points go there once); the result comes back to theirs.
  const torch::Device out = points.device();
  const torch::Tensor p = points.to(block.Device());  // [N, 3]
  if (!block.Moved()) return SurfaceFieldInFieldFrame(block, block.cameras, p, options).to(out);
  // A moved block (reg apply): the cameras and lengths carried back into the field's frame, where
  // its occupancy grid and box are.
  const Sim3d field_from_world = block.world_from_field.Inverse();
  Dataset cameras = block.cameras;
  for (Frame& f : cameras.frames) f.cam_from_world = field_from_world.TransformCamera(f.cam_from_world);
  SurfaceFieldOptions o = options;
  const double s = block.world_from_field.scale;
  o.step_size /= s;
  o.stop_before /= s;
  o.window /= s;
  return SurfaceFieldInFieldFrame(block, cameras, ToFieldFrame(block, p), o).to(out);
}

BlockPoints ExtractOccupiedPoints(NerfBlock& block, double min_density, unsigned seed, bool shell) {
  torch::NoGradGuard no_grad;
  torch::Generator gen = at::detail::createCPUGenerator(seed);
  // Cells of the occupancy grid, in the field's frame; the points returned are in the block's.
  // Computed on the grid's device (the block's, after LoadNerfBlock); the jitter is drawn on the
  // CPU from `gen` and copied, so every device picks the same points.
  const auto centres = block.grid->CellCenters();                                       // [G^3, 3]
  const torch::Tensor cells = block.grid->occupied().reshape(-1).nonzero().squeeze(1);  // [C] flat indices
  const auto cand = centres.index_select(0, cells);                                     // [C, 3]
  const double cell = (block.field_options.aabb_max[0] - block.field_options.aabb_min[0]) / block.grid->resolution();
  const auto pts = FromFieldFrame(block, cand + (torch::rand(cand.sizes(), gen).to(cand.device()) - 0.5) * cell);
  const auto sigma = QueryDensity(block, pts);
  torch::Tensor dense = (sigma > min_density).to(torch::kCPU);  // [C]
  if (shell) {
    const int64_t r = block.grid->resolution();
    torch::Tensor volume = torch::zeros({r * r * r}, torch::kFloat);  // [R^3] 1 where dense
    volume.index_put_({cells.to(torch::kCPU).index({dense})}, 1.0f);
    namespace F = torch::nn::functional;
    // Outside the grid is outside the solid: pad with empty cells before looking at neighbours.
    const torch::Tensor empty =
        F::pad(1.0f - volume.reshape({1, 1, r, r, r}), F::PadFuncOptions({1, 1, 1, 1, 1, 1}).value(1.0));
    const torch::Tensor near_empty = F::max_pool3d(empty, F::MaxPool3dFuncOptions(3).stride(1)).reshape(-1);  // [R^3]
    dense = dense & (near_empty.index_select(0, cells.to(torch::kCPU)) > 0);
  }
  const auto keep = dense.nonzero().squeeze(1).to(sigma.device());
  BlockPoints out;
  out.xyz = pts.index_select(0, keep);
  out.sigma = sigma.index_select(0, keep);
  out.alpha = (1 - torch::exp(-0.01 * out.sigma)).clamp(0, 1);
  out.rgb = ViewAveragedColor(block, out.xyz);
  // Handed back on the CPU (point clouds, PLY files and registration read them there).
  out.xyz = out.xyz.to(torch::kCPU);
  out.rgb = out.rgb.to(torch::kCPU);
  out.sigma = out.sigma.to(torch::kCPU);
  out.alpha = out.alpha.to(torch::kCPU);
  return out;
}

torch::Tensor ViewAveragedColor(NerfBlock& block, const torch::Tensor& positions) {
  torch::NoGradGuard no_grad;
  // Summed on the block's device (the positions go there once); the result comes back to theirs.
  const torch::Device device = block.Device();
  const torch::Tensor x = ToFieldFrame(block, positions.to(device));  // [N, 3]
  const torch::Tensor dirs = DirectionsToFieldFrame(
      block,
      torch::tensor({1.f, 0.f, 0.f, -1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, -1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, -1.f})
          .view({6, 3})
          .to(device));                                                            // [6, 3]
  auto rgb = torch::zeros({x.size(0), 3}, torch::TensorOptions().device(device));  // [N, 3]
  // The field's density part once per point, its colour head once per direction.
  for (std::int64_t s = 0; s < x.size(0); s += 1 << 14) {
    const auto colors = block.field->ColorsAlong(x.slice(0, s, s + (1 << 14)), dirs);  // [n, 6, 3]
    auto out = rgb.slice(0, s, s + (1 << 14));
    for (int d = 0; d < 6; ++d) out += colors.select(1, d) / 6.0;  // in order: the sum rounds as it did
  }
  return rgb.to(positions.device());
}

}  // namespace nerfreg
