// Commands of the registration layer: reg register | reg eval.
#include <cmath>

#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/reg/baselines.h"
#include "nerfreg/render/point_splat.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

using namespace nerfreg;

namespace {

Eigen::Matrix3Xd ToEigen(const torch::Tensor& xyz) {
  const auto c = xyz.to(torch::kFloat64).contiguous();
  Eigen::Matrix3Xd m(3, c.size(0));
  std::memcpy(m.data(), c.data_ptr<double>(), sizeof(double) * 3 * c.size(0));
  return m;
}

Eigen::Matrix3Xd Transform(const Rigid3d& t, const Eigen::Matrix3Xd& p) {
  return (t.RotationMatrix() * p).colwise() + t.translation;
}

}  // namespace

int RunRegRegister(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Register two NeRF blocks from their fields alone: target_from_source maps points of the source "
                  "block's frame into the target's. Methods: ransac (FPFH + RANSAC), fgr (FPFH + fast global "
                  "registration), each with optional ICP refinement; dreg (the learned DReg-NeRF network) needs "
                  "trained weights. Writes T.json and before/after overlay pictures beside it.",
                  "nerfreg reg register runs/block_0.ckpt runs/block_1.ckpt --out runs/target_from_source.json");
  std::string source_path, target_path, out, method = "ransac", refine = "icp", weights;
  double min_density = 5.0, voxel = 0.05;
  unsigned seed = 0;
  app.add_option("source", source_path, "Source block checkpoint")->required();
  app.add_option("target", target_path, "Target block checkpoint")->required();
  app.add_option("--out", out, "Output JSON")->required();
  app.add_option("--method", method, "ransac, fgr or dreg")->check(CLI::IsMember({"ransac", "fgr", "dreg"}));
  app.add_option("--refine", refine, "none or icp")->check(CLI::IsMember({"none", "icp"}));
  app.add_option("--weights", weights, "DReg-NeRF weights (method dreg)");
  app.add_option("--min-density", min_density, "Density above which a cell's point is used (default 5)");
  app.add_option("--voxel", voxel, "Downsampling voxel, scene units (default 0.05)");
  app.add_option("--seed", seed, "Random seed");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force);
  if (method == "dreg") {
    throw InputError("--method dreg: no trained DReg-NeRF weights are shipped yet; use --method ransac or fgr");
  }
  Timer timer;
  NerfBlock source = LoadNerfBlock(source_path), target = LoadNerfBlock(target_path);
  const BlockPoints ps = ExtractOccupiedPoints(source, min_density, seed), pt = ExtractOccupiedPoints(target, min_density, seed);
  const Eigen::Matrix3Xd src = ToEigen(ps.xyz), tgt = ToEigen(pt.xyz);
  Json result;
  if (src.cols() < 100 || tgt.cols() < 100) {
    LOG_WARN("{}: too few occupied points (source {}, target {}); registration is unreliable", out, src.cols(), tgt.cols());
  }
  ClassicalRegistrationOptions options;
  options.method = method;
  options.icp = refine == "icp";
  options.voxel_size = voxel;
  options.normal_radius = 2 * voxel;
  options.feature_radius = 5 * voxel;
  options.seed = seed;
  ClassicalRegistrationResult r;
  if (src.cols() >= 3 && tgt.cols() >= 3) r = RegisterPointClouds(src, tgt, options);
  const double confidence = r.fitness;
  if (confidence < 0.3) LOG_WARN("{}: low confidence {:.2f}: the blocks may not overlap", out, confidence);
  result = {{"target_from_source", MatrixToJson(r.target_from_source.ToMatrix())},
            {"scale", 1.0},
            {"confidence", confidence},
            {"inlier_rmse", r.inlier_rmse},
            {"seconds", timer.Seconds()},
            {"method", method + (options.icp ? "+icp" : "")},
            {"source_points", src.cols()},
            {"target_points", tgt.cols()}};
  WriteJsonFile(out, result);
  // Before / after: source in orange, target in blue, from three fixed viewpoints.
  const std::string stem = out.substr(0, out.size() - LowerExtension(out).size());
  auto subsample = [](const Eigen::Matrix3Xd& m) {
    const Eigen::Index step = std::max<Eigen::Index>(1, m.cols() / 20000);
    Eigen::Matrix3Xd s(3, (m.cols() + step - 1) / step);
    for (Eigen::Index i = 0, k = 0; i < m.cols(); i += step, ++k) s.col(k) = m.col(i);
    return s;
  };
  const Eigen::Matrix3Xd s_small = subsample(src), t_small = subsample(tgt);
  const Eigen::Vector3d centre = t_small.cols() ? Eigen::Vector3d(t_small.rowwise().mean()) : Eigen::Vector3d::Zero();
  const Eigen::Vector3f orange(0.95f, 0.5f, 0.1f), blue(0.1f, 0.35f, 0.9f);
  WriteImage(stem + "_before.png", ThreeViewOverlay({{s_small, orange}, {t_small, blue}}, centre, 5.0));
  WriteImage(stem + "_after.png",
             ThreeViewOverlay({{Transform(r.target_from_source, s_small), orange}, {t_small, blue}}, centre, 5.0));
  std::printf("%s\n", result.dump().c_str());
  return 0;
}

