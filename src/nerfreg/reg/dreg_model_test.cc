#include "nerfreg/reg/dreg_model.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "nerfreg/reg/dreg_loss.h"
#include "nerfreg/reg/test_grids.h"
#include "nerfreg/reg/weighted_procrustes.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Small enough for a unit test on 2 cores; D = 32 grids.
DregModelOptions TinyOptions() {
  DregModelOptions o;
  o.backbone = BackboneOptions::Cpu();  // stem 8, widths {8, 16, 32}, FPN 32
  o.d_model = 32;
  o.heads = 4;
  o.layers = 2;
  o.ffn = 64;
  o.downsample.max_total_points = 400;
  o.name = "tiny";
  return o;
}

class DregModelTest : public ::testing::Test {
 protected:
  void SetUp() override {
    torch::set_num_threads(2);
    torch::manual_seed(3);
  }
};

void ExpectAllGradsFinite(torch::nn::Module& m, bool require_nonzero) {
  for (const auto& p : m.named_parameters()) {
    ASSERT_TRUE(p.value().grad().defined()) << p.key();
    EXPECT_TRUE(torch::isfinite(p.value().grad()).all().item<bool>()) << p.key();
    if (require_nonzero) EXPECT_GT(p.value().grad().abs().sum().item<double>(), 0.0) << p.key();
  }
}

TEST_F(DregModelTest, TransformerShapesGradientsAndCrossAttention) {
  CrossTransformerOptions o;
  o.d_model = 16;
  o.heads = 2;
  o.layers = 3;
  o.ffn = 32;
  CrossTransformer net(o);
  const torch::Tensor src = torch::randn({5, 16}), tgt = torch::randn({7, 16});
  const torch::Tensor src_pe = torch::randn({5, 16}), tgt_pe = torch::randn({7, 16});
  const auto out = net->forward(src, tgt, src_pe, tgt_pe);
  ASSERT_EQ(out.src.size(), 3u);
  ASSERT_EQ(out.tgt.size(), 3u);
  for (int l = 0; l < 3; ++l) {
    EXPECT_EQ(out.src[l].sizes(), torch::IntArrayRef({5, 16}));
    EXPECT_EQ(out.tgt[l].sizes(), torch::IntArrayRef({7, 16}));
  }
  (out.src.back().square().sum() + out.tgt.back().pow(3).sum() + out.src[0].sum()).backward();
  ExpectAllGradsFinite(*net, /*require_nonzero=*/true);
  // Each cloud sees the other: changing the target changes the source's output.
  torch::NoGradGuard no_grad;
  const auto out2 = net->forward(src, tgt + 0.5 * torch::randn({7, 16}), src_pe, tgt_pe);
  EXPECT_GT((out2.src[0] - out.src[0]).abs().max().item<double>(), 1e-3);
}

TEST_F(DregModelTest, DecoderIsExactWhenAttentionIsOneHot) {
  const int64_t d = 8;
  CorrespondenceDecoder dec(d);
  torch::NoGradGuard no_grad;
  // Identity projections scaled so that one-hot features give logits 0 or 9 * 100 / sqrt(8).
  dec->q_proj->weight.copy_(3.0 * torch::eye(d));
  dec->k_proj->weight.copy_(3.0 * torch::eye(d));
  dec->q_proj->bias.zero_();
  dec->k_proj->bias.zero_();
  const torch::Tensor f_other = 10.0 * torch::eye(d);
  const torch::Tensor perm = torch::tensor({3, 0, 7, 7, 1, 5}, torch::kLong);
  const torch::Tensor f = f_other.index_select(0, perm);
  const torch::Tensor xyz_other = torch::randn({d, 3});
  const torch::Tensor corr = dec->Correspond(f, torch::zeros_like(f), f_other, torch::zeros_like(f_other), xyz_other);
  ASSERT_EQ(corr.sizes(), torch::IntArrayRef({6, 3}));
  EXPECT_TRUE(torch::allclose(corr, xyz_other.index_select(0, perm), 0.0, 1e-6));
  EXPECT_EQ(dec->ConfidenceLogits(f).sizes(), torch::IntArrayRef({6}));
}

