// Commands of the registration layer: reg register | reg eval.
#include <cmath>

#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/posegraph/pose_graph.h"
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

int RunRegRegisterMany(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Register many NeRF blocks into one frame (block 0's): every pair is registered, pairs that agree "
                  "(fitness above --min-confidence) become edges of a pose graph, which is solved with a robust loss "
                  "from a cycle-consistent spanning tree. Writes {world_from_block: [4x4...], edges: [...]}.",
                  "nerfreg reg register-many runs/b0.ckpt runs/b1.ckpt runs/b2.ckpt --out runs/poses.json");
  std::vector<std::string> paths;
  std::string out;
  double min_density = 5.0, voxel = 0.05, min_confidence = 0.3;
  unsigned seed = 0;
  app.add_option("blocks", paths, "Block checkpoints (the first defines the world frame)")->required()->expected(2, 1000);
  app.add_option("--out", out, "Output JSON")->required();
  app.add_option("--min-density", min_density, "Density above which a cell's point is used (default 5)");
  app.add_option("--voxel", voxel, "Downsampling voxel, scene units (default 0.05)");
  app.add_option("--min-confidence", min_confidence, "Pairs below this fitness are not used (default 0.3)");
  app.add_option("--seed", seed, "Random seed");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force);
  Timer timer;
  const int n = static_cast<int>(paths.size());
  std::vector<Eigen::Matrix3Xd> clouds;
  for (const auto& p : paths) {
    NerfBlock b = LoadNerfBlock(p);
    clouds.push_back(ToEigen(ExtractOccupiedPoints(b, min_density, seed).xyz));
    if (clouds.back().cols() < 100) LOG_WARN("{}: only {} occupied points", p, clouds.back().cols());
  }
  ClassicalRegistrationOptions options;
  options.voxel_size = voxel;
  options.normal_radius = 2 * voxel;
  options.feature_radius = 5 * voxel;
  options.seed = seed;
  std::vector<PoseGraphEdge> edges;
  Json edges_json = Json::array();
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      if (clouds[i].cols() < 3 || clouds[j].cols() < 3) continue;
      const ClassicalRegistrationResult r = RegisterPointClouds(clouds[i], clouds[j], options);
      const bool used = r.fitness >= min_confidence;
      edges_json.push_back({{"source", i}, {"target", j}, {"target_from_source", MatrixToJson(r.target_from_source.ToMatrix())},
                            {"confidence", r.fitness}, {"used", used}});
      if (!used) continue;
      PoseGraphEdge e;
      e.i = i;
      e.j = j;
      e.j_from_i = r.target_from_source;
      e.weight = r.fitness;
      edges.push_back(e);
    }
  }
  const PoseGraphResult g = OptimizePoseGraph(n, edges, PoseGraphOptions{});
  Json world_from_block = Json::array(), connected = Json::array();
  for (int k = 0; k < n; ++k) {
    // The graph's nodes are block_from_world-like: x_in_world = world_from_node * x_in_block.
    world_from_block.push_back(MatrixToJson(g.world_from_node[k].ToMatrix()));
    connected.push_back(static_cast<bool>(g.connected[k]));
    if (!g.connected[k]) LOG_WARN("{}: no confident registration links it to block 0; left at identity", paths[k]);
  }
  size_t used = 0;
  for (size_t e = 0, k = 0; e < edges_json.size(); ++e) {
    if (!edges_json[e]["used"].get<bool>()) continue;
    edges_json[e]["inlier"] = static_cast<bool>(g.edge_inlier[k]);
    edges_json[e]["rotation_residual_deg"] = g.edge_rotation_error_deg[k];
    ++k;
    ++used;
  }
  const Json result = {{"world_from_block", world_from_block}, {"connected", connected}, {"edges", edges_json},
                       {"seconds", timer.Seconds()}, {"blocks", paths}};
  WriteJsonFile(out, result);
  LOG_INFO("{} blocks, {} of {} pairs used, {:.1f} s", n, used, edges_json.size(), timer.Seconds());
  return 0;
}
