#include "nerfreg/dbarf_data/dbarf_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Geometry>

#include "nerfreg/data/convert.h"
#include "nerfreg/dbarf_data/posed_images.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

std::string TransformsJsonPath(const std::string& path) {
  if (DetectCameraFormat(path) != CameraFormat::kTransformsJson) return "";
  return DirExists(path) ? JoinPaths(path, "transforms.json") : path;
}

torch::Tensor Matrix4ToTensor(const Eigen::Matrix4d& m) {
  const Eigen::Matrix<float, 4, 4, Eigen::RowMajor> f = m.cast<float>();
  return torch::from_blob(const_cast<float*>(f.data()), {4, 4}, torch::kFloat).clone();
}

Eigen::Matrix4d TensorToMatrix4(const torch::Tensor& t) {
  TORCH_CHECK(t.sizes() == torch::IntArrayRef({4, 4}), "TensorToMatrix4: expected [4, 4], got ", t.sizes());
  const torch::Tensor c = t.detach().to(torch::kCPU, torch::kDouble).contiguous();
  return Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(c.data_ptr<double>());
}

torch::Tensor IntrinsicsToTensor(const Camera& c) {
  return torch::tensor({c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0}, torch::kFloat).view({3, 3});
}

Image InverseDepthImage(const torch::Tensor& depth, const torch::Tensor& valid, double near, double far) {
  const torch::Tensor inv =
      ((1.0 / depth.clamp_min(1e-6) - 1.0 / far) / (1.0 / near - 1.0 / far)).clamp(0, 1) * valid.to(torch::kFloat);
  return TensorToImage(inv.unsqueeze(0));
}

void DbarfSceneOptions::Check() const {
  if (max_width < 0) throw InputError("--max-width: expected >= 0, got " + std::to_string(max_width));
  if (cameras != "estimated" && cameras != "ground-truth") {
    throw InputError("--scene-cameras: expected estimated or ground-truth, got " + cameras);
  }
}

torch::Tensor ImageToTensor(const Image& image) {
  const torch::Tensor hwc = torch::from_blob(const_cast<float*>(image.data.data()),
                                             {image.height, image.width, image.channels}, torch::kFloat);
  torch::Tensor rgb;
  if (image.channels == 4) {
    const torch::Tensor a = hwc.narrow(2, 3, 1);
    rgb = hwc.narrow(2, 0, 3) * a + (1 - a);
  } else if (image.channels == 3) {
    rgb = hwc;
  } else {
    rgb = hwc.narrow(2, 0, 1).expand({image.height, image.width, 3});
  }
  return rgb.permute({2, 0, 1}).contiguous().clone();
}

torch::Tensor ImageToTensor(const PackedImage& image) { return ImageToTensor(UnpackImage(image)); }

Image TensorToImage(const torch::Tensor& chw) {
  const torch::Tensor hwc = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image image(static_cast<int>(hwc.size(1)), static_cast<int>(hwc.size(0)), static_cast<int>(hwc.size(2)));
  std::copy(hwc.data_ptr<float>(), hwc.data_ptr<float>() + hwc.numel(), image.data.begin());
  return image;
}

std::vector<int> NearestViews(const DbarfScene& scene, const torch::Tensor& cam_from_world, int k) {
  TORCH_CHECK(scene.cam_from_world.defined(), "NearestViews: the scene has no cameras");
  const auto centre = [](const torch::Tensor& c) {  // -R^T t
    return -torch::matmul(c.slice(-2, 0, 3).slice(-1, 0, 3).transpose(-1, -2), c.slice(-2, 0, 3).slice(-1, 3, 4))
                .squeeze(-1);
  };
  const auto axis = [](const torch::Tensor& c) { return c.slice(-2, 2, 3).slice(-1, 0, 3).squeeze(-2); };  // row 3 of R
  const torch::Tensor centres = centre(scene.cam_from_world);                                              // [V, 3]
  const torch::Tensor axes = axis(scene.cam_from_world);                                                   // [V, 3]
  // Scale: median over views of the distance to the nearest other view.
  const torch::Tensor d = torch::cdist(centres, centres) + 1e9 * torch::eye(centres.size(0));
  const double scale = std::max(1e-9, std::get<0>(d.min(1)).median().item<double>());
  const torch::Tensor q = cam_from_world.to(torch::kFloat);
  const torch::Tensor dist = (centres - centre(q)).norm(2, 1) / scale;
  const torch::Tensor angle = torch::acos((axes * axis(q)).sum(1).clamp(-1, 1));
  const torch::Tensor score = dist + angle;
  std::vector<std::pair<double, int>> order;
  for (int v = 0; v < scene.NumViews(); ++v)
    if (scene.usable[v]) order.push_back({score[v].item<double>(), v});
  std::sort(order.begin(), order.end());
  std::vector<int> out;
  for (size_t i = 0; i < order.size() && static_cast<int>(i) < k; ++i) out.push_back(order[i].second);
  return out;
}

