#include "nerfreg/nerf/trainer.h"

#include <cmath>
#include <fstream>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/sparse_adam.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image_metrics.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/torch_device.h"
#include "nerfreg/util/training_log.h"

namespace nerfreg {

NerfTrainOptions NerfTrainOptions::Preset(const std::string& name) {
  NerfTrainOptions o;
  o.preset = name;
  if (name == "default") {
    o.iterations = 10000;
    o.target_samples = 1 << 18;
    o.max_rays = 1 << 18;
    o.grid.resolution = 128;
    o.march.step_size = 3.0 * std::sqrt(3.0) / 1024;
    o.eval_every = 2000;
    o.checkpoint_every = 1000;
  } else if (name == "fast") {
    o.iterations = 2000;
    o.field.encoding.log2_table_size = 17;
    o.grid.resolution = 64;
    o.march.step_size = 4 * 3.0 * std::sqrt(3.0) / 1024;
  } else {
    ThrowInputError("--preset", "", "fast or default, got " + name);
  }
  return o;
}

void NerfTrainOptions::Check() const {
  if (iterations < 1) ThrowInputError("--iters", "", ">= 1");
  if (sparse_table_adam && !device.is_cpu())
    ThrowInputError("--device", device.str(), "cpu with the sparse table Adam (a CPU kernel)");
  if (target_samples < 1024 || initial_rays < 1 || max_rays < initial_rays || !(lr > 0) || eval_every < 0 ||
      checkpoint_every < 0) {
    throw InputError("nerf train: invalid options");
  }
  try {
    field.Check();
    grid.Check();
    march.Check();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("nerf train options: ") + e.what());
  }
}

Json NerfTrainOptions::ToJson() const {
  return {{"preset", preset},
          {"iterations", iterations},
          {"target_samples", target_samples},
          {"lr", lr},
          {"seed", seed},
          {"random_background", random_background},
          {"sparse_table_adam", sparse_table_adam},
          {"grid_resolution", grid.resolution},
          {"step_size", march.step_size},
          {"log2_table_size", field.encoding.log2_table_size}};
}

namespace {

struct TrainRays {
  torch::Tensor origins, dirs, rgba;  // [P, 3], [P, 3], [P, 4] float32, on the training device
};

// The training images' pixels and their rays, made on the CPU once and moved to `device` (the
// whole set, so that each step gathers its batch there).
TrainRays LoadRays(const Dataset& dataset, const std::vector<int>& indices, const torch::Device& device) {
  std::vector<torch::Tensor> os, ds, cs;
  for (int i : indices) {
    const Frame& f = dataset.frames[i];
    const Image im = ReadImage(dataset.ImagePath(f), 4);
    if (im.width != f.camera.width || im.height != f.camera.height) {
      ThrowInputError(dataset.ImagePath(f), "size",
                      std::to_string(f.camera.width) + "x" + std::to_string(f.camera.height) +
                          " as its camera says, image is " + std::to_string(im.width) + "x" +
                          std::to_string(im.height));
    }
    torch::Tensor o, d;
    CameraRays(f.camera, f.cam_from_world, &o, &d);
    os.push_back(o);
    ds.push_back(d);
    cs.push_back(
        torch::from_blob(const_cast<float*>(im.data.data()), {im.width * im.height, 4}, torch::kFloat32).clone());
  }
  return {torch::cat(os).to(device), torch::cat(ds).to(device), torch::cat(cs).to(device)};
}

// The field's box: the dataset's "aabb" (the object's box) made cubic and padded by 10 %, or
// DReg-NeRF's [-1.5, 1.5]^3 when the dataset has none.
void ChooseAabb(const Dataset& d, FieldOptions* f) {
  if (!d.aabb_min || !d.aabb_max) return;
  const Eigen::Vector3d c = 0.5 * (*d.aabb_min + *d.aabb_max);
  const double half = 0.55 * (*d.aabb_max - *d.aabb_min).maxCoeff();
  f->aabb_min = {c.x() - half, c.y() - half, c.z() - half};
  f->aabb_max = {c.x() + half, c.y() + half, c.z() + half};
}

torch::Tensor GeneratorState(torch::Generator& gen) { return gen.get_state(); }

}  // namespace

