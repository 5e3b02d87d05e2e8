#include "nerfreg/dbarf_data/render_dbarf_views.h"

#include <filesystem>

#include "nerfreg/data/convert.h"
#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"

namespace nerfreg {

namespace fs = std::filesystem;

void DbarfRenderJob::Check() const {
  if (num_sources < 1) throw InputError("--sources: expected >= 1");
}

int RenderDbarfViews(const DbarfRenderJob& job) {
  job.Check();
  CheckCanWriteOutput(job.out, job.force, {job.posed, job.transforms, job.weights});
  DbarfModel model = LoadDbarfWeights(job.weights);
  model.To(job.device);
  DbarfSceneOptions scene_options;
  scene_options.hold_out_test = false;
  scene_options.estimate_cameras = job.estimate_cameras;
  LoadedDbarfScene loaded = LoadDbarfScene(job.posed, scene_options);
  if (loaded.estimated_here) {
    LOG_WARN(
        "{}: not written by dbarf poses; its cameras were estimated again, so the frame is that of this run, "
        "not the file's",
        job.posed);
  }
  const Dataset cams = ReadCameras(job.transforms);
  OutputDir output(job.out, job.force, {job.posed, job.transforms, job.weights});
  const std::string& tmp = output.tmp();
  CreateDirectories(JoinPaths(tmp, "depth"));
  {
    ProgressBar bar("dbarf render", static_cast<int64_t>(cams.frames.size()), "view");
    for (const Frame& f : cams.frames) {
      const torch::Tensor k = IntrinsicsToTensor(f.camera);
      const torch::Tensor pose = Matrix4ToTensor(f.cam_from_world.ToMatrix());
      const std::vector<int> sources = NearestViews(loaded.scene, pose, job.num_sources);
      const NovelView v = RenderNovelView(model, loaded.scene, sources, k, pose, f.camera.height, f.camera.width);
      std::string name = fs::path(f.name).replace_extension(".png").string();
      WriteImage(JoinPaths(tmp, name), TensorToImage(v.rgb));
      WriteImage(JoinPaths(tmp, "depth/" + name),
                 InverseDepthImage(v.depth, v.valid, loaded.scene.near, loaded.scene.far));
      bar.Tick();
    }
    bar.Finish();
    output.Commit();
  }
  LOG_INFO("rendered {} views -> {}", cams.frames.size(), job.out);
  return static_cast<int>(cams.frames.size());
}

}  // namespace nerfreg