std::pair<torch::Tensor, torch::Tensor> ShrinkToWidth(const torch::Tensor& images, const torch::Tensor& intrinsics,
                                                      int max_width) {
  const int64_t w = images.size(3), h = images.size(2);
  if (max_width <= 0 || w <= max_width) return {images, intrinsics};
  const int64_t new_w = max_width, new_h = std::max<int64_t>(1, std::lround(double(h) * max_width / w));
  namespace F = torch::nn::functional;
  torch::Tensor shrunk =
      F::interpolate(images, F::InterpolateFuncOptions().size(std::vector<int64_t>{new_h, new_w}).mode(torch::kArea));
  torch::Tensor k = intrinsics.clone();
  k.select(1, 0) *= double(new_w) / w;  // fx, skew, cx
  k.select(1, 1) *= double(new_h) / h;  // fy, cy
  return {shrunk, k};
}

NovelView RenderNovelView(DbarfModel& model, const DbarfScene& scene, const std::vector<int>& sources,
                          const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, int64_t height,
                          int64_t width) {
  TORCH_CHECK(!sources.empty(), "RenderNovelView: no source views");
  torch::NoGradGuard no_grad;
  model.Train(false);
  // The scene may sit on another device than the model (a CPU scene, a GPU model): the views go
  // to the model's.
  const torch::Device device = model.Device();
  const torch::Tensor idx =
      torch::tensor(std::vector<int64_t>(sources.begin(), sources.end()), torch::kLong).to(scene.images.device());
  IbrSourceViews views;
  views.images = scene.images.index_select(0, idx).to(device);
  views.intrinsics = scene.intrinsics.index_select(0, idx).to(device);
  views.cam_from_world = scene.cam_from_world.index_select(0, idx).to(device);
  const IbrRenderOutput out = RenderIbrImage(
      model.nerf.feature_net, model.nerf.ibrnet, views, intrinsics.to(device, torch::kFloat),
      cam_from_world.to(device, torch::kFloat), height, width, scene.near, scene.far, model.options.nerf.render);
  // Back on the CPU, where images are written and scored.
  return {out.rgb.t().reshape({3, height, width}).contiguous().cpu(), out.depth.reshape({height, width}).cpu(),
          out.valid.reshape({height, width}).cpu()};
}

std::pair<double, double> ViewDepthRange(const torch::Tensor& depth, const torch::Tensor& valid, double near,
                                         double far, double margin) {
  TORCH_CHECK(depth.dim() == 2 && valid.sizes() == depth.sizes(), "ViewDepthRange: depth and valid must be [H, W]");
  TORCH_CHECK(margin > 1 && near > 0 && far > near, "ViewDepthRange: need margin > 1 and 0 < near < far");
  const torch::Tensor z = depth.to(torch::kCPU, torch::kDouble);              // [H, W]
  const torch::Tensor d = z.masked_select(valid.cpu() & torch::isfinite(z));  // [N]
  if (d.numel() < 16) return {near, far};
  const torch::Tensor q = torch::quantile(d, torch::tensor({0.01, 0.99}, torch::kDouble));
  const double lo = std::max(near, q[0].item<double>() / margin), hi = std::min(far, q[1].item<double>() * margin);
  if (!(hi > lo * 1.01)) return {near, far};
  return {lo, hi};
}

