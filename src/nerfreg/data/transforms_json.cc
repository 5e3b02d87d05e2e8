#include "nerfreg/data/transforms_json.h"

#include <cmath>
#include <filesystem>

#include "nerfreg/geometry/conventions.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"

namespace fs = std::filesystem;

namespace nerfreg {
namespace {

// Intrinsics fields as found at one level (top or frame); NaN = absent.
struct IntrinsicFields {
  double fl_x = NAN, fl_y = NAN, cx = NAN, cy = NAN, w = NAN, h = NAN;
  double angle_x = NAN, angle_y = NAN;
  double k1 = NAN, k2 = NAN, p1 = NAN, p2 = NAN;
};

IntrinsicFields ReadIntrinsicFields(const JsonField& j) {
  IntrinsicFields f;
  f.fl_x = j.DoubleOr("fl_x", NAN);
  f.fl_y = j.DoubleOr("fl_y", NAN);
  f.cx = j.DoubleOr("cx", NAN);
  f.cy = j.DoubleOr("cy", NAN);
  f.w = j.DoubleOr("w", NAN);
  f.h = j.DoubleOr("h", NAN);
  f.angle_x = j.DoubleOr("camera_angle_x", NAN);
  f.angle_y = j.DoubleOr("camera_angle_y", NAN);
  f.k1 = j.DoubleOr("k1", NAN);
  f.k2 = j.DoubleOr("k2", NAN);
  f.p1 = j.DoubleOr("p1", NAN);
  f.p2 = j.DoubleOr("p2", NAN);
  return f;
}

double Pick(double frame, double top) { return std::isnan(frame) ? top : frame; }

}  // namespace

Dataset ReadTransformsJson(const std::string& path) {
  return DatasetFromTransformsJson(ReadJsonFile(path), path, fs::path(path).parent_path().string());
}

Dataset DatasetFromTransformsJson(const Json& json, const std::string& path, const std::string& root_dir) {
  const JsonField root(json, path);
  if (!json.is_object()) root.Fail("a JSON object with \"frames\"");
  Dataset dataset;
  dataset.root = root_dir;

  const std::string model = root.StringOr("camera_model", "OPENCV");
  if (model != "OPENCV" && model != "PINHOLE" && model != "SIMPLE_PINHOLE") {
    ThrowInputError(path, "camera_model", "OPENCV or PINHOLE (fisheye models are not supported), got " + model);
  }
  if (root.Has("aabb_scale")) dataset.aabb_scale = static_cast<int>(root["aabb_scale"].Double());
  if (root.Has("scale")) dataset.ngp_scale = root["scale"].Double();
  if (root.Has("offset")) {
    const auto v = root["offset"].Doubles();
    if (v.size() != 3) root["offset"].Fail("3 numbers");
    dataset.ngp_offset = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  if (root.Has("aabb")) {
    const Eigen::MatrixXd box = root["aabb"].Matrix(2, 3);
    dataset.aabb_min = Eigen::Vector3d(box.row(0).transpose());
    dataset.aabb_max = Eigen::Vector3d(box.row(1).transpose());
    if ((dataset.aabb_max.value().array() <= dataset.aabb_min.value().array()).any()) {
      root["aabb"].Fail("[[min x, y, z], [max x, y, z]] with max > min");
    }
  }
  const std::string stem = fs::path(path).stem().string();
  const std::string default_split = stem == "transforms_test" ? "test" : stem == "transforms_val" ? "val" : "train";
  const IntrinsicFields top = ReadIntrinsicFields(root);

  const JsonField frames = root["frames"];
  const size_t n = frames.ArraySize();
  if (n == 0) frames.Fail("at least one frame");
  int cached_w = -1, cached_h = -1;  // image size read from the first image, when no w/h given
  for (size_t k = 0; k < n; ++k) {
    const JsonField jf = frames[k];
    Frame frame;
    frame.file_path = jf["file_path"].String();
    if (frame.file_path.empty()) jf["file_path"].Fail("a non-empty path");
    if (fs::path(frame.file_path).extension().empty()) frame.file_path += ".png";
    frame.name = fs::path(frame.file_path).filename().string();
    frame.split = jf.StringOr("split", default_split);
    frame.near = jf.DoubleOr("near", 0.0);
    frame.far = jf.DoubleOr("far", 0.0);

    const IntrinsicFields own = ReadIntrinsicFields(jf);
    double w = Pick(own.w, top.w), h = Pick(own.h, top.h);
    if (std::isnan(w) || std::isnan(h)) {
      if (cached_w < 0) {
        int c = 0;
        ReadImageSize(dataset.ImagePath(frame), &cached_w, &cached_h, &c);
      }
      w = cached_w;
      h = cached_h;
    }
    if (!(w >= 1 && h >= 1 && w <= 65536 && h <= 65536)) jf.Fail("image size w, h in [1, 65536]");
    Camera& cam = frame.camera;
    cam.width = static_cast<int>(w);
    cam.height = static_cast<int>(h);
    const double fl_x = Pick(own.fl_x, top.fl_x), fl_y = Pick(own.fl_y, top.fl_y);
    const double ax = Pick(own.angle_x, top.angle_x), ay = Pick(own.angle_y, top.angle_y);
    if (!std::isnan(fl_x)) {
      cam.fx = fl_x;
    } else if (!std::isnan(ax)) {
      if (!(ax > 0 && ax < M_PI)) root.Fail("camera_angle_x in (0, pi)");
      cam.fx = 0.5 * w / std::tan(0.5 * ax);
    } else {
      ThrowInputError(path, "frames[" + std::to_string(k) + "]", "intrinsics: fl_x or camera_angle_x");
    }
    if (!std::isnan(fl_y)) cam.fy = fl_y;
    else if (!std::isnan(ay) && ay > 0 && ay < M_PI) cam.fy = 0.5 * h / std::tan(0.5 * ay);
    else cam.fy = cam.fx;
    cam.cx = Pick(Pick(own.cx, top.cx), 0.5 * w);
    cam.cy = Pick(Pick(own.cy, top.cy), 0.5 * h);
    cam.k1 = Pick(own.k1, top.k1);
    cam.k2 = Pick(own.k2, top.k2);
    cam.p1 = Pick(own.p1, top.p1);
    cam.p2 = Pick(own.p2, top.p2);
    for (double* d : {&cam.k1, &cam.k2, &cam.p1, &cam.p2})
      if (std::isnan(*d)) *d = 0;

    const Eigen::Matrix4d c2w = jf["transform_matrix"].Matrix(4, 4);
    try {
      frame.cam_from_world = CamFromWorldFromOpenGL(c2w);
    } catch (const std::invalid_argument& e) {
      jf["transform_matrix"].Fail(std::string("a camera-to-world matrix with a rotation block (") + e.what() + ")");
    }
    dataset.frames.push_back(std::move(frame));
  }
  dataset.Check(path);
  return dataset;
}

Json TransformsJsonFromDataset(const Dataset& dataset) {
  Json j = Json::object();
  bool shared = !dataset.frames.empty();
  const Camera& c0 = dataset.frames.empty() ? Camera() : dataset.frames[0].camera;
  for (const auto& f : dataset.frames) {
    const Camera& c = f.camera;
    shared = shared && c.width == c0.width && c.height == c0.height && c.fx == c0.fx && c.fy == c0.fy &&
             c.cx == c0.cx && c.cy == c0.cy && c.k1 == c0.k1 && c.k2 == c0.k2 && c.p1 == c0.p1 && c.p2 == c0.p2;
  }
  auto put_camera = [](Json& out, const Camera& c) {
    out["camera_angle_x"] = c.FovX();
    out["camera_angle_y"] = c.FovY();
    out["fl_x"] = c.fx;
    out["fl_y"] = c.fy;
    out["cx"] = c.cx;
    out["cy"] = c.cy;
    out["w"] = c.width;
    out["h"] = c.height;
    out["k1"] = c.k1;
    out["k2"] = c.k2;
    out["p1"] = c.p1;
    out["p2"] = c.p2;
  };
  if (shared) put_camera(j, c0);
  if (dataset.aabb_scale) j["aabb_scale"] = *dataset.aabb_scale;
  if (dataset.ngp_scale) j["scale"] = *dataset.ngp_scale;
  if (dataset.ngp_offset) j["offset"] = {dataset.ngp_offset->x(), dataset.ngp_offset->y(), dataset.ngp_offset->z()};
  if (dataset.aabb_min && dataset.aabb_max) {
    j["aabb"] = {{dataset.aabb_min->x(), dataset.aabb_min->y(), dataset.aabb_min->z()},
                 {dataset.aabb_max->x(), dataset.aabb_max->y(), dataset.aabb_max->z()}};
  }
  Json frames = Json::array();
  for (const auto& f : dataset.frames) {
    Json jf = Json::object();
    jf["file_path"] = f.file_path;
    jf["split"] = f.split;
    jf["transform_matrix"] = MatrixToJson(OpenGLFromCamFromWorld(f.cam_from_world));
    if (!shared) put_camera(jf, f.camera);
    if (f.near > 0 || f.far > 0) {
      jf["near"] = f.near;
      jf["far"] = f.far;
    }
    frames.push_back(jf);
  }
  j["frames"] = frames;
  return j;
}

void WriteTransformsJson(const Dataset& dataset, const std::string& path) {
  WriteJsonFile(path, TransformsJsonFromDataset(dataset));
}

void CheckImagesMatchCameras(const Dataset& dataset) {
  for (const auto& f : dataset.frames) {
    int w = 0, h = 0, c = 0;
    const std::string path = dataset.ImagePath(f);
    ReadImageSize(path, &w, &h, &c);
    if (w != f.camera.width || h != f.camera.height) {
      ThrowInputError(path, "size", std::to_string(f.camera.width) + "x" + std::to_string(f.camera.height) +
                                        " as the cameras say, image is " + std::to_string(w) + "x" + std::to_string(h));
    }
  }
}

}  // namespace nerfreg
