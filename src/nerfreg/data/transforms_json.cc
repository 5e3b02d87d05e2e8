#include "nerfreg/data/transforms_json.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <set>

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
  double k1 = NAN, k2 = NAN, p1 = NAN, p2 = NAN, k3 = NAN, k4 = NAN;
  std::string model;  // camera_model; "" = absent
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
  f.k3 = j.DoubleOr("k3", NAN);
  f.k4 = j.DoubleOr("k4", NAN);
  f.model = j.StringOr("camera_model", "");
  if (!f.model.empty() && f.model != "OPENCV" && f.model != "PINHOLE" && f.model != "SIMPLE_PINHOLE" &&
      f.model != "OPENCV_FISHEYE") {
    j["camera_model"].Fail("PINHOLE, OPENCV or OPENCV_FISHEYE, got " + f.model);
  }
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

  if (root.Has("applied_transform")) {
    // ns-process-data writes [3, 4]; a homogeneous [4, 4] is accepted too.
    const JsonField a = root["applied_transform"];
    const bool rows4 = a.json().is_array() && a.json().size() == 4;
    const Eigen::MatrixXd m = a.Matrix(rows4 ? 4 : 3, 4);
    if (rows4 && !m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
      a.Fail("a [3, 4] matrix (or [4, 4] ending 0 0 0 1)");
    dataset.applied_transform = m.topRows(3);
  }
  const std::string dataparser = JoinPaths(root_dir.empty() ? "." : root_dir, "dataparser_transforms.json");
  if (FileExists(dataparser)) dataset.trained_from_data = ReadDataparserTransforms(dataparser);
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

  // nerfstudio's split lists (train_filenames, ...) name frames by their file_path.
  std::map<std::string, std::string> split_of;
  for (const char* split : {"train", "val", "test"}) {
    const std::string key = std::string(split) + "_filenames";
    if (!root.Has(key)) continue;
    const JsonField list = root[key];
    for (size_t i = 0; i < list.ArraySize(); ++i) split_of[list[i].String()] = split;
  }
  const JsonField frames = root["frames"];
  const size_t n = frames.ArraySize();
  if (n == 0) frames.Fail("at least one frame");
  int cached_w = -1, cached_h = -1;  // image size read from the first image, when no w/h given
  for (size_t k = 0; k < n; ++k) {
    const JsonField jf = frames[k];
    Frame frame;
    frame.file_path = jf["file_path"].String();
    if (frame.file_path.empty()) jf["file_path"].Fail("a non-empty path");
    const auto listed = split_of.find(frame.file_path);
    if (fs::path(frame.file_path).extension().empty()) frame.file_path += ".png";
    frame.name = fs::path(frame.file_path).filename().string();
    frame.split = jf.StringOr("split", listed == split_of.end() ? default_split : listed->second);
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
    if (!std::isnan(fl_y))
      cam.fy = fl_y;
    else if (!std::isnan(ay) && ay > 0 && ay < M_PI)
      cam.fy = 0.5 * h / std::tan(0.5 * ay);
    else
      cam.fy = cam.fx;
    cam.cx = Pick(Pick(own.cx, top.cx), 0.5 * w);
    cam.cy = Pick(Pick(own.cy, top.cy), 0.5 * h);
    const std::string model = own.model.empty() ? top.model : own.model;
    if (model == "PINHOLE" || model == "SIMPLE_PINHOLE") {
      // nerfstudio ignores distortion fields of a pinhole camera; so do we.
    } else {
      cam.k1 = Pick(own.k1, top.k1);
      cam.k2 = Pick(own.k2, top.k2);
      cam.k3 = Pick(own.k3, top.k3);
      cam.k4 = Pick(own.k4, top.k4);
      if (model == "OPENCV_FISHEYE") {
        cam.model = CameraModel::kOpenCVFisheye;
      } else {
        cam.p1 = Pick(own.p1, top.p1);
        cam.p2 = Pick(own.p2, top.p2);
      }
      for (double* d : {&cam.k1, &cam.k2, &cam.p1, &cam.p2, &cam.k3, &cam.k4})
        if (std::isnan(*d)) *d = 0;
    }

    const Eigen::Matrix4d c2w = jf["transform_matrix"].Matrix(4, 4);
    try {
      frame.cam_from_world = CamFromWorldFromOpenGL(c2w);
    } catch (const std::invalid_argument& e) {
      jf["transform_matrix"].Fail(std::string("a camera-to-world matrix with a rotation block (") + e.what() + ")");
    }
    dataset.frames.push_back(std::move(frame));
  }
  // Images of several captures in one file (reg register-many --merged-cameras, or a user's merge)
  // share file names (frame_00001.jpg in each folder): then every frame is named by its path.
  std::set<std::string> file_names;
  bool repeated = false;
  for (const Frame& f : dataset.frames) repeated = repeated || !file_names.insert(f.name).second;
  if (repeated) {
    for (Frame& f : dataset.frames) f.name = fs::path(f.file_path).lexically_normal().generic_string();
  }
  dataset.Check(path);
  return dataset;
}

namespace {

bool SameCamera(const Camera& a, const Camera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy &&
         a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3 && a.k4 == b.k4 &&
         a.model == b.model;
}

std::string NerfstudioModel(const Camera& c) {
  return c.model == CameraModel::kOpenCVFisheye ? "OPENCV_FISHEYE" : c.HasDistortion() ? "OPENCV" : "PINHOLE";
}

}  // namespace