NerfEvalResult EvaluateNerfBlock(NerfBlock& block, const Dataset& dataset, int max_views) {
  NerfEvalResult r;
  auto test = dataset.IndicesOfSplit("test");
  if (test.empty()) return r;
  if (max_views > 0 && static_cast<int>(test.size()) > max_views) {
    std::vector<int> pick;
    for (int k = 0; k < max_views; ++k) pick.push_back(test[k * test.size() / max_views]);
    test = pick;
  }
  for (int i : test) {
    const Frame& f = dataset.frames[i];
    const Image gt_rgba = ReadImage(dataset.ImagePath(f), 4);
    const Image gt = CompositeOver(gt_rgba, 1, 1, 1);
    const Image pred = RenderImage(block, f.camera, f.cam_from_world);
    r.psnr += Psnr(pred, gt);
    r.ssim += Ssim(pred, gt);
    ++r.views;
  }
  r.psnr /= r.views;
  r.ssim /= r.views;
  return r;
}

NerfTrainResult TrainNerfBlock(const Dataset& dataset, const NerfTrainOptions& options_in, const std::string& ckpt,
                               bool resume) {
  NerfTrainOptions options = options_in;
  options.Check();
  const auto train_idx = dataset.IndicesOfSplit("train");
  if (train_idx.empty()) ThrowInputError(dataset.root, "frames", "at least one frame with \"split\": \"train\"");
  for (size_t k = 1; k < dataset.frames.size(); ++k) {
    if (dataset.frames[k].camera.width != dataset.frames[0].camera.width ||
        dataset.frames[k].camera.height != dataset.frames[0].camera.height) {
      ThrowInputError(dataset.frames[k].name, "size", "the same image size as " + dataset.frames[0].name);
    }
  }
  Timer timer;
  torch::Generator gen = at::detail::createCPUGenerator(options.seed);
  NerfBlock block;
  torch::optim::Adam* optimizer = nullptr;
  std::unique_ptr<torch::optim::Adam> opt_holder;
  std::unique_ptr<SparseAdam> table_adam;  // the table's optimizer when options.sparse_table_adam
  double seconds_before = 0;
  auto make_optimizer = [&] {
    std::vector<torch::optim::OptimizerParamGroup> groups;
    std::vector<torch::Tensor> mlp;
    for (const auto& p : block.field->named_parameters())
      if (p.key() != "table") mlp.push_back(p.value());
    if (options.sparse_table_adam) {
      table_adam = std::make_unique<SparseAdam>(block.field->table, SparseAdamOptions{0.9, 0.999, 1e-15});
    } else {
      groups.emplace_back(
          std::vector<torch::Tensor>{block.field->table},
          std::make_unique<torch::optim::AdamOptions>(torch::optim::AdamOptions(options.lr).eps(1e-15)));
    }
    groups.emplace_back(mlp, std::make_unique<torch::optim::AdamOptions>(
                                 torch::optim::AdamOptions(options.lr).eps(1e-15).weight_decay(1e-6)));
    opt_holder = std::make_unique<torch::optim::Adam>(groups, torch::optim::AdamOptions(options.lr).eps(1e-15));
    optimizer = opt_holder.get();
  };
  int n_rays = options.initial_rays;
  if (resume) {
    torch::Tensor gen_state, rays_tensor, seconds_tensor;
    std::unique_ptr<torch::serialize::InputArchive> opt_archive, table_archive;
    // Checked before the training state is read: reg apply writes a moved block without one.
    if (LoadNerfBlock(ckpt).Moved()) {
      ThrowInputError(ckpt, "world_from_field", "a block in the frame it was trained in (reg apply moved this one)");
    }
    block = LoadNerfBlock(ckpt, [&](torch::serialize::InputArchive& ar) {
      opt_archive = std::make_unique<torch::serialize::InputArchive>();
      ar.read("optimizer", *opt_archive);
      table_archive = std::make_unique<torch::serialize::InputArchive>();
      options.sparse_table_adam = ar.try_read("table_adam", *table_archive);
      ar.read("rng", gen_state);
      ar.read("n_rays", rays_tensor);
      ar.read("seconds", seconds_tensor);
    });
    // A resumed run keeps its checkpoint's table optimizer; the sparse one is a CPU kernel.
    if (options.sparse_table_adam && !options.device.is_cpu()) {
      ThrowInputError("--device", options.device.str(),
                      "cpu to resume " + ckpt + " (it trains its table with the sparse table Adam, a CPU kernel)");
    }
    block.To(options.device);
    make_optimizer();
    optimizer->load(*opt_archive);
    MoveOptimizerState(*optimizer, options.device);
    if (table_adam) table_adam->Load(*table_archive, "table");
    gen.set_state(gen_state);
    n_rays = static_cast<int>(rays_tensor.item<std::int64_t>());
    seconds_before = seconds_tensor.item<double>();
    LOG_INFO("resuming {} at step {}", ckpt, block.step);
  } else {
    ChooseAabb(dataset, &options.field);
    block = NerfBlock::Create(options.field, options.grid, options.march, options.seed);
    block.cameras = dataset;
    block.To(options.device);
    make_optimizer();
  }
  block.train_options = options.ToJson();
  const torch::Device device = options.device;
  const TrainRays rays = LoadRays(dataset, train_idx, device);
  const std::int64_t P = rays.origins.size(0);
  const bool has_alpha = (rays.rgba.select(1, 3) < 0.999).any().item<bool>();
  const std::string log_path = ckpt + ".log.jsonl";
  if (resume) RewindTrainingLog(log_path, block.step);
  std::ofstream log(log_path, resume ? std::ios::app : std::ios::trunc);

  auto save = [&] {
    const double secs = seconds_before + timer.Seconds();
    SaveNerfBlock(block, ckpt, [&](torch::serialize::OutputArchive& ar) {
      torch::serialize::OutputArchive opt_ar;
      // The Adam moments are written from the CPU (an archive keeps each tensor's device; the
      // checkpoint must load on a machine without a GPU), then moved back: two copies of the
      // moments per checkpoint, none per step.
      if (!device.is_cpu()) MoveOptimizerState(*optimizer, torch::kCPU);
      optimizer->save(opt_ar);
      if (!device.is_cpu()) MoveOptimizerState(*optimizer, device);
      ar.write("optimizer", opt_ar);
      if (table_adam) {
        torch::serialize::OutputArchive table_ar;
        table_adam->Save(table_ar, "table");
        ar.write("table_adam", table_ar);
      }
      ar.write("rng", GeneratorState(gen));
      ar.write("n_rays", torch::tensor(static_cast<std::int64_t>(n_rays)));
      ar.write("seconds", torch::tensor(secs, torch::kFloat64));
    });
  };
  auto density_fn = [&](const torch::Tensor& x) { return block.field->Density(x); };

  ProgressBar bar("nerf train", options.iterations, "it");
  bar.Resume(block.step);
  double loss_value = 0, psnr_test = 0;
  const double step_size = block.march.step_size;
  const int end_step = options.stop_after > 0 ? std::min(options.stop_after, options.iterations) : options.iterations;
  const int first_step = block.step;
  for (; block.step < end_step;) {
    const int step = block.step;
    // Learning-rate schedule: x0.33 at 50, 75 and 90 % of the run.
    double lr = options.lr;
    for (double m : {0.5, 0.75, 0.9})
      if (step >= m * options.iterations) lr *= 0.33;
    for (auto& g : optimizer->param_groups()) static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);

    block.grid->Update(step, step_size, density_fn, gen);

    // One training step: batch -> samples -> field -> composite -> loss, all on `device`. The
    // batch's pixels are drawn on the CPU from `gen` (n_rays int64 go over), as are the marching
    // offsets (MarchRays) and the background colours: every device takes the same batch.
    const auto idx = torch::randint(P, {n_rays}, gen, torch::kInt64).to(device);           // [n_rays]
    const auto o = rays.origins.index_select(0, idx), d = rays.dirs.index_select(0, idx);  // [n_rays, 3]
    const auto target_rgba = rays.rgba.index_select(0, idx);                               // [n_rays, 4]
    MarchOptions march = block.march;
    march.perturb = true;
    const RaySamples s = MarchRays(o, d, *block.grid, march, gen);  // on `device`
    const std::int64_t S = s.t_starts.numel();
    if (S > 0) {
      const auto t_mid = 0.5 * (s.t_starts + s.t_ends);
      const auto pos = o.index_select(0, s.ray_ids) + d.index_select(0, s.ray_ids) * t_mid.unsqueeze(1);
      auto [sigma, rgb] = block.field->Forward(pos, d.index_select(0, s.ray_ids));
      const auto comp = options.field.reference_kernels
                            ? CompositeReference(sigma, rgb, s.t_starts, s.t_ends, s.offsets)
                            : Composite(sigma, rgb, s.t_starts, s.t_ends, s.offsets);
      const auto bg = has_alpha && options.random_background
                          ? torch::rand({n_rays, 3}, gen).to(device)
                          : torch::ones({n_rays, 3}, torch::TensorOptions().device(device));  // [n_rays, 3]
      const auto alpha = target_rgba.slice(1, 3, 4);
      const auto target = target_rgba.slice(1, 0, 3) * alpha + bg * (1 - alpha);
      const auto pred = comp.rgb + (1 - comp.opacity).unsqueeze(1) * bg;
      const auto loss = torch::smooth_l1_loss(pred, target);
      // What a step copies to the CPU is scalars: the sample count marching sizes its output by
      // (MarchRays), the occupancy threshold on update steps, and here the loss (checked for NaN
      // before the step) and the batch's MSE (the progress bar's PSNR), read together.
      const auto scalars = torch::stack({loss.detach(), torch::mse_loss(pred.detach(), target)})
                               .to(torch::kCPU, torch::kFloat64);  // [2]
      loss_value = scalars[0].item<double>();
      const double mse = scalars[1].item<double>();
      if (!std::isfinite(loss_value)) {
        throw std::runtime_error("training diverged: loss is " + std::to_string(loss_value) + " at step " +
                                 std::to_string(step) + "; the last good checkpoint " + ckpt + " was kept");
      }
      optimizer->zero_grad();
      block.field->table.mutable_grad() = torch::Tensor();  // the encoding's backward hands over a fresh one
      loss.backward();
      optimizer->step();
      if (table_adam) table_adam->Step(lr);
      // Keep about target_samples samples per batch.
      const double ratio = double(options.target_samples) / double(S);
      n_rays = static_cast<int>(std::clamp<double>(n_rays * ratio, 64, options.max_rays));
      bar.SetMetric("loss", loss_value);
      bar.SetMetric("psnr", -10 * std::log10(std::max(mse, 1e-10)));
    }
    ++block.step;
    bar.Tick();
    const bool last = block.step == options.iterations;
    if ((options.eval_every > 0 && block.step % options.eval_every == 0) || last) {
      psnr_test = EvaluateNerfBlock(block, dataset, last ? 0 : options.max_eval_views).psnr;
      bar.SetMetric("test_psnr", psnr_test);
      log << Json{{"step", block.step},
                  {"loss", loss_value},
                  {"test_psnr", psnr_test},
                  {"rays", n_rays},
                  {"occupied", block.grid->OccupiedFraction()},
                  {"seconds", seconds_before + timer.Seconds()}}
                 .dump()
          << "\n";
      log.flush();
    } else if (block.step % 50 == 0) {
      // Flushed: with --quiet (reg make-data) the log is the only sign of a block's progress.
      log << Json{{"step", block.step}, {"loss", loss_value}}.dump() << "\n";
      log.flush();
    }
    if ((options.checkpoint_every > 0 && block.step % options.checkpoint_every == 0) || last || block.step == end_step)
      save();
  }
  bar.Finish();
  // Resuming a finished run trains nothing; its test PSNR is measured again rather than reported
  // as the 0 of a loop that never ran.
  if (block.step == first_step && block.step == options.iterations)
    psnr_test = EvaluateNerfBlock(block, dataset, 0).psnr;
  NerfTrainResult r;
  r.psnr_test = psnr_test;
  r.seconds = seconds_before + timer.Seconds();
  r.iterations = block.step;
  r.final_loss = loss_value;
  return r;
}

}  // namespace nerfreg
