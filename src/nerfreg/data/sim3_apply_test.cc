#include "nerfreg/data/sim3_apply.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "nerfreg/data/splat_test_util.h"
#include "nerfreg/geometry/sh_rotation.h"
#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

const Sim3d kNewFromOld(1.7, Eigen::Quaterniond(Eigen::AngleAxisd(2.2, Eigen::Vector3d(1, -0.4, 0.8).normalized())),
                        Eigen::Vector3d(0.5, -1.5, 0.9));

// Splat i's covariance from its stored rotation and log scales.
Eigen::Matrix3d Covariance(const Splats& s, std::int64_t i) {
  const Eigen::Vector4d q = s.rotation.col(i).cast<double>();
  const Eigen::Matrix3d r = Eigen::Quaterniond(q(0), q(1), q(2), q(3)).normalized().toRotationMatrix();
  return r * (2.0 * s.log_scale.col(i).cast<double>()).array().exp().matrix().asDiagonal() * r.transpose();
}

// Channel c of splat i's view-dependent colour along d (3DGS's sum, without the 0.5 offset).
double ShColour(const Splats& s, std::int64_t i, int c, const Eigen::Vector3d& d) {
  const int rest = ShCoefficientCount(s.sh_degree) - 1;
  const Eigen::VectorXd y = RealShBasis(d, s.sh_degree);
  double v = y(0) * s.f_dc(c, i);
  for (int k = 1; k <= rest; ++k) v += y(k) * s.f_rest(c * rest + k - 1, i);
  return v;
}

