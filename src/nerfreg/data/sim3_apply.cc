#include "nerfreg/data/sim3_apply.h"

#include <Eigen/Geometry>
#include <cmath>

#include "nerfreg/geometry/sh_rotation.h"
#include "nerfreg/util/error.h"

namespace nerfreg {

Splats TransformSplats(const Splats& splats, const Sim3d& new_from_old) {
  splats.CheckShapes();
  Splats out = splats;
  const Eigen::Matrix3d r = new_from_old.rotation.toRotationMatrix();
  const double log_s = std::log(new_from_old.scale);
  const int rest = ShCoefficientCount(splats.sh_degree) - 1;  // per channel
  const Eigen::MatrixXd sh = ShRotationMatrix(r, splats.sh_degree).bottomRightCorner(rest, rest);
  for (std::int64_t i = 0; i < splats.size(); ++i) {
    out.position.col(i) = (new_from_old * Eigen::Vector3d(splats.position.col(i).cast<double>())).cast<float>();
    if (splats.has_normals()) out.normal.col(i) = (r * splats.normal.col(i).cast<double>()).cast<float>();
    out.log_scale.col(i) = (splats.log_scale.col(i).cast<double>().array() + log_s).cast<float>();
    const Eigen::Vector4d q = splats.rotation.col(i).cast<double>();
    const Eigen::Quaterniond moved = new_from_old.rotation * Eigen::Quaterniond(q(0), q(1), q(2), q(3));
    out.rotation.col(i) = Eigen::Vector4d(moved.w(), moved.x(), moved.y(), moved.z()).cast<float>();
    for (int c = 0; c < 3 && rest > 0; ++c) {
      out.f_rest.col(i).segment(c * rest, rest) =
          (sh * splats.f_rest.col(i).segment(c * rest, rest).cast<double>()).cast<float>();
    }
  }
  return out;
}

namespace {

// The box around a box moved by a Sim(3).
void MoveBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Sim3d& new_from_old, Eigen::Vector3d* new_lo,
             Eigen::Vector3d* new_hi) {
  Eigen::AlignedBox3d moved;
  const Eigen::AlignedBox3d box(lo, hi);
  for (int k = 0; k < 8; ++k) moved.extend(new_from_old * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)));
  *new_lo = moved.min();
  *new_hi = moved.max();
}