namespace {

// A frame's depth range from the dataset's scene box (object datasets, such as nerfreg render's,
// give a box rather than per-frame bounds): the depths of its 8 corners, the near one no closer
// than 1 % of the far one (a camera inside the box). False without a box, or with the box behind
// the camera.
bool DepthRangeOfBox(const Dataset& d, const Frame& f, double* near, double* far) {
  if (!d.aabb_min || !d.aabb_max) return false;
  const Eigen::AlignedBox3d box(*d.aabb_min, *d.aabb_max);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    const double z = (f.cam_from_world * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner))).z();
    lo = std::min(lo, z), hi = std::max(hi, z);
  }
  if (!(hi > 0)) return false;
  *near = std::max(lo, 0.01 * hi);
  *far = hi;
  return true;
}

// DbarfSceneOptions::cameras == "ground-truth": the dataset's poses in the frame dbarf poses
// writes, the nearest cameras as the view graph, the frames' near / far as the depth range.
void UseGroundTruthCameras(const std::string& path, const Dataset& d, DbarfScene* scene) {
  const int64_t v = static_cast<int64_t>(d.frames.size());
  int reference = -1;
  for (int64_t i = 0; i < v && reference < 0; ++i)
    if (scene->usable[i]) reference = static_cast<int>(i);
  if (reference < 0) ThrowInputError(path, "frames", "at least one training view");
  const Rigid3d world_from_reference = d.frames[reference].cam_from_world.Inverse();
  std::vector<Rigid3d> cam_from_reference;
  double distance = 0;
  int others = 0;
  for (int64_t i = 0; i < v; ++i) {
    cam_from_reference.push_back(d.frames[i].cam_from_world * world_from_reference);
    if (i != reference && scene->usable[i]) {
      distance += cam_from_reference.back().Inverse().translation.norm();
      ++others;
    }
  }
  if (others == 0 || !(distance > 1e-12)) ThrowInputError(path, "frames", "training views at distinct centres");
  const double scale = others / distance;  // the mean distance to the reference becomes 1
  double near = std::numeric_limits<double>::infinity(), far = 0;
  std::vector<torch::Tensor> cameras;
  for (int64_t i = 0; i < v; ++i) {
    const Frame& f = d.frames[i];
    double frame_near = f.near, frame_far = f.far;
    if (!(frame_near > 0 && frame_far > frame_near) && !DepthRangeOfBox(d, f, &frame_near, &frame_far)) {
      ThrowInputError(path, "frames[" + std::to_string(i) + "].near",
                      "per-frame near and far depths (0 < near < far), or the scene's aabb in front of the camera, "
                      "with --scene-cameras ground-truth");
    }
    near = std::min(near, frame_near * scale);
    far = std::max(far, frame_far * scale);
    Rigid3d c = cam_from_reference[i];
    c.translation *= scale;
    cameras.push_back(Matrix4ToTensor(c.ToMatrix()));
  }
  scene->cam_from_world = torch::stack(cameras);
  // The frames' bounds are the seen depths padded by 0.9 / 1.1 (LLFF's habit, and our renders');
  // the estimated range the network meets in inference is the SfM points' widened by 0.7 / 1.4
  // (DepthRangeFromPoints). Widened alike, training sees the ranges inference gives.
  scene->near = near * (0.7 / 0.9);
  scene->far = far * (1.4 / 1.1);
  scene->neighbours.assign(v, {});
  for (int64_t i = 0; i < v; ++i) {
    for (int j : NearestViews(*scene, scene->cam_from_world[i], static_cast<int>(v)))
      if (j != i) scene->neighbours[i].push_back(j);
  }
}

}  // namespace