TEST_F(DregModelTest, ForwardShapesAndFiniteGradientsThroughLoss) {
  const RegGrid src = MakeShapeGrid(32, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 0, 1)).toRotationMatrix();
  const Eigen::Vector3d t(0.1, 0.0, -0.1);
  const RegGrid tgt = MakeShapeGrid(32, r, t, 2);
  const DregModelOptions o = TinyOptions();
  DregNet net(o);
  const DregOutput out = net->forward(src, tgt);
  const int64_t ks = out.src_xyz.size(0), kt = out.tgt_xyz.size(0);
  EXPECT_GT(ks, 20);
  EXPECT_GT(kt, 20);
  EXPECT_LE(ks + kt, o.downsample.max_total_points);
  ASSERT_EQ(out.num_layers(), o.layers);
  EXPECT_EQ(out.src_surface.sizes(), torch::IntArrayRef({ks}));
  EXPECT_GE(out.src_surface.min().item<float>(), 0.5f - 1e-6f);  // the mask keeps S >= 0.5
  for (int64_t l = 0; l < o.layers; ++l) {
    EXPECT_EQ(out.src_features[l].sizes(), torch::IntArrayRef({ks, o.d_model}));
    EXPECT_EQ(out.tgt_features[l].sizes(), torch::IntArrayRef({kt, o.d_model}));
    EXPECT_EQ(out.src_corr[l].sizes(), torch::IntArrayRef({ks, 3}));
    EXPECT_EQ(out.tgt_corr[l].sizes(), torch::IntArrayRef({kt, 3}));
    EXPECT_EQ(out.src_conf[l].sizes(), torch::IntArrayRef({ks}));
    EXPECT_EQ(out.tgt_conf[l].sizes(), torch::IntArrayRef({kt}));
    EXPECT_EQ(out.rotation[l].sizes(), torch::IntArrayRef({3, 3}));
    EXPECT_EQ(out.translation[l].sizes(), torch::IntArrayRef({3}));
    EXPECT_NEAR(torch::det(out.rotation[l]).item<double>(), 1.0, 1e-4);
    EXPECT_FLOAT_EQ(out.scale[l].item<float>(), 1.0f);
  }
  const DregLossTerms loss = DregLoss(out, src, tgt, RigidMatrix(r, t));
  ASSERT_TRUE(std::isfinite(loss.total.item<double>()));
  loss.total.backward();
  ExpectAllGradsFinite(*net, /*require_nonzero=*/false);
  EXPECT_GT(net->feature_w.grad().abs().sum().item<double>(), 0.0);
  EXPECT_GT(net->backbone->parameters().front().grad().abs().sum().item<double>(), 0.0);
  EXPECT_GT(net->decoder->conf_head->weight.grad().abs().sum().item<double>(), 0.0);
}

