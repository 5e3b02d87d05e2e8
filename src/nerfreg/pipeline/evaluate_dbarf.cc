#include "nerfreg/pipeline/evaluate_dbarf.h"

#include <filesystem>
#include <map>
#include <set>

#include "nerfreg/data/npy.h"
#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_sfm/scene_cameras.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/image_metrics.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/stats.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace fs = std::filesystem;

namespace {

double Mean(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return x.empty() ? 0.0 : s / x.size();
}

// The rendered z-depth's error against the dataset's own depth map of the view, where it has one
// (`render --depth` writes ROOT/depth/<image stem>.npy): the median over the pixels valid in both
// of |depth / (s * true) - 1|, s the median ratio (the estimated cameras' frame has a scale of its
// own). -1 when there is no map. It measures the renderer's geometry, which the finetune's last
// stage bundle-adjusts the cameras through (docs/poses_and_views.md, "The last stage").
double DepthError(const std::string& root, const std::string& name, const NovelView& nv) {
  const std::string path = JoinPaths(root, "depth/" + fs::path(name).stem().string() + ".npy");
  if (!fs::exists(path)) return -1;
  const NpyArray a = ReadNpy(path);
  if (a.shape.size() != 2 || a.shape[0] < 1 || a.shape[1] < 1) ThrowInputError(path, "shape", "a depth map [H, W]");
  const int64_t h = nv.depth.size(0), w = nv.depth.size(1);
  torch::Tensor truth = torch::tensor(a.data, torch::kDouble).to(torch::kFloat).view({1, 1, a.shape[0], a.shape[1]});
  torch::Tensor covered = (torch::isfinite(truth) & (truth > 0)).to(torch::kFloat);  // 0 = no surface
  truth = torch::where(covered > 0, truth, torch::zeros_like(truth));
  if (a.shape[0] != h || a.shape[1] != w) {  // the scene was loaded downsampled (--max-width)
    // Area-averaged over surface pixels only; a pixel counts only where its whole footprint has a
    // surface (one that also covers the background would average the two).
    namespace F = torch::nn::functional;
    const auto area = F::InterpolateFuncOptions().size(std::vector<int64_t>{h, w}).mode(torch::kArea);
    covered = F::interpolate(covered, area);
    truth = F::interpolate(truth, area) / covered.clamp_min(1e-6);
  }
  truth = truth.view({h, w});
  const torch::Tensor ok =
      nv.valid & (covered.view({h, w}) > 0.999) & torch::isfinite(nv.depth) & (nv.depth > 0);  // [H, W]
  if (ok.sum().item<int64_t>() < 10) return -1;
  const torch::Tensor d = nv.depth.masked_select(ok), t = truth.masked_select(ok);
  const double scale = (d / t).median().item<double>();
  return (d / (scale * t) - 1).abs().median().item<double>();
}

Json RelativeToJson(const RelativePoseError& e) {
  return Json{{"rotation_deg", e.rotation_deg}, {"translation_direction_deg", e.translation_deg}, {"pairs", e.pairs}};
}

// Poses: every posed image against the ground truth. Fills posed (per view) and the estimate's figures.
void EvaluateScenePoses(const DbarfEvaluationOptions& o, DbarfModel& model, const LoadedDbarfScene& loaded,
                        std::vector<bool>* posed, DbarfEvaluation* e, Json* relative) {
  const DbarfScene& scene = loaded.scene;
  std::vector<Rigid3d> est, gt;
  posed->assign(scene.NumViews(), true);
  for (const auto& name : loaded.not_posed)
    for (int v = 0; v < scene.NumViews(); ++v)
      if (scene.image_names[v] == name) (*posed)[v] = false;
  const auto rigid = [](const torch::Tensor& t) { return Rigid3d::FromMatrix(TensorToMatrix4(t), 1e-3); };
  for (int v = 0; v < scene.NumViews(); ++v) {
    if (!(*posed)[v]) continue;
    est.push_back(rigid(scene.cam_from_world[v]));
    gt.push_back(rigid(loaded.ground_truth[v]));
  }
  e->posed = est.size();
  e->poses = EvaluatePoses(est, gt, PoseAlignment::kRotationsAndCenters);
  // Relative poses between each usable view and its view-graph neighbours (scale-free measures):
  // the estimated cameras', and the pose network's refinement of them.
  e->relative_cameras = EvaluateCameraRelativePoses(scene, loaded.ground_truth, o.num_sources);
  e->relative_network = EvaluateRelativePoses(model, scene, loaded.ground_truth, o.num_sources, "cameras");
  *relative = {{"cameras", RelativeToJson(e->relative_cameras)}, {"network", RelativeToJson(e->relative_network)}};
  if (o.perturb.Active()) {
    // What the network does with a worse initialisation than the cameras: the same perturbation
    // for both rows.
    (*relative)["perturbed"] = {
        {"deg", o.perturb.deg},
        {"translation", o.perturb.translation},
        {"cameras", RelativeToJson(EvaluateCameraRelativePoses(scene, loaded.ground_truth, o.num_sources, o.perturb))},
        {"network", RelativeToJson(EvaluateRelativePoses(model, scene, loaded.ground_truth, o.num_sources, "cameras",
                                                         o.perturb))}};
  }
}

// The cameras of `cameras` (a posed-images file for the dataset's images) in place of the
// dataset's estimated ones: matched by file name; images the file lacks or did not pose are
// unposed; the view graph and depth range are the file's.
void UsePosedCameras(const std::string& cameras, const DbarfSceneOptions& scene_options, LoadedDbarfScene* loaded) {
  DbarfSceneOptions posed_options;
  posed_options.hold_out_test = false;
  posed_options.max_width = scene_options.max_width;
  posed_options.cameras = "ground-truth";  // a file of another kind is then read without an SfM, and refused
  const LoadedDbarfScene posed = LoadDbarfScene(cameras, posed_options);
  if (posed.ground_truth.defined()) {
    ThrowInputError(cameras, "", "posed images written by dbarf poses or dbarf finetune --refine-cameras");
  }
  DbarfScene& scene = loaded->scene;
  const auto base = [](const std::string& name) { return fs::path(name).filename().string(); };
  std::map<std::string, int> index;  // dataset view of a file name
  for (int v = 0; v < scene.NumViews(); ++v) index[base(scene.image_names[v])] = v;
  std::set<std::string> unposed;
  for (const auto& name : posed.not_posed) unposed.insert(base(name));
  std::vector<int> of_posed(posed.scene.NumViews(), -1);  // dataset view of each posed view
  std::vector<bool> have(scene.NumViews(), false);
  for (int p = 0; p < posed.scene.NumViews(); ++p) {
    const auto it = index.find(base(posed.scene.image_names[p]));
    if (it == index.end() || unposed.count(it->first)) continue;
    of_posed[p] = it->second;
    have[it->second] = true;
    scene.cam_from_world[it->second].copy_(posed.scene.cam_from_world[p]);
  }
  loaded->not_posed.clear();
  for (int v = 0; v < scene.NumViews(); ++v) {
    scene.neighbours[v].clear();
    if (!have[v]) loaded->not_posed.push_back(scene.image_names[v]);
    scene.usable[v] = have[v] && !loaded->is_test[v];
  }
  for (int p = 0; p < posed.scene.NumViews(); ++p) {
    if (of_posed[p] < 0) continue;
    for (int q : posed.scene.neighbours[p])
      if (of_posed[q] >= 0) scene.neighbours[of_posed[p]].push_back(of_posed[q]);
  }
  scene.near = posed.scene.near;
  scene.far = posed.scene.far;
  scene.supervision_cam_from_world = torch::Tensor();
}

}  // namespace