int RunRegEval(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Errors of an estimated target_from_source against a rendered dataset's ground truth: rotation "
                  "(geodesic, degrees) and translation (full norm, scene units and as a fraction of the object extent "
                  "2.5). Success: <= 5 deg and <= 0.05 of the extent.",
                  "nerfreg reg eval --pair runs/t.json --ground-truth data/spider/ground_truth.json --source 0 --target 1");
  std::string pair, gt_path, out;
  int source = 0, target = 1;
  app.add_option("--pair", pair, "Registration output (reg register)")->required();
  app.add_option("--ground-truth", gt_path, "ground_truth.json of the rendered dataset")->required();
  app.add_option("--source", source, "Source block index (default 0)");
  app.add_option("--target", target, "Target block index (default 1)");
  app.add_option("--out", out, "Also write the errors to this JSON file");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  if (!out.empty()) CheckCanWriteOutput(out, common.force);
  const Json pj = ReadJsonFile(pair), gj = ReadJsonFile(gt_path);
  const JsonField p(pj, pair), g(gj, gt_path);
  Sim3d est, src_from_world, tgt_from_world;
  try {
    est = Sim3d::FromMatrix(p["target_from_source"].Matrix(4, 4));
    src_from_world = Sim3d::FromMatrix(g["blocks"][source]["block_from_world"].Matrix(4, 4));
    tgt_from_world = Sim3d::FromMatrix(g["blocks"][target]["block_from_world"].Matrix(4, 4));
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("reg eval: a transform is not a similarity: ") + e.what());
  }
  const Sim3d gt = tgt_from_world * src_from_world.Inverse();
  const double rot = RotationErrorDeg(est.rotation, gt.rotation);
  const double trans = TranslationError(est.translation, gt.translation);
  const double extent = 2.5;
  const bool success = rot <= 5.0 && trans / extent <= 0.05;
  const Json j = {{"rotation_error_deg", rot}, {"translation_error", trans}, {"translation_error_fraction", trans / extent},
                  {"success", success}, {"method", p.StringOr("method", "?")}, {"seconds", p.DoubleOr("seconds", 0)}};
  if (!out.empty()) WriteJsonFile(out, j);
  std::printf("%-14s %10s %12s %10s %8s\n", "method", "rot (deg)", "trans", "trans/ext", "success");
  std::printf("%-14s %10.3f %12.4f %10.4f %8s\n", p.StringOr("method", "?").c_str(), rot, trans, trans / extent,
              success ? "yes" : "no");
  return 0;
}
