#include "nerfreg/reg/dreg_trainer.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <random>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/training_data.h"
#include "nerfreg/util/torch_device.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {

void DregTrainOptions::Check() const {
  if (config != "cpu" && config != "paper") ThrowInputError("--config", "", "cpu or paper");
  if (iterations < 1) ThrowInputError("--iters", "", ">= 1");
  if (!(lr > 0) || weight_decay < 0 || lr_step < 1 || !(lr_gamma > 0) || !(grad_clip > 0)) {
    ThrowInputError("reg train", "optimizer options", "lr > 0, weight decay >= 0, lr step >= 1, gamma > 0, clip > 0");
  }
  if (jitter < 0 || move_probability < 0 || move_probability > 1 || move_deg < 0 || move_translation < 0) {
    ThrowInputError("reg train", "augmentation options", "non-negative sizes, a probability in [0, 1]");
  }
  if (move_deg > 180) ThrowInputError("--move-deg", "", "an angle in [0, 180] degrees");
  if (!(mirror_probability >= 0 && mirror_probability <= 1)) ThrowInputError("--mirror", "", "a probability in [0, 1]");
  if (!(colour_probability >= 0 && colour_probability <= 1)) ThrowInputError("--recolour", "", "a probability in [0, 1]");
  if (val_every < 0 || checkpoint_every < 0 || max_val_pairs < 0 || nerf_fraction < 0 || nerf_fraction > 1) {
    ThrowInputError("reg train", "schedule options", "non-negative counts, --nerf-fraction in [0, 1]");
  }
}

Json DregTrainOptions::ToJson() const {
  return {{"config", config}, {"iterations", iterations}, {"lr", lr}, {"weight_decay", weight_decay},
          {"lr_step", lr_step}, {"lr_gamma", lr_gamma}, {"grad_clip", grad_clip}, {"jitter", jitter},
          {"move_probability", move_probability}, {"move_deg", move_deg}, {"move_translation", move_translation},
          {"swap", swap}, {"mirror_probability", mirror_probability}, {"colour_probability", colour_probability},
          {"nerf_fraction", nerf_fraction}, {"seed", seed}, {"init_weights", init_weights},
          {"overlap_labels", loss.overlap_labels}};
}

namespace {

struct LoadedPair {
  RegGrid source, target;
  Eigen::Matrix4d target_from_source;
};

LoadedPair Load(const PairRecord& p) { return {LoadRegGrid(p.source), LoadRegGrid(p.target), p.target_from_source}; }

torch::Tensor ToTensor(const Eigen::Matrix4d& m) {
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> r = m;
  return torch::from_blob(r.data(), {4, 4}, torch::kFloat64).to(torch::kFloat32).clone();
}

DregValResult Validate(DregNet& net, const std::vector<PairRecord>& val, double inlier_radius) {
  DregValResult r;
  std::vector<double> rot, trans;
  int success = 0;
  for (const auto& p : val) {
    const LoadedPair lp = Load(p);
    DregSolveOptions solve;
    solve.inlier_radius = inlier_radius;
    const DregRegistration reg = Register(net, lp.source, lp.target, solve);
    const Sim3d est = Sim3d::FromMatrix(reg.target_from_source, 1e-3);
    const Sim3d gt = Sim3d::FromMatrix(p.target_from_source, 1e-3);
    rot.push_back(RotationErrorDeg(est.rotation, gt.rotation));
    trans.push_back(TranslationError(est.translation, gt.translation));
    success += rot.back() <= 5 && trans.back() / 2.5 <= 0.05;
  }
  if (rot.empty()) return r;
  r.pairs = static_cast<int>(rot.size());
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  r.median_rotation_deg = median(rot);
  r.median_translation = median(trans);
  for (double x : rot) r.mean_rotation_deg += x / rot.size();
  r.success_rate = double(success) / rot.size();
  return r;
}

Json ValJson(const DregValResult& v) {
  return {{"median_rotation_deg", v.median_rotation_deg}, {"mean_rotation_deg", v.mean_rotation_deg},
          {"median_translation", v.median_translation}, {"success_rate", v.success_rate}, {"pairs", v.pairs}};
}

}  // namespace