TEST_F(DregModelTest, ScoreRegistrationIsHighOnlyForConfidentAgreeingMatches) {
  const torch::Tensor x = torch::randn({200, 3}, torch::kDouble);
  const torch::Tensor rot = torch::tensor({{0.0, -1.0, 0.0}, {1.0, 0.0, 0.0}, {0.0, 0.0, 1.0}}, torch::kDouble);
  const torch::Tensor t = torch::tensor({0.2, -0.1, 0.3}, torch::kDouble);
  const torch::Tensor y = torch::matmul(x, rot.t()) + t;
  const torch::Tensor high = torch::full({200}, 0.9, torch::kDouble);
  auto solve_and_score = [&](const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& c) {
    const auto pose = WeightedProcrustes(a, b, c);
    return ScoreRegistration(a, b, c, pose.rotation, pose.translation, 1.0, 0.1);
  };
  // Overlapping blocks, right matches, confident: inliers 1, confidence = mean confidence.
  const RegistrationAgreement good = solve_and_score(x, y, high);
  EXPECT_NEAR(good.inlier_fraction, 1.0, 1e-9);
  EXPECT_NEAR(good.confidence, 0.9, 1e-9);
  // Same matches, network unsure: low.
  EXPECT_LT(solve_and_score(x, y, torch::full({200}, 0.05, torch::kDouble)).confidence, 0.06);
  // Non-overlapping blocks: the matches are unrelated points elsewhere; the best rigid fit
  // explains almost none of them.
  const RegistrationAgreement unrelated = solve_and_score(x, torch::randn({200, 3}, torch::kDouble) + 5.0, high);
  EXPECT_LT(unrelated.inlier_fraction, 0.1);
  EXPECT_LT(unrelated.confidence, 0.1);
  // Soft attention over a cloud it does not match collapses onto the other cloud's centre.
  const RegistrationAgreement collapsed =
      solve_and_score(x, torch::zeros({200, 3}, torch::kDouble) + 0.01 * torch::randn({200, 3}, torch::kDouble), high);
  EXPECT_LT(collapsed.inlier_fraction, 0.05);
  // Half right, half scattered: confidence-weighted fraction ~ 0.5 when all are equally sure,
  // ~ 0.9 when the scattered half is given 1/9 of the weight.
  torch::Tensor mixed = y.clone();
  mixed.slice(0, 100) = torch::randn({100, 3}, torch::kDouble) * 3.0;
  const auto pose = WeightedProcrustes(x.slice(0, 0, 100), y.slice(0, 0, 100), high.slice(0, 0, 100));
  EXPECT_NEAR(ScoreRegistration(x, mixed, high, pose.rotation, pose.translation, 1.0, 0.1).inlier_fraction, 0.5, 0.03);
  torch::Tensor conf = high.clone();
  conf.slice(0, 100) = 0.1;
  EXPECT_NEAR(ScoreRegistration(x, mixed, conf, pose.rotation, pose.translation, 1.0, 0.1).inlier_fraction, 0.9, 0.03);
}

