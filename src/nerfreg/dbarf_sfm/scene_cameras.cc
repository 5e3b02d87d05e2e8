#include "nerfreg/dbarf_sfm/scene_cameras.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

namespace {

uint64_t Fnv1a(uint64_t h, const void* data, size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

template <typename T>
uint64_t Fnv1aValue(uint64_t h, const T& value) {
  return Fnv1a(h, &value, sizeof(value));
}

// The cache entry's name: a hash of everything the SfM sees (pixels, intrinsics, size).
std::string SfmCacheKey(const std::vector<Image>& images, const std::vector<Camera>& cameras, int max_width) {
  uint64_t h = 14695981039346656037ull;
  h = Fnv1aValue(h, kSfmCacheVersion);
  h = Fnv1aValue(h, max_width);
  for (size_t i = 0; i < images.size(); ++i) {
    const Image& im = images[i];
    h = Fnv1aValue(h, im.width);
    h = Fnv1aValue(h, im.height);
    h = Fnv1aValue(h, im.channels);
    h = Fnv1a(h, im.data.data(), im.data.size() * sizeof(float));
    const Camera& c = cameras[i];
    for (double x : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2}) h = Fnv1aValue(h, x);
  }
  char name[32];
  std::snprintf(name, sizeof(name), "%016llx.json", static_cast<unsigned long long>(h));
  return name;
}

// Fills the scene's cameras, usability, neighbours and depth range from a cache entry. Returns
// false (and changes nothing) when the entry is missing or does not fit the scene: a stale or
// damaged entry costs one SfM run, never a wrong camera.
bool ReadSfmCache(const std::string& file, DbarfScene* scene, std::vector<std::string>* not_posed) {
  if (!FileExists(file)) return false;
  try {
    const Json json = ReadJsonFile(file);
    const int64_t v = scene->NumViews();
    if (json.at("version").get<int>() != kSfmCacheVersion) return false;
    const auto& poses = json.at("cam_from_world");
    const auto& posed = json.at("posed");
    const auto& neighbours = json.at("neighbours");
    if (static_cast<int64_t>(poses.size()) != v || static_cast<int64_t>(posed.size()) != v ||
        static_cast<int64_t>(neighbours.size()) != v)
      return false;
    std::vector<torch::Tensor> cams;
    std::vector<std::vector<int>> nbrs(v);
    for (int64_t i = 0; i < v; ++i) {
      const std::vector<double> m = poses[i].get<std::vector<double>>();
      if (m.size() != 16) return false;
      cams.push_back(torch::tensor(m, torch::kDouble).view({4, 4}).to(torch::kFloat));
      for (int j : neighbours[i].get<std::vector<int>>()) {
        if (j < 0 || j >= v) return false;
        nbrs[i].push_back(j);
      }
    }
    const double near = json.at("near").get<double>(), far = json.at("far").get<double>();
    if (!(near > 0 && far > near)) return false;
    scene->cam_from_world = torch::stack(cams);
    scene->neighbours = std::move(nbrs);
    scene->near = near;
    scene->far = far;
    for (int64_t i = 0; i < v; ++i) {
      if (!posed[i].get<bool>()) {
        scene->usable[i] = false;
        not_posed->push_back(scene->image_names[i]);
      }
    }
    return true;
  } catch (const std::exception& e) {
    LOG_WARN("{}: ignoring an unreadable SfM cache entry ({})", file, e.what());
    return false;
  }
}

void WriteSfmCache(const std::string& file, const std::string& scene_path, const DbarfScene& scene,
                   const std::vector<bool>& posed) {
  Json json;
  json["version"] = kSfmCacheVersion;
  json["scene"] = scene_path;  // for people reading the folder; not part of the key
  Json poses = Json::array(), nbrs = Json::array();
  for (int64_t i = 0; i < scene.NumViews(); ++i) {
    const Eigen::Matrix4d m = TensorToMatrix4(scene.cam_from_world[i]);
    std::vector<double> row;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) row.push_back(m(r, c));
    poses.push_back(row);
    nbrs.push_back(scene.neighbours[i]);
  }
  json["cam_from_world"] = poses;
  json["posed"] = posed;
  json["neighbours"] = nbrs;
  json["near"] = scene.near;
  json["far"] = scene.far;
  WriteJsonFile(file, json);
}

}  // namespace

void SfmSceneCamerasOptions::Check() const { sfm.Check(); }

void DepthRangeFromPoints(const SfmResult& sfm, const std::string& source, double* near, double* far) {
  std::vector<double> depths;
  for (const SfmPoint& p : sfm.points) {
    for (const auto& e : p.elements) {
      if (!sfm.posed[e.image]) continue;
      const double z = (sfm.cam_from_world[e.image] * p.x_in_world).z();
      if (z > 0 && std::isfinite(z)) depths.push_back(z);
    }
  }
  if (depths.size() < 10) ThrowInputError(source, "", "images with enough triangulated points to bound the depth");
  std::sort(depths.begin(), depths.end());
  const auto at = [&](double q) { return depths[static_cast<size_t>(q * (depths.size() - 1))]; };
  *near = 0.7 * at(0.02);
  *far = 1.4 * at(0.98);
}

Json ViewGraphToJson(const ViewGraph& graph) {
  Json edges = Json::array();
  for (const ViewGraphEdge& e : graph.edges) edges.push_back({graph.names[e.i], graph.names[e.j], e.num_inliers});
  return edges;
}

DbarfCameraEstimator SfmCameraEstimator(const SfmSceneCamerasOptions& options) {
  options.Check();
  return [options](const std::string& path, const std::vector<Image>& images, const std::vector<Camera>& cameras,
                   int max_width, DbarfScene* scene, std::vector<std::string>* not_posed) {
    const int64_t v = scene->NumViews();
    std::string cache_file;
    if (!options.cache_dir.empty()) {
      CreateDirectories(options.cache_dir);
      cache_file = JoinPaths(options.cache_dir, SfmCacheKey(images, cameras, max_width));
      if (ReadSfmCache(cache_file, scene, not_posed)) {
        LOG_INFO("{}: cameras estimated from the images earlier, from {}", path, cache_file);
        return;
      }
    }
    LOG_INFO("{}: estimating cameras from the {} images (the file's poses are kept for evaluation only)", path, v);
    const SfmResult sfm = PoseImages(images, cameras, scene->image_names, options.sfm);
    std::vector<torch::Tensor> estimated;
    for (int64_t i = 0; i < v; ++i) {
      estimated.push_back(Matrix4ToTensor(sfm.cam_from_world[i].ToMatrix()));
      if (!sfm.posed[i]) {
        scene->usable[i] = false;
        not_posed->push_back(scene->image_names[i]);
      }
    }
    scene->cam_from_world = torch::stack(estimated);
    scene->neighbours.resize(v);
    for (int64_t i = 0; i < v; ++i)
      scene->neighbours[i] = sfm.view_graph.Neighbors(static_cast<int>(i), static_cast<int>(v));
    DepthRangeFromPoints(sfm, path, &scene->near, &scene->far);
    if (!cache_file.empty()) WriteSfmCache(cache_file, path, *scene, sfm.posed);
  };
}

}  // namespace nerfreg