DregTrainResult TrainDreg(const std::vector<std::string>& pairs_files, const DregTrainOptions& options,
                          const std::string& out, bool resume) {
  options.Check();
  std::vector<PairRecord> train, val, train_nerf, train_mesh;
  for (const auto& f : pairs_files) {
    for (const auto& p : ReadPairs(f)) (p.split == "val" ? val : train).push_back(p);
  }
  if (train.empty()) ThrowInputError(pairs_files.front(), "pairs", "at least one pair with \"split\": \"train\"");
  for (const auto& p : train) (p.kind == "nerf" ? train_nerf : train_mesh).push_back(p);
  if (static_cast<int>(val.size()) > options.max_val_pairs) {
    std::vector<PairRecord> pick;
    for (int k = 0; k < options.max_val_pairs; ++k) pick.push_back(val[k * val.size() / options.max_val_pairs]);
    val = pick;
  }
  LOG_INFO("reg train: {} training pairs ({} from real NeRF blocks), {} validation pairs", train.size(), train_nerf.size(),
           val.size());

  Timer timer;
  const std::string state_path = out + ".train";
  DregModelOptions model_options = options.config == "paper" ? DregModelOptions::Paper() : DregModelOptions::Cpu();
  torch::manual_seed(options.seed);
  DregNet net(model_options);
  if (!options.init_weights.empty()) {
    // The run keeps the init file's options (its point budget and scale solve too), also when
    // resumed: the weights it writes must say what they are.
    DregModelOptions stored;
    DregNet init = LoadDregWeights(options.init_weights, &stored);
    CheckDregOptionsMatch(stored, model_options, options.init_weights);
    model_options = stored;
    net = init;  // replaced by the state's weights below when resuming
    if (!resume) LOG_INFO("reg train: starting from the weights {}", options.init_weights);
  }
  int step = 0;
  double seconds_before = 0;
  std::mt19937 rng(options.seed);
  auto make_optimizer = [&] {
    return std::make_unique<torch::optim::AdamW>(net->parameters(),
                                                 torch::optim::AdamWOptions(options.lr).weight_decay(options.weight_decay));
  };
  net->to(options.device);
  auto optimizer = make_optimizer();
  if (resume) {
    if (!FileExists(state_path)) ThrowInputError(state_path, "", "a training state to resume (written by reg train)");
    try {
      torch::serialize::InputArchive ar;
      ar.load_from(state_path, torch::Device(torch::kCPU));  // written on any device, read on the CPU
      torch::serialize::InputArchive model_ar, opt_ar;
      ar.read("model", model_ar);
      net->load(model_ar);
      net->to(options.device);  // the state was read on the CPU
      ar.read("optimizer", opt_ar);
      optimizer->load(opt_ar);
      MoveOptimizerState(*optimizer, options.device);
      torch::Tensor step_t, seconds_t, rng_t, config_t;
      ar.read("step", step_t);
      ar.read("seconds", seconds_t);
      ar.read("rng", rng_t);
      step = static_cast<int>(step_t.item<std::int64_t>());
      seconds_before = seconds_t.item<double>();
      const auto c = rng_t.contiguous();
      std::stringstream ss(std::string(reinterpret_cast<const char*>(c.data_ptr<std::uint8_t>()), c.numel()));
      ss >> rng;
    } catch (const std::exception& e) {
      ThrowInputError(state_path, "", std::string("a complete reg train state (") + e.what() + ")");
    }
    LOG_INFO("resuming {} at step {}", state_path, step);
  }
  auto save = [&] {
    torch::serialize::OutputArchive ar, model_ar, opt_ar;
    net->save(model_ar);
    ar.write("model", model_ar);
    optimizer->save(opt_ar);
    ar.write("optimizer", opt_ar);
    ar.write("step", torch::tensor(static_cast<std::int64_t>(step)));
    ar.write("seconds", torch::tensor(seconds_before + timer.Seconds(), torch::kFloat64));
    std::stringstream ss;
    ss << rng;
    const std::string s = ss.str();
    ar.write("rng", torch::from_blob(const_cast<char*>(s.data()), {static_cast<std::int64_t>(s.size())}, torch::kUInt8).clone());
    SaveArchiveAtomic(ar, state_path);
    SaveDregWeights(net, model_options, out);
  };

  std::ofstream log(out + ".log.jsonl", resume ? std::ios::app : std::ios::trunc);
  const int end_step = options.stop_after > 0 ? std::min(options.stop_after, options.iterations) : options.iterations;
  ProgressBar bar("reg train", options.iterations, "it");
  bar.Tick(step);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<double> normal(0, 1);
  DregTrainResult result;
  double loss_ema = 0;
  net->train();
  for (; step < end_step;) {
    const double lr = options.lr * std::pow(options.lr_gamma, step / options.lr_step);
    for (auto& g : optimizer->param_groups()) static_cast<torch::optim::AdamWOptions&>(g.options()).lr(lr);
    // A pair: real-NeRF pairs with probability nerf_fraction (when set and present), else any.
    const bool pick_nerf = options.nerf_fraction > 0 && !train_nerf.empty() && uni(rng) < options.nerf_fraction;
    const auto& pool = pick_nerf ? train_nerf : (options.nerf_fraction > 0 && !train_mesh.empty() ? train_mesh : train);
    const PairRecord& rec = pool[std::uniform_int_distribution<size_t>(0, pool.size() - 1)(rng)];
    LoadedPair p = Load(rec);
    // Augmentation.
    if (options.swap && uni(rng) < 0.5) {
      std::swap(p.source, p.target);
      p.target_from_source = Eigen::Matrix4d(p.target_from_source.inverse());
    }
    if (uni(rng) < options.move_probability) {
      const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
      const double angle = options.move_deg * M_PI / 180 * uni(rng);
      const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      const Eigen::Vector3d t = options.move_translation * Eigen::Vector3d(2 * uni(rng) - 1, 2 * uni(rng) - 1, 2 * uni(rng) - 1);
      // Rotate about the grid's centre so the object stays inside the box.
      const Eigen::Vector3d c = 0.5 * (p.source.aabb_min + p.source.aabb_max);
      const Eigen::Vector3d tt = c - R * c + t;
      p.source = TransformRegGrid(p.source, R, tt);
      Eigen::Matrix4d moved_from_source = Eigen::Matrix4d::Identity();
      moved_from_source.topLeftCorner<3, 3>() = R;
      moved_from_source.topRightCorner<3, 1>() = tt;
      p.target_from_source = p.target_from_source * moved_from_source.inverse();
    }
    if (uni(rng) < options.mirror_probability) MirrorRegGridPair(&p.source, &p.target, &p.target_from_source);
    if (uni(rng) < options.colour_probability) {
      std::array<std::int64_t, 3> perm = {0, 1, 2};
      std::shuffle(perm.begin(), perm.end(), rng);
      const std::array<double, 3> gain = {0.7 + 0.6 * uni(rng), 0.7 + 0.6 * uni(rng), 0.7 + 0.6 * uni(rng)};
      p.source = RecolourRegGrid(p.source, perm, gain);
      p.target = RecolourRegGrid(p.target, perm, gain);
    }
    if (options.jitter > 0) {
      p.source.xyz = p.source.xyz + options.jitter * torch::randn(p.source.xyz.sizes());
      p.target.xyz = p.target.xyz + options.jitter * torch::randn(p.target.xyz.sizes());
    }
    if (p.source.mask.sum().item<std::int64_t>() < 8 || p.target.mask.sum().item<std::int64_t>() < 8) {
      ++step;
      bar.Tick();
      continue;
    }
    const DregOutput o = net->forward(p.source, p.target);
    const DregLossTerms terms = DregLoss(o, p.source, p.target, ToTensor(p.target_from_source), options.loss);
    const double loss = terms.total.item<double>();
    if (!std::isfinite(loss)) {
      throw std::runtime_error("reg train diverged: loss is " + std::to_string(loss) + " at step " + std::to_string(step) +
                               " (pair " + rec.name + "); the last good checkpoint " + state_path + " was kept");
    }
    optimizer->zero_grad();
    terms.total.backward();
    torch::nn::utils::clip_grad_norm_(net->parameters(), options.grad_clip);
    optimizer->step();
    loss_ema = step == 0 || loss_ema == 0 ? loss : 0.98 * loss_ema + 0.02 * loss;
    result.final_loss = loss;
    ++step;
    bar.SetMetric("loss", loss_ema);
    bar.Tick();
    Json line = {{"step", step}, {"loss", loss}, {"lr", lr}, {"pair", rec.name},
                 {"confidence", terms.confidence.item<double>()}, {"correspondence", terms.correspondence.item<double>()},
                 {"surface", terms.surface.item<double>()}, {"feature", terms.feature.item<double>()},
                 {"seconds", seconds_before + timer.Seconds()}};
    const bool last = step == options.iterations;
    if (!val.empty() && ((options.val_every > 0 && step % options.val_every == 0) || last)) {
      net->eval();
      result.val = Validate(net, val, options.inlier_radius);
      net->train();
      line["val"] = ValJson(result.val);
      bar.SetMetric("val_med_deg", result.val.median_rotation_deg);
      LOG_INFO("step {}: validation median rotation error {:.2f} deg, success {:.0f} % ({} pairs)", step,
               result.val.median_rotation_deg, 100 * result.val.success_rate, result.val.pairs);
    }
    log << line.dump() << "\n";
    log.flush();
    if ((options.checkpoint_every > 0 && step % options.checkpoint_every == 0) || last || step == end_step) save();
  }
  bar.Finish();
  if (step == end_step && options.checkpoint_every == 0) save();
  result.iterations = step;
  result.seconds = seconds_before + timer.Seconds();
  Json summary = {{"options", options.ToJson()}, {"model", model_options.ToJson()}, {"data", pairs_files},
                  {"train_pairs", train.size()}, {"train_pairs_nerf", train_nerf.size()}, {"val", ValJson(result.val)},
                  {"iterations", step}, {"seconds", result.seconds}, {"final_loss", result.final_loss}};
  WriteJsonFile(out + ".json", summary);
  return result;
}

}  // namespace nerfreg