TEST_F(DregModelTest, RegisterReturnsAPoseAndRefusesEmptyMasks) {
  const RegGrid src = MakeShapeGrid(32, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
  DregNet net(TinyOptions());
  const DregRegistration reg = Register(net, src, src, DregSolveOptions{});
  EXPECT_TRUE(reg.valid);
  EXPECT_TRUE(net->is_training());  // mode restored
  EXPECT_GT(reg.src_points, 0);
  EXPECT_GE(reg.confidence, 0.0);
  EXPECT_LE(reg.confidence, 1.0);
  const Eigen::Matrix3d top_left = reg.target_from_source.topLeftCorner(3, 3);
  EXPECT_NEAR(top_left.determinant(), 1.0, 1e-4);
  RegGrid empty = src;
  empty.mask = torch::zeros_like(src.mask);
  const DregRegistration none = Register(net, src, empty, DregSolveOptions{});
  EXPECT_FALSE(none.valid);
  EXPECT_EQ(none.confidence, 0.0);
}

TEST_F(DregModelTest, OptionsJsonRoundTripAndValidation) {
  const std::vector<DregModelOptions> all = {DregModelOptions::Paper(), DregModelOptions::Cpu(), TinyOptions()};
  for (const DregModelOptions& o : all) {
    const DregModelOptions back = DregModelOptions::FromJson(o.ToJson(), "opts.json");
    EXPECT_EQ(back.ToJson(), o.ToJson());
  }
  Json bad = DregModelOptions::Cpu().ToJson();
  bad["heads"] = 5;  // 64 is not divisible by 5
  EXPECT_NE(InputErrorOf([&] { DregModelOptions::FromJson(bad, "opts.json"); }).find("opts.json"), std::string::npos);
  bad.erase("d_model");
  EXPECT_NE(InputErrorOf([&] { DregModelOptions::FromJson(bad, "opts.json"); }).find("d_model"), std::string::npos);
}

TEST_F(DregModelTest, SaveLoadGivesIdenticalOutputs) {
  ScopedTempDir dir;
  const RegGrid src = MakeShapeGrid(32, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
  const RegGrid tgt = MakeShapeGrid(32, Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX()).toRotationMatrix(),
                                    Eigen::Vector3d(0.1, 0.1, 0.0), 2);
  DregNet net(TinyOptions());
  {
    torch::NoGradGuard no_grad;
    net->forward(src, tgt);  // a forward pass in training mode before saving (no state may depend on it)
  }
  const std::string path = dir.File("dreg.pt");
  SaveDregWeights(net, TinyOptions(), path);
  DregModelOptions loaded_options;
  DregNet loaded = LoadDregWeights(path, &loaded_options);
  EXPECT_EQ(loaded_options.ToJson(), TinyOptions().ToJson());
  net->eval();
  loaded->eval();
  torch::NoGradGuard no_grad;
  const DregOutput a = net->forward(src, tgt);
  const DregOutput b = loaded->forward(src, tgt);
  EXPECT_TRUE(torch::allclose(a.src_corr.back(), b.src_corr.back(), 0.0, 1e-6));
  EXPECT_TRUE(torch::allclose(a.tgt_conf.back(), b.tgt_conf.back(), 0.0, 1e-6));
  EXPECT_TRUE(torch::allclose(a.rotation.back(), b.rotation.back(), 0.0, 1e-6));
  EXPECT_TRUE(torch::equal(net->feature_w, loaded->feature_w));
}

TEST_F(DregModelTest, LoadRejectsBadFilesAndOtherConfigs) {
  ScopedTempDir dir;
  const std::string good = dir.File("good.pt");
  DregNet net(TinyOptions());
  SaveDregWeights(net, TinyOptions(), good);
  DregModelOptions o;
  // Missing.
  EXPECT_NE(InputErrorOf([&] { LoadDregWeights(dir.File("none.pt"), &o); }).find("none.pt"), std::string::npos);
  // Truncated.
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string cut = dir.File("cut.pt");
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_NE(InputErrorOf([&] { LoadDregWeights(cut, &o); }).find("cut.pt"), std::string::npos);
  // Foreign.
  const std::string text = dir.File("text.pt");
  std::ofstream(text) << "not a torch archive";
  EXPECT_NE(InputErrorOf([&] { LoadDregWeights(text, &o); }).find("text.pt"), std::string::npos);
  // Tensors that do not fit the stored options (wider model claimed).
  DregModelOptions wider = TinyOptions();
  wider.d_model = 48;
  const std::string lie = dir.File("lie.pt");
  SaveDregWeights(net, wider, lie);
  const std::string msg = InputErrorOf([&] { LoadDregWeights(lie, &o); });
  EXPECT_NE(msg.find("lie.pt"), std::string::npos);
  EXPECT_NE(msg.find("model"), std::string::npos);
  // --weights for another configuration.
  const std::string other = InputErrorOf([&] { CheckDregOptionsMatch(TinyOptions(), DregModelOptions::Cpu(), good); });
  EXPECT_NE(other.find("good.pt"), std::string::npos);
  EXPECT_NE(other.find("options.backbone"), std::string::npos);
  DregModelOptions renamed = TinyOptions();
  renamed.name = "another label";
  renamed.downsample.max_total_points = 2000;
  EXPECT_EQ(InputErrorOf([&] { CheckDregOptionsMatch(TinyOptions(), renamed, good); }), "");
}

TEST_F(DregModelTest, AverageIsTheElementwiseMeanOfWeightsOfOneArchitecture) {
  ScopedTempDir dir;
  DregNet a(TinyOptions());
  DregNet b(TinyOptions());  // another random start: most tensors differ from a's
  SaveDregWeights(a, TinyOptions(), dir.File("a.pt"));
  SaveDregWeights(b, TinyOptions(), dir.File("b.pt"));
  DregModelOptions o;
  DregNet mean = AverageDregWeights({dir.File("a.pt"), dir.File("b.pt")}, &o);
  EXPECT_EQ(o.ToJson(), TinyOptions().ToJson());
  auto pa = a->named_parameters();
  auto pb = b->named_parameters();
  int differing = 0;
  for (const auto& p : mean->named_parameters()) {
    const torch::Tensor expected = (pa[p.key()] + pb[p.key()]) / 2.0;
    EXPECT_TRUE(torch::allclose(p.value(), expected, 1e-6, 1e-6)) << p.key();
    if (!torch::equal(pa[p.key()], pb[p.key()])) ++differing;
  }
  EXPECT_GT(differing, 10);
  EXPECT_TRUE(torch::allclose(mean->feature_w, (a->feature_w + b->feature_w) / 2.0, 1e-6, 1e-6));
  // One file is itself.
  DregNet one = AverageDregWeights({dir.File("a.pt")}, &o);
  for (const auto& p : one->named_parameters()) EXPECT_TRUE(torch::equal(p.value(), pa[p.key()])) << p.key();
  // Another architecture, a missing file, no file: errors naming what is wrong.
  DregModelOptions wider = TinyOptions();
  wider.d_model = 48;
  DregNet wide(wider);
  SaveDregWeights(wide, wider, dir.File("wide.pt"));
  const std::string msg = InputErrorOf([&] { AverageDregWeights({dir.File("a.pt"), dir.File("wide.pt")}, &o); });
  EXPECT_NE(msg.find("wide.pt"), std::string::npos) << msg;
  EXPECT_NE(msg.find("d_model"), std::string::npos) << msg;
  EXPECT_NE(InputErrorOf([&] {
              AverageDregWeights({dir.File("a.pt"), dir.File("none.pt")}, &o);
            }).find("none.pt"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { AverageDregWeights({}, &o); }), "");
}

// Found by fuzz/torch_archive_fuzz.cc: weights whose meta has no "options" escaped as a JSON
// out_of_range (not an InputError), and options claiming d_model 600000 or a 60000-wide stage
// built a network of hundreds of GB before the tensors were compared.
TEST_F(DregModelTest, WeightsWithoutOptionsOrWithSizesTheFileCannotHoldAreInputErrors) {
  ScopedTempDir dir;
  DregNet net(TinyOptions());
  DregModelOptions o;
  const std::string no_options = dir.File("no_options.pt");
  torch::serialize::OutputArchive archive;
  const std::string meta = R"({"format": "nerfreg-dreg-weights", "version": 1})";
  archive.write("meta",
                torch::from_blob(const_cast<char*>(meta.data()), {int64_t(meta.size())}, torch::kUInt8).clone());
  archive.save_to(no_options);
  std::string e = InputErrorOf([&] { LoadDregWeights(no_options, &o); });
  EXPECT_EQ(e.rfind(no_options + ": options:", 0), 0u) << e;

  for (int k = 0; k < 2; ++k) {
    DregModelOptions huge = TinyOptions();
    if (k == 0) huge.d_model = 600000;
    if (k == 1) huge.backbone.stage_widths = {60000, 16, 32};
    const std::string path = dir.File("huge_" + std::to_string(k) + ".pt");
    SaveDregWeights(net, huge, path);  // the small network's tensors under the huge options
    e = InputErrorOf([&] { LoadDregWeights(path, &o); });
    EXPECT_EQ(e.rfind(path + ": options:", 0), 0u) << e;
    EXPECT_NE(e.find("parameters"), std::string::npos) << e;
  }
  // The shipped weights pass every check before torch (zip CRCs, the size bound) and load.
  EXPECT_EQ(InputErrorOf([&] { LoadDregWeights(std::string(NERFREG_SOURCE_DIR) + "/models/dreg_cpu.pt", &o); }), "");
  // The shipped CPU configuration is within the bound of its own file.
  const std::string cpu = dir.File("cpu.pt");
  DregNet cpu_net(DregModelOptions::Cpu());
  SaveDregWeights(cpu_net, DregModelOptions::Cpu(), cpu);
  EXPECT_EQ(InputErrorOf([&] { LoadDregWeights(cpu, &o); }), "");
}

DregSolveOptions Paper(double radius) {
  DregSolveOptions o;
  o.solver = "procrustes";
  o.inlier_radius = radius;
  return o;
}

DregSolveOptions Robust(double radius) {
  DregSolveOptions o;
  o.solver = "ransac";
  o.inlier_radius = radius;
  return o;
}

// The key test: the network can learn one pair. The target block is the same shape rotated by
// 75 degrees and translated; 100 AdamW steps must bring the rotation error from the untrained
// network's (> 30 deg) to < 10 deg. Measured: 50 -> ~3.5 deg (it is ~1 deg by step 40), 12 s of
// CPU time on 2 cores.
TEST_F(DregModelTest, ExtraPassesComposeTheCorrectionOnTheMovedSource) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.6, Eigen::Vector3d(0.0, 1.0, 1.0).normalized()).toRotationMatrix();
  const RegGrid src = MakeShapeGrid(32, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
  const RegGrid tgt = MakeShapeGrid(32, r, Eigen::Vector3d(0.1, 0.0, -0.1), 2);
  DregNet net(TinyOptions());
  DregSolveOptions one, two;
  two.passes = 2;
  const DregRegistration first = Register(net, src, tgt, one);
  ASSERT_TRUE(first.valid);
  // The second pass registers the source as the first pass placed it, and its correction is
  // applied after the first pose (target_from_source = target_from_moved * moved_from_source).
  const Eigen::Matrix4d& t1 = first.target_from_source;
  const RegGrid moved = TransformRegGrid(src, t1.topLeftCorner<3, 3>(), t1.topRightCorner<3, 1>());
  const DregRegistration correction = Register(net, moved, tgt, one);
  const DregRegistration both = Register(net, src, tgt, two);
  ASSERT_TRUE(both.valid);
  EXPECT_LT((both.target_from_source - correction.target_from_source * t1).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT((both.target_from_source - t1).cwiseAbs().maxCoeff(), 1e-4);  // the second pass did move it
  EXPECT_DOUBLE_EQ(both.confidence, correction.confidence);
  two.passes = 0;
  EXPECT_THROW(Register(net, src, tgt, two), InputError);
  two.passes = 11;
  EXPECT_THROW(Register(net, src, tgt, two), InputError);
}

TEST_F(DregModelTest, OverfitsOnePairAndRecoversTheRotation) {
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(75.0 * M_PI / 180.0, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.15, -0.1, 0.1);
  const RegGrid src = MakeShapeGrid(32, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 1);
  const RegGrid tgt = MakeShapeGrid(32, r, t, 2);
  const torch::Tensor gt = RigidMatrix(r, t);
  const torch::Tensor gt_rot = gt.slice(0, 0, 3).slice(1, 0, 3);
  DregModelOptions o = TinyOptions();
  o.downsample.max_total_points = 300;
  DregNet net(o);
  const double initial_deg = RotationErrorDeg(
      torch::from_blob(Register(net, src, tgt, Paper(0.1)).target_from_source.data(), {4, 4}, torch::kDouble)
          .t()
          .slice(0, 0, 3)
          .slice(1, 0, 3),
      gt_rot);
  torch::optim::AdamW opt(net->parameters(), torch::optim::AdamWOptions(1e-3).weight_decay(1e-4));
  const auto start = std::chrono::steady_clock::now();
  const int steps = 100;
  double first_loss = 0, last_loss = 0;
  for (int step = 0; step < steps; ++step) {
    const DregOutput out = net->forward(src, tgt);
    const DregLossTerms loss = DregLoss(out, src, tgt, gt);
    opt.zero_grad();
    loss.total.backward();
    torch::nn::utils::clip_grad_norm_(net->parameters(), 1.0);
    opt.step();
    if (step == 0) first_loss = loss.total.item<double>();
    last_loss = loss.total.item<double>();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const DregRegistration reg = Register(net, src, tgt, Paper(0.15));
  const DregRegistration robust = Register(net, src, tgt, Robust(0.15));
  const torch::Tensor m =
      torch::from_blob(const_cast<double*>(reg.target_from_source.data()), {4, 4}, torch::kDouble).t();
  const double final_deg = RotationErrorDeg(m.slice(0, 0, 3).slice(1, 0, 3), gt_rot);
  const double trans_err =
      (m.slice(0, 0, 3).select(1, 3) - gt.slice(0, 0, 3).select(1, 3).to(torch::kDouble)).norm().item<double>();
  std::printf(
      "[overfit] %d steps in %.1f s; loss %.3f -> %.3f; rotation error %.1f -> %.1f deg; translation error %.3f; "
      "confidence %.3f (inliers %.2f)\n",
      steps, seconds, first_loss, last_loss, initial_deg, final_deg, trans_err, reg.confidence, reg.inlier_fraction);
  // Blocks that see disjoint halves of the shape (source x > 0.25, target x < -0.25 in the shape
  // frame): no overlap, so the registration confidence must drop.
  RegGrid src_half = src, tgt_half = tgt;
  src_half.mask = src.mask & (src.xyz.select(3, 0) > 0.25);
  const torch::Tensor rt = torch::from_blob(const_cast<double*>(r.data()), {3, 3}, torch::kDouble).to(torch::kFloat);
  // Column-major Eigen data read row-major is R^T: x_shape = R^T (p - t) = (p - t) @ R.
  const torch::Tensor tgt_in_shape = torch::matmul(tgt.xyz.view({-1, 3}) - gt.slice(0, 0, 3).select(1, 3), rt.t());
  tgt_half.mask = tgt.mask & (tgt_in_shape.select(1, 0) < -0.25).view_as(tgt.mask);
  const DregRegistration disjoint = Register(net, src_half, tgt_half, Paper(0.15));
  const DregRegistration disjoint_robust = Register(net, src_half, tgt_half, Robust(0.15));
  std::printf("[overfit] disjoint halves: confidence %.3f (inliers %.2f, mean confidence %.2f)\n", disjoint.confidence,
              disjoint.inlier_fraction, disjoint.mean_confidence);
  EXPECT_GT(initial_deg, 30.0);
  EXPECT_LT(final_deg, 10.0);
  EXPECT_LT(disjoint.confidence, 0.7 * reg.confidence);  // measured 0.13 vs 0.30 (LibTorch 1.13), 0.16 vs 0.27 (2.11)
  // RANSAC over the same correspondences: at least as accurate here (measured 1.6 vs 3.6 deg), and
  // less confident without overlap, though by less: it finds the pose most wrong matches agree on
  // (measured 0.20 vs 0.30 with LibTorch 1.13, 0.22 vs 0.27 with 2.11, whose arithmetic differs).
  const double robust_deg =
      RotationErrorDeg(torch::from_blob(const_cast<double*>(robust.target_from_source.data()), {4, 4}, torch::kDouble)
                           .t()
                           .slice(0, 0, 3)
                           .slice(1, 0, 3),
                       gt_rot);
  std::printf("[overfit] ransac: rotation error %.2f deg, confidence %.3f; disjoint halves %.3f\n", robust_deg,
              robust.confidence, disjoint_robust.confidence);
  EXPECT_LT(robust_deg, 10.0);
  EXPECT_LT(disjoint_robust.confidence, 0.9 * robust.confidence);
  EXPECT_LT(last_loss, 0.5 * first_loss);
}

}  // namespace
}  // namespace nerfreg