Eigen::Vector3d Vector3(const JsonField& f) {
  const std::vector<double> v = f.Doubles();
  if (v.size() != 3) f.Fail("3 numbers");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

Json VectorJson(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

}  // namespace

Json TransformTransformsJson(const Json& json, const Sim3d& new_from_old, const std::string& source) {
  const JsonField root(json, source);
  if (!json.is_object()) root.Fail("a JSON object with \"frames\"");
  const JsonField frames = root["frames"];
  const Eigen::Matrix3d r = new_from_old.rotation.toRotationMatrix();
  const double s = new_from_old.scale;
  Json out = json;
  for (size_t i = 0; i < frames.ArraySize(); ++i) {
    const JsonField frame = frames[i];
    // Camera-to-world with any axis convention: the world moves, the camera's axes turn with it.
    Eigen::Matrix4d m = frame["transform_matrix"].Matrix(4, 4);
    const Eigen::Vector3d centre = m.block<3, 1>(0, 3);
    m.topLeftCorner<3, 3>() = r * m.topLeftCorner<3, 3>();
    m.block<3, 1>(0, 3) = new_from_old * centre;
    Json& f = out["frames"][i];
    f["transform_matrix"] = MatrixToJson(m);
    for (const char* bound : {"near", "far"}) {
      if (frame.Has(bound)) f[bound] = frame[bound].Double() * s;
    }
  }
  if (root.Has("aabb")) {
    const Eigen::MatrixXd box = root["aabb"].Matrix(2, 3);
    Eigen::Vector3d lo, hi;
    MoveBox(box.row(0).transpose(), box.row(1).transpose(), new_from_old, &lo, &hi);
    out["aabb"] = Json::array({VectorJson(lo), VectorJson(hi)});
  }
  if (root.Has("scale") || root.Has("offset")) {
    // instant-ngp: p_ngp = scale p + offset (before its axis cycle); its cube's centre 0.5 is the
    // scene point c = (0.5 - offset) / scale, which moves to T c.
    const double scale = root.DoubleOr("scale", 0.33);
    if (!(scale > 0)) root["scale"].Fail("a positive number");
    const Eigen::Vector3d offset = root.Has("offset") ? Vector3(root["offset"]) : Eigen::Vector3d::Constant(0.5);
    const Eigen::Vector3d centre = (Eigen::Vector3d::Constant(0.5) - offset) / scale;
    const double new_scale = scale / s;
    out["scale"] = new_scale;
    out["offset"] = VectorJson(Eigen::Vector3d::Constant(0.5) - new_scale * (new_from_old * centre));
  }
  if (root.Has("applied_transform")) {
    const JsonField a = root["applied_transform"];
    const bool four = a.ArraySize() == 4;
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topRows(four ? 4 : 3) = a.Matrix(four ? 4 : 3, 4);
    const Eigen::Matrix4d moved = new_from_old.ToMatrix() * m;
    out["applied_transform"] = MatrixToJson(four ? Eigen::MatrixXd(moved) : Eigen::MatrixXd(moved.topRows(3)));
  }
  return out;
}

Sim3d TransformDataparser(const Sim3d& trained_from_old, const Sim3d& new_from_old) {
  return trained_from_old * new_from_old.Inverse();
}

void MoveCameras(Dataset* cameras, const Sim3d& new_from_old) {
  Dataset& cams = *cameras;
  for (Frame& f : cams.frames) {
    f.cam_from_world = new_from_old.TransformCamera(f.cam_from_world);
    f.near *= new_from_old.scale;
    f.far *= new_from_old.scale;
  }
  if (cams.aabb_min && cams.aabb_max) {
    Eigen::AlignedBox3d moved;
    const Eigen::AlignedBox3d box(*cams.aabb_min, *cams.aabb_max);
    for (int k = 0; k < 8; ++k)
      moved.extend(new_from_old * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)));
    cams.aabb_min = moved.min();
    cams.aabb_max = moved.max();
  }
  if (cams.applied_transform) {
    Eigen::Matrix4d a = Eigen::Matrix4d::Identity();
    a.topRows(3) = *cams.applied_transform;
    cams.applied_transform = (new_from_old.ToMatrix() * a).topRows(3);
  }
  if (cams.trained_from_data) cams.trained_from_data = *cams.trained_from_data * new_from_old.Inverse();
}

ColmapModel TransformColmapModel(const ColmapModel& model, const Sim3d& new_from_old) {
  ColmapModel out = model;
  for (auto& [id, image] : out.images) image.cam_from_world = new_from_old.TransformCamera(image.cam_from_world);
  for (auto& [id, point] : out.points3d) point.xyz = new_from_old * point.xyz;
  return out;
}

NpyArray TransformLlffPoses(const NpyArray& poses_bounds, const Sim3d& new_from_old, const std::string& source) {
  if (poses_bounds.shape.size() != 2 || poses_bounds.shape[1] != 17) {
    ThrowInputError(source, "shape", "(N, 17): a 3x5 pose and near, far per image");
  }
  const Eigen::Matrix3d r = new_from_old.rotation.toRotationMatrix();
  NpyArray out = poses_bounds;
  for (std::int64_t i = 0; i < poses_bounds.shape[0]; ++i) {
    // Row-major 3x5: [R | centre | hwf].
    Eigen::Map<Eigen::Matrix<double, 3, 5, Eigen::RowMajor>> pose(out.data.data() + 17 * i);
    pose.leftCols<3>() = (r * pose.leftCols<3>()).eval();
    pose.col(3) = new_from_old * Eigen::Vector3d(pose.col(3));
    out.data[17 * i + 15] *= new_from_old.scale;
    out.data[17 * i + 16] *= new_from_old.scale;
  }
  return out;
}

}  // namespace nerfreg