LoadedDbarfScene LoadDbarfScene(const std::string& path, const DbarfSceneOptions& options) {
  options.Check();
  LoadedDbarfScene out;
  out.dataset = ReadCameras(path);
  Dataset& d = out.dataset;
  const int64_t v = static_cast<int64_t>(d.frames.size());
  if (v < 3) ThrowInputError(path, "frames", "at least 3 images, found " + std::to_string(v));
  DbarfScene& scene = out.scene;
  scene.name = path;

  // Images at one size (downsampled to max_width), intrinsics scaled with them.
  std::vector<Image> images;
  std::vector<torch::Tensor> tensors, intrinsics;
  for (Frame& f : d.frames) {
    const std::string file = d.ImagePath(f);
    Image image = ReadImage(file);
    if (image.width != f.camera.width || image.height != f.camera.height) {
      ThrowInputError(file, "",
                      "an image of the camera's size " + std::to_string(f.camera.width) + "x" +
                          std::to_string(f.camera.height) + ", got " + std::to_string(image.width) + "x" +
                          std::to_string(image.height));
    }
    torch::Tensor t = ImageToTensor(image);
    if (options.max_width > 0 && image.width > options.max_width) {
      const int64_t w = options.max_width;
      const int64_t h = std::max<int64_t>(1, std::lround(static_cast<double>(image.height) * w / image.width));
      t = torch::nn::functional::interpolate(
              t.unsqueeze(0),
              torch::nn::functional::InterpolateFuncOptions().size(std::vector<int64_t>{h, w}).mode(torch::kArea))
              .squeeze(0);
      const double sx = static_cast<double>(w) / image.width, sy = static_cast<double>(h) / image.height;
      f.camera.fx *= sx;
      f.camera.cx *= sx;
      f.camera.fy *= sy;
      f.camera.cy *= sy;
      f.camera.width = static_cast<int>(w);
      f.camera.height = static_cast<int>(h);
      image = TensorToImage(t);
    }
    if (!tensors.empty() && t.sizes() != tensors[0].sizes()) {
      ThrowInputError(file, "",
                      "images of one size (the first is " + std::to_string(tensors[0].size(2)) + "x" +
                          std::to_string(tensors[0].size(1)) + ")");
    }
    tensors.push_back(t);
    intrinsics.push_back(IntrinsicsToTensor(f.camera));
    images.push_back(std::move(image));
    scene.image_names.push_back(f.name);
    out.is_test.push_back(f.split == "test");
  }
  scene.images = torch::stack(tensors);
  scene.intrinsics = torch::stack(intrinsics);
  scene.usable.assign(v, true);
  if (options.hold_out_test)
    for (int64_t i = 0; i < v; ++i) scene.usable[i] = !out.is_test[i];

  // Cameras estimated by dbarf poses: use them, their depth range and their view graph.
  const std::string json_path = TransformsJsonPath(path);
  Json json;
  if (!json_path.empty()) json = ReadJsonFile(json_path);
  std::vector<torch::Tensor> poses;
  for (const Frame& f : d.frames) poses.push_back(Matrix4ToTensor(f.cam_from_world.ToMatrix()));
  if (IsPosedImages(json)) {
    scene.cam_from_world = torch::stack(poses);
    const PosedImagesInfo posed = ReadPosedImagesInfo(json, json_path);
    std::map<std::string, int> index;
    for (int64_t i = 0; i < v; ++i) index[scene.image_names[i]] = static_cast<int>(i);
    std::vector<std::vector<std::pair<int, int>>> weighted(v);
    for (const PosedImagesInfo::Edge& e : posed.view_graph) {
      if (!index.count(e.a) || !index.count(e.b)) continue;  // an image that was not posed
      weighted[index[e.a]].push_back({e.inliers, index[e.b]});
      weighted[index[e.b]].push_back({e.inliers, index[e.a]});
    }
    scene.neighbours.resize(v);
    for (int64_t i = 0; i < v; ++i) {
      std::stable_sort(weighted[i].begin(), weighted[i].end(),
                       [](const auto& x, const auto& y) { return x.first > y.first; });
      for (const auto& [w, j] : weighted[i]) scene.neighbours[i].push_back(j);
    }
    scene.near = posed.near;
    scene.far = posed.far;
  } else if (options.cameras == "ground-truth") {
    out.ground_truth = torch::stack(poses);
    UseGroundTruthCameras(path, d, &scene);
    out.ground_truth = scene.cam_from_world.clone();  // the same cameras, in the frame used
  } else {
    // The dataset's poses are ground truth: kept aside; estimate everything from the images.
    if (!options.estimate_cameras) {
      ThrowInputError(path, "frames",
                      "posed images written by dbarf poses, or --scene-cameras ground-truth: this build estimates no "
                      "cameras from images (the learned-core build has no SfM)");
    }
    out.ground_truth = torch::stack(poses);
    std::vector<Camera> cameras;
    for (const Frame& f : d.frames) cameras.push_back(f.camera);
    options.estimate_cameras(path, images, cameras, options.max_width, &scene, &out.not_posed);
    out.estimated_here = true;
  }
  scene.Check();
  return out;
}

}  // namespace nerfreg
