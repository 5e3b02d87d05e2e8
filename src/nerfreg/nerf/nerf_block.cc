#include "nerfreg/nerf/nerf_block.h"

#include <fmt/format.h>

#include <filesystem>

#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/geometry/rays.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {

NerfBlock NerfBlock::Create(const FieldOptions& fo, const OccupancyGridOptions& go, const MarchOptions& march,
                            unsigned seed) {
  torch::manual_seed(seed);
  NerfBlock b;
  b.field_options = fo;
  b.grid_options = go;
  b.march = march;
  b.field = NerfField(fo);
  b.grid = std::make_unique<OccupancyGrid>(go, fo.aabb_min, fo.aabb_max);
  return b;
}

void CameraRays(const Camera& camera, const Rigid3d& cam_from_world, torch::Tensor* origins, torch::Tensor* dirs) {
  Eigen::Matrix3Xd o, d;
  GenerateRays(camera, cam_from_world, &o, &d);
  const Eigen::Matrix3Xf of = o.cast<float>(), df = d.cast<float>();
  *origins = torch::from_blob(const_cast<float*>(of.data()), {of.cols(), 3}, torch::kFloat32).clone();
  *dirs = torch::from_blob(const_cast<float*>(df.data()), {df.cols(), 3}, torch::kFloat32).clone();
}

bool NerfBlock::Moved() const { return world_from_field.ToMatrix() != Eigen::Matrix4d::Identity(); }

torch::Device NerfBlock::Device() const { return field->table.device(); }

void NerfBlock::To(const torch::Device& device) {
  field->to(device);
  grid->To(device);
}

namespace {

// world_from_field's rotation [3, 3] (row-major) and translation [3] as float32 tensors on `like`'s device.
std::pair<torch::Tensor, torch::Tensor> FrameTensors(const NerfBlock& block, const torch::Tensor& like) {
  const Eigen::Matrix<float, 3, 3, Eigen::RowMajor> r =
      block.world_from_field.rotation.toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = block.world_from_field.translation.cast<float>();
  const auto opts = torch::TensorOptions().dtype(torch::kFloat32).device(like.device());
  return {torch::from_blob(const_cast<float*>(r.data()), {3, 3}, torch::kFloat32).clone().to(opts),
          torch::tensor({t.x(), t.y(), t.z()}).to(opts)};
}

}  // namespace

// Row vectors: (R^T v)^T = v^T R.
torch::Tensor ToFieldFrame(const NerfBlock& block, const torch::Tensor& positions) {
  if (!block.Moved()) return positions;
  const auto [r, t] = FrameTensors(block, positions);
  return (positions.to(torch::kFloat32) - t).matmul(r) / block.world_from_field.scale;
}

torch::Tensor DirectionsToFieldFrame(const NerfBlock& block, const torch::Tensor& dirs) {
  if (!block.Moved()) return dirs;
  return dirs.to(torch::kFloat32).matmul(FrameTensors(block, dirs).first);
}

torch::Tensor FromFieldFrame(const NerfBlock& block, const torch::Tensor& positions) {
  if (!block.Moved()) return positions;
  const auto [r, t] = FrameTensors(block, positions);
  return block.world_from_field.scale * positions.to(torch::kFloat32).matmul(r.t()) + t;
}

torch::Tensor BlockDensity(NerfBlock& block, const torch::Tensor& positions) {
  torch::NoGradGuard no_grad;
  const torch::Tensor p = ToFieldFrame(block, positions);
  std::vector<torch::Tensor> out;
  for (std::int64_t s = 0; s < p.size(0); s += 1 << 17)
    out.push_back(block.field->Density(p.slice(0, s, s + (1 << 17))));
  const torch::Tensor sigma =
      out.empty() ? torch::zeros({0}, torch::TensorOptions().device(p.device())) : torch::cat(out);
  // A length of the block's frame is `scale` lengths of the field's: the density per unit length shrinks.
  return block.Moved() ? sigma / block.world_from_field.scale : sigma;
}

std::pair<torch::Tensor, torch::Tensor> BlockForward(NerfBlock& block, const torch::Tensor& positions,
                                                     const torch::Tensor& dirs) {
  torch::NoGradGuard no_grad;
  auto [sigma, rgb] = block.field->Forward(ToFieldFrame(block, positions), DirectionsToFieldFrame(block, dirs));
  if (block.Moved()) sigma = sigma / block.world_from_field.scale;
  return {sigma, rgb};
}

