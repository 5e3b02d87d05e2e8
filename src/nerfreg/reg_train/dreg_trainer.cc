#include "nerfreg/reg_train/dreg_trainer.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/registration_success.h"
#include "nerfreg/reg_train/pairs.h"
#include "nerfreg/util/torch_device.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/util/torch_archive.h"
#include "nerfreg/util/training_log.h"

namespace nerfreg {

void DregTrainOptions::Check() const {
  if (config != "cpu" && config != "paper") ThrowInputError("--config", "", "cpu or paper");
  if (iterations < 1) ThrowInputError("--iters", "", ">= 1");
  if (batch < 0 || batch > 4096) ThrowInputError("--batch", "", "pairs per step in [1, 4096] (0: one per process)");
  if (!(lr > 0) || weight_decay < 0 || lr_step < 1 || !(lr_gamma > 0) || !(grad_clip > 0)) {
    ThrowInputError("reg train", "optimizer options", "lr > 0, weight decay >= 0, lr step >= 1, gamma > 0, clip > 0");
  }
  if (jitter < 0 || move_probability < 0 || move_probability > 1 || move_deg < 0 || move_translation < 0) {
    ThrowInputError("reg train", "augmentation options", "non-negative sizes, a probability in [0, 1]");
  }
  if (move_deg > 180) ThrowInputError("--move-deg", "", "an angle in [0, 180] degrees");
  if (!(mirror_probability >= 0 && mirror_probability <= 1)) ThrowInputError("--mirror", "", "a probability in [0, 1]");
  if (!(colour_probability >= 0 && colour_probability <= 1))
    ThrowInputError("--recolour", "", "a probability in [0, 1]");
  if (val_every < 0 || checkpoint_every < 0 || max_val_pairs < 0 || nerf_fraction < 0 || nerf_fraction > 1) {
    ThrowInputError("reg train", "schedule options", "non-negative counts, --nerf-fraction in [0, 1]");
  }
}

Json DregTrainOptions::ToJson() const {
  return {{"config", config},
          {"iterations", iterations},
          {"batch", batch},
          {"lr", lr},
          {"weight_decay", weight_decay},
          {"lr_step", lr_step},
          {"lr_gamma", lr_gamma},
          {"grad_clip", grad_clip},
          {"jitter", jitter},
          {"move_probability", move_probability},
          {"move_deg", move_deg},
          {"move_translation", move_translation},
          {"swap", swap},
          {"mirror_probability", mirror_probability},
          {"colour_probability", colour_probability},
          {"nerf_fraction", nerf_fraction},
          {"seed", seed},
          {"init_weights", init_weights},
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

}  // namespace

DregValResult EvaluateDreg(DregNet& net, const std::vector<PairRecord>& val, double inlier_radius, DistGroup& group) {
  DregValResult r;
  const std::int64_t n = static_cast<std::int64_t>(val.size());
  std::vector<torch::Tensor> errors = {torch::zeros({2, n}, torch::kFloat64)};  // [2, V] rotation deg, translation
  for (std::int64_t k = group.rank(); k < n; k += group.world_size()) {
    const PairRecord& p = val[k];
    const LoadedPair lp = Load(p);
    DregSolveOptions solve;
    solve.inlier_radius = inlier_radius;
    const DregRegistration reg = Register(net, lp.source, lp.target, solve);
    const Sim3d est = Sim3d::FromMatrix(reg.target_from_source, 1e-3);
    const Sim3d gt = Sim3d::FromMatrix(p.target_from_source, 1e-3);
    errors[0][0][k] = RotationErrorDeg(est.rotation, gt.rotation);
    errors[0][1][k] = TranslationError(est.translation, gt.translation);
  }
  group.AllReduceSum(errors);
  std::vector<double> rot, trans;
  int success = 0;
  for (std::int64_t k = 0; k < n; ++k) {
    rot.push_back(errors[0][0][k].item<double>());
    trans.push_back(errors[0][1][k].item<double>());
    success += RegistrationSucceeded(rot.back(), trans.back());
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

Json DregValResult::ToJson() const {
  return {{"median_rotation_deg", median_rotation_deg},
          {"mean_rotation_deg", mean_rotation_deg},
          {"median_translation", median_translation},
          {"success_rate", success_rate},
          {"pairs", pairs}};
}

namespace {

// One training pair's random choices, drawn by every rank for every pair of the global batch (so
// the stream stays in step across ranks) and applied only by the rank that trains on the pair.
struct PairDraw {
  const PairRecord* record = nullptr;
  bool swap = false;
  bool move = false;
  Eigen::Matrix3d move_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d move_translation = Eigen::Vector3d::Zero();
  bool mirror = false, recolour = false;
  std::array<std::int64_t, 3> perm = {0, 1, 2};
  std::array<double, 3> gain = {1, 1, 1};
  std::uint64_t jitter_seed = 0;  // the pair's own torch generator: the noise does not depend on the rank
};

PairDraw DrawPair(const DregTrainOptions& options, const std::vector<PairRecord>& train,
                  const std::vector<PairRecord>& train_nerf, const std::vector<PairRecord>& train_mesh,
                  std::mt19937& rng, std::normal_distribution<double>& normal) {
  std::uniform_real_distribution<double> uni(0, 1);
  PairDraw d;
  // A pair: real-NeRF pairs with probability nerf_fraction (when set and present), else any.
  const bool pick_nerf = options.nerf_fraction > 0 && !train_nerf.empty() && uni(rng) < options.nerf_fraction;
  const auto& pool = pick_nerf ? train_nerf : (options.nerf_fraction > 0 && !train_mesh.empty() ? train_mesh : train);
  d.record = &pool[std::uniform_int_distribution<size_t>(0, pool.size() - 1)(rng)];
  d.swap = options.swap && uni(rng) < 0.5;
  d.move = uni(rng) < options.move_probability;
  if (d.move) {
    const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const double angle = options.move_deg * M_PI / 180 * uni(rng);
    d.move_rotation = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    d.move_translation =
        options.move_translation * Eigen::Vector3d(2 * uni(rng) - 1, 2 * uni(rng) - 1, 2 * uni(rng) - 1);
  }
  d.mirror = uni(rng) < options.mirror_probability;
  d.recolour = uni(rng) < options.colour_probability;
  if (d.recolour) {
    std::shuffle(d.perm.begin(), d.perm.end(), rng);
    d.gain = {0.7 + 0.6 * uni(rng), 0.7 + 0.6 * uni(rng), 0.7 + 0.6 * uni(rng)};
  }
  d.jitter_seed = (static_cast<std::uint64_t>(rng()) << 32) | rng();
  return d;
}

LoadedPair ApplyDraw(const PairDraw& d, double jitter) {
  LoadedPair p = Load(*d.record);
  if (d.swap) {
    std::swap(p.source, p.target);
    p.target_from_source = Eigen::Matrix4d(p.target_from_source.inverse());
  }
  if (d.move) {
    // Rotate about the grid's centre so the object stays inside the box.
    const Eigen::Matrix3d& R = d.move_rotation;
    const Eigen::Vector3d c = 0.5 * (p.source.aabb_min + p.source.aabb_max);
    const Eigen::Vector3d tt = c - R * c + d.move_translation;
    p.source = TransformRegGrid(p.source, R, tt);
    Eigen::Matrix4d moved_from_source = Eigen::Matrix4d::Identity();
    moved_from_source.topLeftCorner<3, 3>() = R;
    moved_from_source.topRightCorner<3, 1>() = tt;
    p.target_from_source = p.target_from_source * moved_from_source.inverse();
  }
  if (d.mirror) MirrorRegGridPair(&p.source, &p.target, &p.target_from_source);
  if (d.recolour) {
    p.source = RecolourRegGrid(p.source, d.perm, d.gain);
    p.target = RecolourRegGrid(p.target, d.perm, d.gain);
  }
  if (jitter > 0) {
    torch::Generator gen = at::detail::createCPUGenerator(d.jitter_seed);
    p.source.xyz = p.source.xyz + jitter * torch::randn(p.source.xyz.sizes(), gen);
    p.target.xyz = p.target.xyz + jitter * torch::randn(p.target.xyz.sizes(), gen);
  }
  return p;
}

}  // namespace

DregTrainResult TrainDreg(const std::vector<std::string>& pairs_files, const DregTrainOptions& options,
                          const std::string& out, bool resume, DistGroup* group_in) {
  options.Check();
  DistGroup single;
  DistGroup& group = group_in != nullptr ? *group_in : single;
  const int world = group.world_size(), rank = group.rank();
  const int batch = options.batch > 0 ? options.batch : world;
  if (batch < world) {
    ThrowInputError("--batch", "", "at least one pair per process (>= " + std::to_string(world) + ")");
  }
  std::vector<PairRecord> train, val, train_nerf, train_mesh;
  for (const auto& f : pairs_files) {
    // Test pairs (held-out meshes, e.g. the furniture's test split) are neither trained nor validated on.
    for (const auto& p : ReadPairs(f)) {
      if (p.split == "val") val.push_back(p);
      if (p.split == "train") train.push_back(p);
    }
  }
  if (train.empty()) ThrowInputError(pairs_files.front(), "pairs", "at least one pair with \"split\": \"train\"");
  for (const auto& p : train) (p.kind == "nerf" ? train_nerf : train_mesh).push_back(p);
  if (static_cast<int>(val.size()) > options.max_val_pairs) {
    std::vector<PairRecord> pick;
    for (int k = 0; k < options.max_val_pairs; ++k) pick.push_back(val[k * val.size() / options.max_val_pairs]);
    val = pick;
  }
  LOG_INFO("reg train: {} training pairs ({} from real NeRF blocks), {} validation pairs, {} per step{}", train.size(),
           train_nerf.size(), val.size(), batch, world > 1 ? " over " + std::to_string(world) + " processes" : "");

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
    return std::make_unique<torch::optim::AdamW>(
        net->parameters(), torch::optim::AdamWOptions(options.lr).weight_decay(options.weight_decay));
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
  // Every rank starts from rank 0's weights (the same seed made them equal already; this makes it
  // so whatever the ranks read).
  {
    std::vector<torch::Tensor> state = net->parameters();
    for (const auto& b : net->buffers()) state.push_back(b);
    BroadcastParameters(group, state);
  }
  auto save = [&] {
    if (!group.is_main()) return;
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
    ar.write(
        "rng",
        torch::from_blob(const_cast<char*>(s.data()), {static_cast<std::int64_t>(s.size())}, torch::kUInt8).clone());
    SaveArchiveAtomic(ar, state_path);
    SaveDregWeights(net, model_options, out);
  };

  std::ofstream log;
  if (group.is_main()) {
    if (resume) RewindTrainingLog(out + ".log.jsonl", step);
    log.open(out + ".log.jsonl", resume ? std::ios::app : std::ios::trunc);
  }
  const int end_step = options.stop_after > 0 ? std::min(options.stop_after, options.iterations) : options.iterations;
  const int first_step = step;
  int trained_steps = 0;  // steps of this call that trained on at least one pair
  ProgressBar bar("reg train", options.iterations, "it");
  bar.Resume(step);
  std::normal_distribution<double> normal(0, 1);
  DregTrainResult result;
  double loss_ema = 0;
  net->train();
  const std::vector<torch::Tensor> parameters = net->parameters();
  for (; step < end_step;) {
    const double lr = options.lr * std::pow(options.lr_gamma, step / options.lr_step);
    for (auto& g : optimizer->param_groups()) static_cast<torch::optim::AdamWOptions&>(g.options()).lr(lr);
    std::vector<PairDraw> draws;
    for (int b = 0; b < batch; ++b) draws.push_back(DrawPair(options, train, train_nerf, train_mesh, rng, normal));
    // This rank's pairs: b = rank, rank + world, ... Their gradients accumulate; `stats` sums the
    // loss terms and counts the pairs trained on (a pair with too few surface voxels is skipped).
    optimizer->zero_grad();
    torch::Tensor stats =
        torch::zeros({6}, torch::kFloat64);  // [6] loss, pairs, confidence, correspondence, surface, feature
    for (int b = rank; b < batch; b += world) {
      LoadedPair p = ApplyDraw(draws[b], options.jitter);
      if (p.source.mask.sum().item<std::int64_t>() < 8 || p.target.mask.sum().item<std::int64_t>() < 8) continue;
      const DregOutput o = net->forward(p.source, p.target);
      const DregLossTerms terms = DregLoss(o, p.source, p.target, ToTensor(p.target_from_source), options.loss);
      terms.total.backward();
      const double values[6] = {terms.total.item<double>(),      1,
                                terms.confidence.item<double>(), terms.correspondence.item<double>(),
                                terms.surface.item<double>(),    terms.feature.item<double>()};
      for (int k = 0; k < 6; ++k) stats[k] += values[k];
    }
    AllReduceGradients(group, parameters, &stats);
    const double pairs = stats[1].item<double>();
    std::string names = draws[0].record->name;
    for (int b = 1; b < batch; ++b) names += "," + draws[b].record->name;
    if (pairs == 0) {
      ++step;
      bar.Tick();
      // A skipped last step still writes what the trained ones learnt.
      if (trained_steps > 0 && (step == options.iterations || step == end_step)) save();
      continue;
    }
    ++trained_steps;
    const double loss = stats[0].item<double>() / pairs;
    if (!std::isfinite(loss)) {
      throw std::runtime_error("reg train diverged: loss is " + std::to_string(loss) + " at step " +
                               std::to_string(step) + " (pairs " + names + "); the last good checkpoint " + state_path +
                               " was kept");
    }
    // The mean over the batch's pairs, as one process with the whole batch computes it.
    for (const auto& param : parameters) {
      if (param.grad().defined()) param.mutable_grad().div_(pairs);
    }
    torch::nn::utils::clip_grad_norm_(net->parameters(), options.grad_clip);
    optimizer->step();
    loss_ema = step == 0 || loss_ema == 0 ? loss : 0.98 * loss_ema + 0.02 * loss;
    result.final_loss = loss;
    ++step;
    bar.SetMetric("loss", loss_ema);
    bar.Tick();
    Json line = {{"step", step},
                 {"loss", loss},
                 {"lr", lr},
                 {"pair", names},
                 {"confidence", stats[2].item<double>() / pairs},
                 {"correspondence", stats[3].item<double>() / pairs},
                 {"surface", stats[4].item<double>() / pairs},
                 {"feature", stats[5].item<double>() / pairs},
                 {"seconds", seconds_before + timer.Seconds()}};
    const bool last = step == options.iterations;
    if (!val.empty() && ((options.val_every > 0 && step % options.val_every == 0) || last)) {
      net->eval();
      result.val = EvaluateDreg(net, val, options.inlier_radius, group);
      net->train();
      line["val"] = result.val.ToJson();
      bar.SetMetric("val_med_deg", result.val.median_rotation_deg);
      LOG_INFO("step {}: validation median rotation error {:.2f} deg, success {:.0f} % ({} pairs)", step,
               result.val.median_rotation_deg, 100 * result.val.success_rate, result.val.pairs);
    }
    if (group.is_main()) {
      log << line.dump() << "\n";
      log.flush();
    }
    if ((options.checkpoint_every > 0 && step % options.checkpoint_every == 0) || last || step == end_step) save();
  }
  bar.Finish();
  // Every pair drawn had too few surface voxels: no weights to write, and none are claimed.
  if (trained_steps == 0 && first_step < end_step) {
    if (group.is_main() && !resume) {
      log.close();
      std::error_code ignored;
      std::filesystem::remove(out + ".log.jsonl", ignored);
    }
    ThrowInputError(pairs_files.front(), "pairs",
                    "pairs whose grids both have at least 8 surface voxels (every pair drawn had fewer: nothing was "
                    "trained or written)");
  }
  if (step == end_step && options.checkpoint_every == 0) save();
  result.iterations = step;
  result.seconds = seconds_before + timer.Seconds();
  Json summary = {{"options", options.ToJson()},     {"processes", world},
                  {"model", model_options.ToJson()}, {"data", pairs_files},
                  {"train_pairs", train.size()},     {"train_pairs_nerf", train_nerf.size()},
                  {"val", result.val.ToJson()},      {"iterations", step},
                  {"seconds", result.seconds},       {"final_loss", result.final_loss}};
  if (group.is_main()) WriteJsonFile(out + ".json", summary);
  return result;
}

}  // namespace nerfreg
