#include "nerfreg/pipeline/evaluate_dbarf.h"

#include <filesystem>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/image_metrics.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

namespace fs = std::filesystem;

namespace {

double Mean(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return x.empty() ? 0.0 : s / x.size();
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

}  // namespace

void DbarfEvaluationOptions::Check() const {
  if (num_sources < 1) throw InputError("--sources: expected >= 1");
  if (!(perturb.deg >= 0 && perturb.deg <= 30 && perturb.translation >= 0 && perturb.translation <= 1)) {
    throw InputError("--perturb-deg / --perturb-translation: expected 0 to 30 degrees and 0 to 1");
  }
}

DbarfEvaluation EvaluateDbarf(const DbarfEvaluationOptions& o) {
  o.Check();
  CheckCanWriteOutput(o.out, o.force, {o.dataset, o.weights});
  DbarfModel model = LoadDbarfWeights(o.weights);
  model.To(o.device);
  const Timer timer;
  LoadedDbarfScene loaded = LoadDbarfScene(o.dataset, o.scene);
  if (!loaded.ground_truth.defined())
    ThrowInputError(o.dataset, "", "a dataset with ground-truth poses (not the output of dbarf poses)");
  DbarfEvaluation e;
  e.seconds_poses = timer.Seconds();
  const DbarfScene& scene = loaded.scene;
  std::vector<bool> posed;
  Json relative;
  EvaluateScenePoses(o, model, loaded, &posed, &e, &relative);

  // Novel views: test views at their estimated cameras, from training views.
  OutputDir output(o.out, o.force, {o.dataset, o.weights});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "views"));
  Json views = Json::array();
  std::vector<double> psnrs, ssims;
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
    views.push_back({{"name", name}, {"rendered", true}, {"psnr", psnr}, {"ssim", ssim}, {"sources", sources.size()}});
  }
  bar.Finish();
  const PoseEvaluation& pe = e.poses;
  e.images = scene.NumViews();
  e.rendered = psnrs.size();
  e.psnr_mean = Mean(psnrs);
  e.ssim_mean = Mean(ssims);
  e.seconds = timer.Seconds();
  e.json = {{"dataset", o.dataset},
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