RenderedRays RenderRays(NerfBlock& block, const torch::Tensor& block_origins, const torch::Tensor& block_dirs,
                        const torch::Tensor& background, std::int64_t chunk) {
  torch::NoGradGuard no_grad;
  // The rays go to the field's device once; marching (against the grid, moved there with the block),
  // the field and compositing then run there, and only the results come back. On the CPU the
  // moves are no-ops.
  const torch::Device device = block.Device();
  const torch::Tensor bg = background.to(device);  // [3]
  // Marched in the field's frame (its occupancy grid and box live there); only depth changes units.
  const torch::Tensor origins = ToFieldFrame(block, block_origins.to(device)),
                      dirs = DirectionsToFieldFrame(block, block_dirs.to(device));  // [R, 3] each, on `device`
  MarchOptions march = block.march;
  march.perturb = false;
  std::vector<torch::Tensor> rgbs, opacities, depths;
  for (std::int64_t s = 0; s < origins.size(0); s += chunk) {
    const auto o = origins.slice(0, s, s + chunk), d = dirs.slice(0, s, s + chunk);
    const RaySamples samples = MarchRays(o, d, *block.grid, march);
    const std::int64_t R = o.size(0);
    if (samples.t_starts.numel() == 0) {
      rgbs.push_back(bg.expand({R, 3}).clone());
      opacities.push_back(torch::zeros({R}, torch::TensorOptions().device(device)));
      depths.push_back(torch::zeros({R}, torch::TensorOptions().device(device)));
      continue;
    }
    const auto t_mid = 0.5 * (samples.t_starts + samples.t_ends);
    const auto pos = o.index_select(0, samples.ray_ids) + d.index_select(0, samples.ray_ids) * t_mid.unsqueeze(1);
    auto [sigma, rgb] = block.field->Forward(pos, d.index_select(0, samples.ray_ids));
    const auto comp = Composite(sigma, rgb, samples.t_starts, samples.t_ends, samples.offsets);
    rgbs.push_back(comp.rgb + (1 - comp.opacity).unsqueeze(1) * bg);
    opacities.push_back(comp.opacity);
    depths.push_back(
        torch::where(comp.opacity > 1e-4, comp.depth / comp.opacity.clamp_min(1e-4), torch::zeros_like(comp.depth)) *
        block.world_from_field.scale);
  }
  const torch::Device out = block_origins.device();
  return {torch::cat(rgbs).to(out), torch::cat(opacities).to(out), torch::cat(depths).to(out)};
}

Image RenderImage(NerfBlock& block, const Camera& camera, const Rigid3d& cam_from_world) {
  torch::Tensor o, d;
  CameraRays(camera, cam_from_world, &o, &d);
  // The rays are made on the CPU (camera model, Eigen) and moved to the block's device by
  // RenderRays; the image comes back once ([H*W, 3]).
  const auto out = RenderRays(block, o, d, torch::ones({3})).rgb.clamp(0, 1).contiguous();
  Image im(camera.width, camera.height, 3);
  std::memcpy(im.data.data(), out.data_ptr<float>(), im.data.size() * sizeof(float));
  return im;
}