Json TransformsJsonFromDataset(const Dataset& dataset, TransformsJsonFlavour flavour) {
  const bool ns = flavour == TransformsJsonFlavour::kNerfstudio;
  Json j = Json::object();
  bool shared = !dataset.frames.empty();
  const Camera& c0 = dataset.frames.empty() ? Camera() : dataset.frames[0].camera;
  for (const auto& f : dataset.frames) shared = shared && SameCamera(f.camera, c0);
  auto put_camera = [ns](Json& out, const Camera& c) {
    out["camera_model"] = NerfstudioModel(c);
    if (!ns) {  // NeRF-synthetic readers need the angles
      out["camera_angle_x"] = c.FovX();
      out["camera_angle_y"] = c.FovY();
    }
    out["fl_x"] = c.fx;
    out["fl_y"] = c.fy;
    out["cx"] = c.cx;
    out["cy"] = c.cy;
    out["w"] = c.width;
    out["h"] = c.height;
    out["k1"] = c.k1;
    out["k2"] = c.k2;
    if (c.model != CameraModel::kOpenCVFisheye) {
      out["p1"] = c.p1;
      out["p2"] = c.p2;
    }
    if (c.k3 != 0 || c.k4 != 0 || c.model == CameraModel::kOpenCVFisheye) {
      out["k3"] = c.k3;
      out["k4"] = c.k4;
    }
  };
  if (shared) put_camera(j, c0);
  if (dataset.aabb_scale) j["aabb_scale"] = *dataset.aabb_scale;
  if (dataset.ngp_scale) j["scale"] = *dataset.ngp_scale;
  if (dataset.ngp_offset) j["offset"] = {dataset.ngp_offset->x(), dataset.ngp_offset->y(), dataset.ngp_offset->z()};
  if (dataset.aabb_min && dataset.aabb_max) {
    j["aabb"] = {{dataset.aabb_min->x(), dataset.aabb_min->y(), dataset.aabb_min->z()},
                 {dataset.aabb_max->x(), dataset.aabb_max->y(), dataset.aabb_max->z()}};
  }
  if (dataset.applied_transform) j["applied_transform"] = MatrixToJson(*dataset.applied_transform);
  Json frames = Json::array();
  Json split_names = Json::object();
  for (const auto& f : dataset.frames) {
    Json jf = Json::object();
    jf["file_path"] = f.file_path;
    if (!ns) jf["split"] = f.split;
    jf["transform_matrix"] = MatrixToJson(OpenGLFromCamFromWorld(f.cam_from_world));
    if (!shared) put_camera(jf, f.camera);
    if (f.near > 0 || f.far > 0) {
      jf["near"] = f.near;
      jf["far"] = f.far;
    }
    frames.push_back(jf);
    split_names[f.split + "_filenames"].push_back(f.file_path);
  }
  j["frames"] = frames;
  // nerfstudio's own split lists, written only when the frames are not all for training.
  if (ns && (split_names.size() > 1 || !split_names.contains("train_filenames"))) j.update(split_names);
  return j;
}

void WriteTransformsJson(const Dataset& dataset, const std::string& path, TransformsJsonFlavour flavour) {
  WriteJsonFile(path, TransformsJsonFromDataset(dataset, flavour));
}

Sim3d ReadDataparserTransforms(const std::string& path) {
  const Json json = ReadJsonFile(path);
  const JsonField root(json, path);
  if (!json.is_object()) root.Fail("an object with \"transform\" and \"scale\"");
  const JsonField t = root["transform"];
  const bool rows4 = t.json().is_array() && t.json().size() == 4;
  const Eigen::MatrixXd m = t.Matrix(rows4 ? 4 : 3, 4);
  const double scale = root["scale"].Double();
  if (!(scale > 0) || !std::isfinite(scale)) root["scale"].Fail("a positive number");
  Eigen::Matrix4d h = Eigen::Matrix4d::Identity();
  h.topRows(3) = m.topRows(3);
  Sim3d rigid;
  try {
    rigid = Sim3d::FromMatrix(h, 1e-4);
  } catch (const std::invalid_argument& e) {
    t.Fail(std::string("a rotation and a translation [3, 4] (") + e.what() + ")");
  }
  if (std::abs(rigid.scale - 1) > 1e-4) t.Fail("a rotation and a translation [3, 4] (the scale is \"scale\")");
  // p_trained = scale * (R p + t).
  return Sim3d(scale, rigid.rotation, scale * rigid.translation);
}

void WriteDataparserTransforms(const Sim3d& trained_from_data, const std::string& path) {
  const Eigen::Matrix4d m =
      Sim3d(1.0, trained_from_data.rotation, trained_from_data.translation / trained_from_data.scale).ToMatrix();
  WriteJsonFile(path, Json{{"transform", MatrixToJson(m.topRows(3))}, {"scale", trained_from_data.scale}});
}

void CheckImagesMatchCameras(const Dataset& dataset) {
  for (const auto& f : dataset.frames) {
    int w = 0, h = 0, c = 0;
    const std::string path = dataset.ImagePath(f);
    ReadImageSize(path, &w, &h, &c);
    if (w != f.camera.width || h != f.camera.height) {
      ThrowInputError(path, "size",
                      std::to_string(f.camera.width) + "x" + std::to_string(f.camera.height) +
                          " as the cameras say, image is " + std::to_string(w) + "x" + std::to_string(h));
    }
  }
}

}  // namespace nerfreg