void DbarfEvaluationOptions::Check() const {
  if (num_sources < 1) throw InputError("--sources: expected >= 1");
  if (!(perturb.deg >= 0 && perturb.deg <= 30 && perturb.translation >= 0 && perturb.translation <= 1)) {
    throw InputError("--perturb-deg / --perturb-translation: expected 0 to 30 degrees and 0 to 1");
  }
}

DbarfEvaluation EvaluateDbarf(const DbarfEvaluationOptions& o) {
  o.Check();
  CheckCanWriteOutput(o.out, o.force, {o.dataset, o.weights, o.cameras});
  DbarfModel model = LoadDbarfWeights(o.weights);
  model.To(o.device);
  const Timer timer;
  DbarfSceneOptions scene_options = o.scene;
  if (!scene_options.estimate_cameras) scene_options.estimate_cameras = SfmCameraEstimator({});
  // Given cameras replace the estimate, so none is made (the dataset's own poses stand in until
  // UsePosedCameras overwrites every one of them).
  if (!o.cameras.empty()) scene_options.cameras = "ground-truth";
  LoadedDbarfScene loaded = LoadDbarfScene(o.dataset, scene_options);
  if (!loaded.ground_truth.defined())
    ThrowInputError(o.dataset, "", "a dataset with ground-truth poses (not the output of dbarf poses)");
  if (!o.cameras.empty()) UsePosedCameras(o.cameras, o.scene, &loaded);
  DbarfEvaluation e;
  e.seconds_poses = timer.Seconds();
  const DbarfScene& scene = loaded.scene;
  std::vector<bool> posed;
  Json relative;
  EvaluateScenePoses(o, model, loaded, &posed, &e, &relative);

  // Novel views: test views at their estimated cameras, from training views.
  OutputDir output(o.out, o.force, {o.dataset, o.weights, o.cameras});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "views"));
  Json views = Json::array();
  std::vector<double> psnrs, ssims, depth_errors;
  std::vector<Image> sheet;
  int num_test = 0;
  for (int v = 0; v < scene.NumViews(); ++v) num_test += loaded.is_test[v];
  ProgressBar bar("dbarf eval", num_test, "view");
  for (int v = 0; v < scene.NumViews(); ++v) {
    if (!loaded.is_test[v]) continue;
    bar.Tick();
    const std::string& name = scene.image_names[v];
    std::vector<int> sources = DbarfTrainer::SourcesOf(scene, v, o.num_sources);
    if (!posed[v] || sources.empty()) {
      views.push_back({{"name", name}, {"rendered", false}});
      LOG_WARN("{}: test view {} not posed or without training neighbours; not rendered", o.dataset, name);
      continue;
    }
    const int64_t h = scene.images.size(2), w = scene.images.size(3);
    const NovelView nv = RenderNovelView(model, scene, sources, scene.intrinsics[v], scene.cam_from_world[v], h, w);
    const Image render = TensorToImage(nv.rgb), truth = TensorToImage(scene.images[v]);
    const double psnr = Psnr(render, truth), ssim = Ssim(render, truth);
    psnrs.push_back(psnr);
    ssims.push_back(ssim);
    const std::string png = fs::path(name).replace_extension(".png").string();
    WriteImage(JoinPaths(tmp, "views/" + png), render);
    const Image depth = InverseDepthImage(nv.depth, nv.valid, scene.near, scene.far);
    WriteImage(JoinPaths(tmp, "views/depth_" + png), depth);
    sheet.insert(sheet.end(), {truth, render, depth});
    Json entry = {{"name", name}, {"rendered", true}, {"psnr", psnr}, {"ssim", ssim}, {"sources", sources.size()}};
    if (const double d = DepthError(loaded.dataset.root, name, nv); d >= 0) {
      entry["depth_error"] = d;
      depth_errors.push_back(d);
    }
    views.push_back(entry);
  }
  bar.Finish();
  const PoseEvaluation& pe = e.poses;
  e.images = scene.NumViews();
  e.rendered = psnrs.size();
  e.psnr_mean = Mean(psnrs);
  e.ssim_mean = Mean(ssims);
  if (!depth_errors.empty()) e.depth_error_median = Median(depth_errors);
  e.seconds = timer.Seconds();
  e.json = {{"dataset", o.dataset},
            {"cameras", o.cameras.empty() ? Json("estimated") : Json(o.cameras)},
            {"weights", o.weights},
            {"images", scene.NumViews()},
            {"posed", e.posed},
            {"not_posed", loaded.not_posed},
            {"rotation_deg_median", pe.aligned ? pe.median_rotation_deg : -1.0},
            {"rotation_deg_mean", pe.aligned ? pe.mean_rotation_deg : -1.0},
            {"center_median", pe.aligned ? pe.median_center : -1.0},
            {"center_percent_median", pe.aligned ? pe.median_center_percent : -1.0},
            {"relative_poses", relative},
            {"test_views", views.size()},
            {"rendered", psnrs.size()},
            {"psnr_mean", e.psnr_mean},
            {"ssim_mean", e.ssim_mean},
            {"depth_error_median", depth_errors.empty() ? Json(nullptr) : Json(e.depth_error_median)},
            {"seconds_poses", e.seconds_poses},
            {"seconds", e.seconds},
            {"views", views},
            {"protocol",
             "test views rendered at their estimated cameras (posed from all images), "
             "from view-graph neighbours among the training views"}};
  WriteJsonFile(JoinPaths(tmp, "eval.json"), e.json);
  if (!sheet.empty()) WriteImage(JoinPaths(tmp, "compare.png"), ContactSheet(sheet, 3));
  output.Commit();
  return e;
}

}  // namespace nerfreg