TEST(Sim3Apply, SplatsMoveAsAWholeAndTheInverseReturnsThemWithin1e6) {
  for (int degree = 0; degree <= 3; ++degree) {
    const Splats s = RandomSplats(300, degree, 30 + degree);
    const Splats moved = TransformSplats(s, kNewFromOld);
    const Eigen::Matrix3d r = kNewFromOld.rotation.toRotationMatrix();
    const double s2 = kNewFromOld.scale * kNewFromOld.scale;
    for (std::int64_t i = 0; i < s.size(); ++i) {
      // Each Gaussian is the old one moved: mean T mu, covariance s^2 R Sigma R^T.
      EXPECT_LT((moved.position.col(i).cast<double>() - kNewFromOld * Eigen::Vector3d(s.position.col(i).cast<double>()))
                    .norm(),
                1e-5);
      const Eigen::Matrix3d expected = s2 * r * Covariance(s, i) * r.transpose();
      EXPECT_LT((Covariance(moved, i) - expected).norm(), 1e-5 * std::max(1e-3, expected.norm()));
      EXPECT_NEAR(moved.rotation.col(i).norm(), s.rotation.col(i).norm(), 1e-5);
      EXPECT_LT((moved.normal.col(i).cast<double>() - r * s.normal.col(i).cast<double>()).norm(), 1e-5);
      // Seen along R d, the moved splat shows the colour the old one showed along d (brute force).
      const Eigen::Vector3d d = Eigen::Vector3d(std::sin(i), std::cos(3.0 * i), 0.3).normalized();
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(ShColour(moved, i, c, r * d), ShColour(s, i, c, d), 1e-5);
    }
    EXPECT_EQ(moved.opacity, s.opacity);
    EXPECT_EQ(moved.f_dc, s.f_dc);
    EXPECT_EQ(moved.extras[0].values, s.extras[0].values);
    // T then T^-1: every field back within 1e-6 (SH included).
    const Splats back = TransformSplats(moved, kNewFromOld.Inverse());
    EXPECT_LT((back.position - s.position).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((back.normal - s.normal).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((back.log_scale - s.log_scale).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LT((back.rotation - s.rotation).cwiseAbs().maxCoeff(), 1e-6);
    if (degree > 0) {
      EXPECT_LT((back.f_rest - s.f_rest).cwiseAbs().maxCoeff(), 1e-6);
      EXPECT_GT((moved.f_rest - s.f_rest).cwiseAbs().maxCoeff(), 1e-2);  // they did turn
    }
  }
}

Json TestTransformsJson() {
  return ParseJson(R"({
    "camera_model": "OPENCV", "fl_x": 100, "fl_y": 100, "cx": 50, "cy": 40, "w": 100, "h": 80,
    "aabb_scale": 4, "scale": 0.5, "offset": [0.5, 0.4, 0.6], "my_key": "kept",
    "applied_transform": [[0, 1, 0, 0.1], [1, 0, 0, 0.2], [0, 0, -1, 0.3]],
    "aabb": [[-1, -1, -1], [1, 1, 1]],
    "frames": [
      {"file_path": "images/a.png", "near": 0.5, "far": 6,
       "transform_matrix": [[1, 0, 0, 1], [0, 0, -1, -3], [0, 1, 0, 0.5], [0, 0, 0, 1]]},
      {"file_path": "images/b.png", "fl_x": 90,
       "transform_matrix": [[0, 0, 1, 3], [1, 0, 0, 0.2], [0, 1, 0, -0.5], [0, 0, 0, 1]]}]})",
                   "t.json");
}

TEST(Sim3Apply, TransformsJsonMovesCamerasKeepsTheRestAndRoundTrips) {
  const Json in = TestTransformsJson();
  const Json moved = TransformTransformsJson(in, kNewFromOld, "t.json");
  // The camera centre moved by the Sim(3), its axes by R (not scaled), the bounds scaled.
  const Eigen::Matrix4d m0 = JsonField(in, "t.json")["frames"][0]["transform_matrix"].Matrix(4, 4);
  const Eigen::Matrix4d n0 = JsonField(moved, "t.json")["frames"][0]["transform_matrix"].Matrix(4, 4);
  EXPECT_LT((n0.block<3, 1>(0, 3) - kNewFromOld * Eigen::Vector3d(m0.block<3, 1>(0, 3))).norm(), 1e-12);
  EXPECT_LT((n0.topLeftCorner<3, 3>() - kNewFromOld.rotation.toRotationMatrix() * m0.topLeftCorner<3, 3>()).norm(),
            1e-12);
  EXPECT_NEAR(moved["frames"][0]["far"].get<double>(), 6 * kNewFromOld.scale, 1e-12);
  EXPECT_EQ(moved["my_key"], "kept");
  EXPECT_EQ(moved["frames"][1]["fl_x"], 90);
  // ngp's cube holds the same scene point at its centre.
  const Eigen::Vector3d c_old = (Eigen::Vector3d::Constant(0.5) - Eigen::Vector3d(0.5, 0.4, 0.6)) / 0.5;
  const double new_scale = moved["scale"].get<double>();
  const auto off = moved["offset"].get<std::vector<double>>();
  const Eigen::Vector3d c_new = (Eigen::Vector3d::Constant(0.5) - Eigen::Vector3d(off[0], off[1], off[2])) / new_scale;
  EXPECT_LT((c_new - kNewFromOld * c_old).norm(), 1e-12);
  // T then T^-1: every number back within 1e-6, except our aabb, which may only grow.
  Json back = TransformTransformsJson(moved, kNewFromOld.Inverse(), "t.json");
  const Eigen::MatrixXd box = JsonField(back, "t.json")["aabb"].Matrix(2, 3);
  EXPECT_TRUE((box.row(0).array() <= -1 + 1e-9).all() && (box.row(1).array() >= 1 - 1e-9).all());
  back["aabb"] = in["aabb"];
  const Json diff = Json::diff(in, back);
  for (const Json& op : diff) {
    ASSERT_EQ(op["op"], "replace") << op.dump();
    const std::string path = op["path"];
    EXPECT_NEAR(op["value"].get<double>(), in.at(Json::json_pointer(path)).get<double>(), 1e-6) << path;
  }
}

TEST(Sim3Apply, ColmapLlffAndDataparserRoundTrip) {
  ColmapModel model;
  ColmapImage image;
  image.image_id = 1;
  image.cam_from_world =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY())), Eigen::Vector3d(1, 2, 3));
  model.images[1] = image;
  ColmapPoint3D point;
  point.point3d_id = 7;
  point.xyz = Eigen::Vector3d(0.2, -0.4, 1.1);
  model.points3d[7] = point;
  const ColmapModel moved = TransformColmapModel(model, kNewFromOld);
  // A point seen at camera coordinates x is, after the move, at s x: the same pixel.
  const Eigen::Vector3d x_old = image.cam_from_world * point.xyz;
  const Eigen::Vector3d x_new = moved.images.at(1).cam_from_world * moved.points3d.at(7).xyz;
  EXPECT_LT((x_new - kNewFromOld.scale * x_old).norm(), 1e-12);
  const ColmapModel back = TransformColmapModel(moved, kNewFromOld.Inverse());
  EXPECT_LT((back.images.at(1).cam_from_world.ToMatrix() - image.cam_from_world.ToMatrix()).norm(), 1e-12);
  EXPECT_LT((back.points3d.at(7).xyz - point.xyz).norm(), 1e-12);

  NpyArray llff;
  llff.shape = {2, 17};
  for (int i = 0; i < 34; ++i) llff.data.push_back(std::sin(1.0 + i));
  const Eigen::Matrix3d r0 = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) llff.data[row * 5 + col] = r0(row, col);
  const NpyArray llff_moved = TransformLlffPoses(llff, kNewFromOld, "p.npy");
  EXPECT_NEAR(llff_moved.data[16], llff.data[16] * kNewFromOld.scale, 1e-12);
  EXPECT_EQ(llff_moved.data[4], llff.data[4]);  // hwf kept
  const NpyArray llff_back = TransformLlffPoses(llff_moved, kNewFromOld.Inverse(), "p.npy");
  for (size_t k = 0; k < llff.data.size(); ++k) EXPECT_NEAR(llff_back.data[k], llff.data[k], 1e-12);
  NpyArray bad;
  bad.shape = {2, 15};
  bad.data.assign(30, 0.0);
  EXPECT_THROW(TransformLlffPoses(bad, kNewFromOld, "p.npy"), InputError);

  // The trained model's frame stays put: a point there is the same whichever file frame maps into it.
  const Sim3d trained_from_old(0.8, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ())),
                               Eigen::Vector3d(1, 0, 0));
  const Sim3d trained_from_new = TransformDataparser(trained_from_old, kNewFromOld);
  const Eigen::Vector3d p(0.3, 0.2, -0.7);
  EXPECT_LT((trained_from_new * (kNewFromOld * p) - trained_from_old * p).norm(), 1e-12);
}

}  // namespace
}  // namespace nerfreg