void MoveNerfBlock(NerfBlock* block, const Sim3d& new_from_old) {
  block->world_from_field = new_from_old * block->world_from_field;
  if ((block->world_from_field.ToMatrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff() < 1e-12) {
    block->world_from_field = Sim3d();
  }
  MoveCameras(&block->cameras, new_from_old);
}

namespace {
const char* kFormatTag = "nerfreg-nerf-block";

Json FieldOptionsToJson(const FieldOptions& f) {
  const auto& e = f.encoding;
  return {{"levels", e.levels},
          {"features", e.features},
          {"log2_table_size", e.log2_table_size},
          {"base_resolution", e.base_resolution},
          {"per_level_scale", e.per_level_scale},
          {"hidden_dim", f.hidden_dim},
          {"geo_feature_dim", f.geo_feature_dim},
          {"color_hidden_layers", f.color_hidden_layers},
          {"aabb_min", f.aabb_min},
          {"aabb_max", f.aabb_max},
          {"grid_rule", e.grid_rule},
          {"flavor", f.flavor},
          {"axis_order", f.axis_order},
          {"density_scale", f.density_scale}};
}

FieldOptions FieldOptionsFromJson(const JsonField& j) {
  FieldOptions f;
  f.encoding.levels = j["levels"].Int();
  f.encoding.features = j["features"].Int();
  f.encoding.log2_table_size = j["log2_table_size"].Int();
  f.encoding.base_resolution = j["base_resolution"].Int();
  f.encoding.per_level_scale = j["per_level_scale"].Double();
  f.hidden_dim = j["hidden_dim"].Int();
  f.geo_feature_dim = j["geo_feature_dim"].Int();
  f.color_hidden_layers = j["color_hidden_layers"].Int();
  f.aabb_min = j["aabb_min"].Doubles();
  f.aabb_max = j["aabb_max"].Doubles();
  // Absent in checkpoints written before instant-ngp import: the defaults ("nerfreg") apply.
  f.encoding.grid_rule = j.StringOr("grid_rule", f.encoding.grid_rule);
  f.flavor = j.StringOr("flavor", f.flavor);
  f.density_scale = j.DoubleOr("density_scale", f.density_scale);
  if (j.Has("axis_order")) {
    f.axis_order.clear();
    for (size_t k = 0; k < j["axis_order"].ArraySize(); ++k) f.axis_order.push_back(j["axis_order"][k].Int());
  }
  try {
    f.Check();
  } catch (const std::invalid_argument& e) {
    j.Fail(std::string("valid field options (") + e.what() + ")");
  }
  return f;
}
}  // namespace

namespace {

// Module::save's layout (its own parameters, then its buffers, then one nested archive per
// serializable child) with every tensor copied to the CPU first, so a module on a GPU is written
// as the same module on the CPU would be. Module::load reads it back into a module on any device.
void SaveModuleOnCpu(const torch::nn::Module& module, torch::serialize::OutputArchive& archive) {
  const auto cpu = [](const torch::Tensor& t) {
    return t.is_cpu() ? t : t.detach().to(torch::kCPU).requires_grad_(t.requires_grad());
  };
  for (const auto& p : module.named_parameters(/*recurse=*/false)) archive.write(p.key(), cpu(p.value()));
  for (const auto& b : module.named_buffers(/*recurse=*/false))
    archive.write(b.key(), cpu(b.value()), /*is_buffer=*/true);
  for (const auto& child : module.named_children()) {
    if (!child.value()->is_serializable()) continue;
    torch::serialize::OutputArchive child_archive(archive.compilation_unit());
    SaveModuleOnCpu(*child.value(), child_archive);
    archive.write(child.key(), child_archive);
  }
}

// The cameras as transforms.json, with the folder their image paths start from ("root", absolute;
// our own key, ignored by other readers) so the images can be found from the checkpoint alone
// (reg register-many --merged-cameras).
Json CamerasJson(const Dataset& cameras) {
  Json j = TransformsJsonFromDataset(cameras);
  if (!cameras.root.empty()) j["root"] = std::filesystem::absolute(cameras.root).lexically_normal().string();
  return j;
}

}  // namespace

void SaveNerfBlock(const NerfBlock& block, const std::string& path,
                   const std::function<void(torch::serialize::OutputArchive&)>& extra) {
  Json meta = {{"format", kFormatTag},
               {"version", kNerfCheckpointVersion},
               {"step", block.step},
               {"field", FieldOptionsToJson(block.field_options)},
               {"grid",
                {{"resolution", block.grid_options.resolution},
                 {"update_every", block.grid_options.update_every},
                 {"warmup_steps", block.grid_options.warmup_steps},
                 {"ema_decay", block.grid_options.ema_decay},
                 {"threshold", block.grid_options.threshold}}},
               {"march",
                {{"step_size", block.march.step_size},
                 {"near", block.march.near},
                 {"max_samples_per_ray", block.march.max_samples_per_ray}}},
               {"cameras", CamerasJson(block.cameras)},
               {"world_from_field", MatrixToJson(block.world_from_field.ToMatrix())},
               {"train_options", block.train_options}};
  torch::serialize::OutputArchive archive;
  archive.write("meta", StringTensor(meta.dump()));
  torch::serialize::OutputArchive field_archive;
  if (block.Device().is_cpu()) {
    block.field->save(field_archive);
  } else {
    SaveModuleOnCpu(*block.field, field_archive);
  }
  archive.write("field", field_archive);
  // CPU tensors: an archive keeps each tensor's device, and a GPU-trained block must load anywhere.
  archive.write("grid_density", block.grid->density().to(torch::kCPU));
  archive.write("grid_occupied", block.grid->occupied().to(torch::kUInt8).to(torch::kCPU));
  if (extra) extra(archive);
  SaveArchiveAtomic(archive, path);
}

NerfBlock LoadNerfBlock(const std::string& path, const std::function<void(torch::serialize::InputArchive&)>& extra,
                        const torch::Device& device) {
  torch::serialize::InputArchive archive;
  const Json meta = LoadArchiveMeta(path, "NeRF checkpoint", kFormatTag, kNerfCheckpointVersion, &archive);
  const JsonField m(meta, path);
  NerfBlock b;
  b.field_options = FieldOptionsFromJson(m["field"]);
  b.grid_options.resolution = m["grid"]["resolution"].Int();
  b.grid_options.update_every = m["grid"]["update_every"].Int();
  b.grid_options.warmup_steps = m["grid"]["warmup_steps"].Int();
  b.grid_options.ema_decay = m["grid"]["ema_decay"].Double();
  b.grid_options.threshold = m["grid"]["threshold"].Double();
  b.march.step_size = m["march"]["step_size"].Double();
  b.march.near = m["march"]["near"].Double();
  b.march.max_samples_per_ray = m["march"]["max_samples_per_ray"].Int();
  b.step = m["step"].Int();
  b.train_options = meta.value("train_options", Json::object());
  // Absent in checkpoints written before `reg apply`: the identity.
  if (m.Has("world_from_field")) {
    try {
      b.world_from_field = Sim3d::FromMatrix(Eigen::Matrix4d(m["world_from_field"].Matrix(4, 4)), 1e-6);
    } catch (const std::invalid_argument& e) {
      m["world_from_field"].Fail(std::string("a similarity transform (") + e.what() + ")");
    }
    if (!(b.world_from_field.scale >= kMinSim3Scale && b.world_from_field.scale <= kMaxSim3Scale)) {
      m["world_from_field"].Fail(
          fmt::format("a scale in [{:g}, {:g}], got {:g}", kMinSim3Scale, kMaxSim3Scale, b.world_from_field.scale));
    }
  }
  try {
    b.grid_options.Check();
    b.march.Check();
  } catch (const std::invalid_argument& e) {
    ThrowInputError(path, "grid", std::string("valid grid and march settings (") + e.what() + ")");
  }
  // A corrupted size must be an error, not a multi-GB allocation (real tables are ~64 MB).
  const auto& enc = b.field_options.encoding;
  if (double(enc.levels) * double(enc.TableSize()) * enc.features * 4 > double(std::int64_t(1) << 32)) {
    ThrowInputError(path, "field", "a hash table of at most 4 GiB");
  }
  // The stored tensors (field.cc, occupancy_grid.cc): hash table, density and colour MLPs, grid.
  const double h = b.field_options.hidden_dim, geo = b.field_options.geo_feature_dim;
  const double g = b.grid_options.resolution;
  CheckArchiveCanHold(path, "field",
                      double(enc.levels) * double(enc.TableSize()) * enc.features + h * enc.OutputDim() +
                          h * (1 + geo) + h * (16 + geo) + (b.field_options.color_hidden_layers - 1) * h * h + 3 * h +
                          g * g * g);
  b.field = NerfField(b.field_options);
  b.grid = std::make_unique<OccupancyGrid>(b.grid_options, b.field_options.aabb_min, b.field_options.aabb_max);
  try {
    torch::serialize::InputArchive field_archive;
    archive.read("field", field_archive);
    b.field->load(field_archive);
    torch::Tensor density, occupied;
    archive.read("grid_density", density);
    archive.read("grid_occupied", occupied);
    b.grid->SetState(density, occupied);
    if (extra) extra(archive);
  } catch (const c10::Error& e) {
    ThrowInputError(path, "", "a complete nerfreg NeRF checkpoint (tensors missing or of the wrong shape)");
  }
  // The training cameras, kept as transforms.json inside the checkpoint (with sizes: no image needed).
  // A block may have no cameras (an instant-ngp import without --transforms).
  // (meta is const: operator[] on a missing key would be undefined behaviour, found by fuzzing.)
  if (!meta.contains("cameras"))
    ThrowInputError(path, "cameras", "the block's cameras (transforms.json, frames may be empty)");
  const Json& cams = meta["cameras"];
  const bool no_cameras =
      cams.is_object() && cams.contains("frames") && cams["frames"].is_array() && cams["frames"].empty();
  if (!no_cameras) {
    // Checkpoints written before "root" was recorded: paths from the checkpoint's folder.
    const bool has_root = cams.is_object() && cams.contains("root") && cams["root"].is_string();
    b.cameras = DatasetFromTransformsJson(cams, path + " (cameras)",
                                          has_root ? cams["root"].get<std::string>() : ParentDir(path));
  }
  b.To(device);
  return b;
}

}  // namespace nerfreg
