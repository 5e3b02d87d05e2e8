// Scenes for DBARF from the formats people have: a transforms.json written by `nerfreg dbarf
// poses` (estimated cameras, depth range and view graph already in it), or any dataset
// `nerfreg convert` reads (transforms.json, LLFF poses_bounds.npy, COLMAP model), whose poses are
// ground truth. Those are either used as the training cameras (DbarfSceneOptions::cameras
// "ground-truth") or kept for evaluation only while the cameras, depth range and view graph are
// estimated from the images by a DbarfCameraEstimator: dbarf_sfm/scene_cameras.h gives the SfM's.
// This layer has no SfM, so the learned-core build (no OpenCV, Ceres) loads and trains on scenes too.
#pragma once

#include <torch/torch.h>

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf/dbarf_trainer.h"
#include "nerfreg/data/dataset.h"
#include "nerfreg/geometry/camera.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

// Estimates a scene's cameras from its images, for a dataset whose own poses are ground truth:
// fills scene->cam_from_world [V, 4, 4] float32, neighbours, near and far, marks the images it
// could not pose unusable and names them in not_posed. images: as loaded (max_width wide at most);
// cameras: their intrinsics at that size. Throws InputError (naming path) when it cannot.
using DbarfCameraEstimator =
    std::function<void(const std::string& path, const std::vector<Image>& images, const std::vector<Camera>& cameras,
                       int max_width, DbarfScene* scene, std::vector<std::string>* not_posed)>;

struct DbarfSceneOptions {
  // Images wider than this are downsampled (area) to it, intrinsics scaled on a copy (all of fx,
  // fy, cx, cy: spec 9.1). 0 keeps the size.
  int max_width = 0;
  // Test-split frames are loaded but not usable as sources or training targets.
  bool hold_out_test = true;
  // Where a dataset's training cameras come from: "estimated" (from the images by
  // estimate_cameras, the dataset's poses kept for evaluation only) or "ground-truth" (the
  // dataset's own poses, for training data only, as the original trains: its views are chosen by
  // true camera distance). With "ground-truth" the poses are put in the frame `dbarf poses` writes
  // (the first usable camera at the identity, the mean distance of the others to it 1), the view
  // graph is the nearest cameras (centre distance plus viewing angle), and the depth range is the
  // frames' own near / far (without them, the depths of the dataset's aabb) in that frame,
  // widened as the SfM's estimate is; nothing is estimated,
  // so scenes the SfM cannot pose (low texture, repetition) can be trained on too.
  std::string cameras = "estimated";
  // "estimated" cameras come from this (dbarf_sfm/scene_cameras.h: SfmCameraEstimator). Empty:
  // this build or caller estimates none, and such a dataset is refused with a named error.
  DbarfCameraEstimator estimate_cameras;
  void Check() const;  // throws InputError naming the option
};

struct LoadedDbarfScene {
  DbarfScene scene;
  // [V, 4, 4] float32: the dataset's own poses when it was not written by dbarf poses (ground
  // truth for evaluation, never used for training or rendering); undefined otherwise.
  torch::Tensor ground_truth;
  std::vector<bool> is_test;           // per view, split == "test"
  Dataset dataset;                     // as read (cameras at the loaded size)
  bool estimated_here = false;         // cameras estimated from the images (estimate_cameras), not
                                       // written by dbarf poses
  std::vector<std::string> not_posed;  // images the estimation could not pose (left unusable)
};

// Throws InputError naming the file and field on bad input (see data/convert.h for formats).
LoadedDbarfScene LoadDbarfScene(const std::string& path, const DbarfSceneOptions& options = {});

// The transforms.json behind `path` (a file or a folder holding one), or "" for other formats.
std::string TransformsJsonPath(const std::string& path);

// The k usable views nearest to a camera cam_from_world [4, 4]: centre distance (in units of the
// scene's median distance between neighbouring centres) plus the angle between viewing directions
// (radians), smallest first. For novel cameras, which have no image and so no view-graph edge.
std::vector<int> NearestViews(const DbarfScene& scene, const torch::Tensor& cam_from_world, int k);

// Images [V, 3, H, W] and their intrinsics [V, 3, 3] area-averaged to max_width wide (the height
// in proportion), the intrinsics' rows scaled alike; as given where max_width <= 0 or W <= max_width.
std::pair<torch::Tensor, torch::Tensor> ShrinkToWidth(const torch::Tensor& images, const torch::Tensor& intrinsics,
                                                      int max_width);

struct NovelView {
  torch::Tensor rgb;    // [3, H, W] float32
  torch::Tensor depth;  // [H, W] float32, z-depth
  torch::Tensor valid;  // [H, W] bool
};
// Renders a camera (intrinsics [3, 3], cam_from_world [4, 4], in the scene's frame) of size
// height x width from the scene's views `sources` placed by the scene's cameras, without gradients.
NovelView RenderNovelView(DbarfModel& model, const DbarfScene& scene, const std::vector<int>& sources,
                          const torch::Tensor& intrinsics, const torch::Tensor& cam_from_world, int64_t height,
                          int64_t width);

// The depth range a render of a view spans: the 1st and 99th percentiles of its valid depths
// (depth [H, W] float32, valid [H, W] bool), divided and multiplied by margin (> 1), within
// [near, far]. {near, far} when fewer than 16 pixels are valid or the range would not narrow.
// Why: the renderer's samples are uniform in inverse depth over the range it is given; over a
// view's own range they are closer together than over the scene's.
std::pair<double, double> ViewDepthRange(const torch::Tensor& depth, const torch::Tensor& valid, double near,
                                         double far, double margin);

// Cameras between the data layer and tensors: 4x4 matrices [4, 4] float32 and back, and a
// camera's intrinsics [3, 3] float32.
torch::Tensor Matrix4ToTensor(const Eigen::Matrix4d& m);
Eigen::Matrix4d TensorToMatrix4(const torch::Tensor& t);
torch::Tensor IntrinsicsToTensor(const Camera& camera);

// Image [H, W, C] in [0, 1] -> tensor [3, H, W] float32 (alpha composited over white), and back.
torch::Tensor ImageToTensor(const Image& image);
torch::Tensor ImageToTensor(const PackedImage& image);
Image TensorToImage(const torch::Tensor& chw);

// Inverse depth for viewing (depth [H, W], valid [H, W] bool): near is white, far black, invalid
// pixels black.
Image InverseDepthImage(const torch::Tensor& depth, const torch::Tensor& valid, double near, double far);

}  // namespace nerfreg
