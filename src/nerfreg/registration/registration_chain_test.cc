#include "nerfreg/registration/registration_chain.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace nerfreg {
namespace {

// An asymmetric object as a smooth density (two ellipsoids and a box; sigma = 60 *
// sigmoid(-d / 0.02), a surface ~0.05 thick like a trained block's), seen at `scale` in a frame
// where it sits at frame_from_shape: densities per unit length / scale (the same optical depth).
double ObjectDistance(const Eigen::Vector3d& x) {
  const double e1 = ((x - Eigen::Vector3d(0.3, 0.0, 0.1)).cwiseQuotient(Eigen::Vector3d(0.5, 0.3, 0.25))).norm() - 1;
  const double e2 = ((x - Eigen::Vector3d(-0.4, 0.35, -0.1)).cwiseQuotient(Eigen::Vector3d(0.2, 0.45, 0.2))).norm() - 1;
  const Eigen::Vector3d q = (x - Eigen::Vector3d(-0.1, -0.4, 0.3)).cwiseAbs() - Eigen::Vector3d(0.3, 0.12, 0.2);
  const double box = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  return std::min({e1 * 0.25, e2 * 0.2, box});
}

// `mirrored`: the object's mirror image (x -> -x in its own frame), which no similarity aligns
// with it.
DensityField ObjectField(const Sim3d& frame_from_shape, bool mirrored = false) {
  DensityField f;
  const Sim3d shape_from_frame = frame_from_shape.Inverse();
  const double scale = frame_from_shape.scale;
  const Eigen::Vector3d flip(mirrored ? -1 : 1, 1, 1);
  f.density = [shape_from_frame, scale, flip](const torch::Tensor& x) {
    const torch::Tensor c = x.to(torch::kDouble).contiguous();
    torch::Tensor out = torch::empty({c.size(0)}, torch::kFloat);
    const double* p = c.data_ptr<double>();
    float* o = out.data_ptr<float>();
    for (int64_t i = 0; i < c.size(0); ++i) {
      const double d =
          ObjectDistance(flip.cwiseProduct(shape_from_frame * Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2])));
      o[i] = static_cast<float>(60.0 / (1.0 + std::exp(d / 0.02)) / scale);
    }
    return out;
  };
  f.box = Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-5), Eigen::Vector3d::Constant(5));
  return f;
}

// Points within half a cell of the surface on a cubic lattice (what a grid's mask gives), in the
// frame.
Eigen::Matrix3Xd ObjectSurface(const Sim3d& frame_from_shape, double cell, bool mirrored = false) {
  const Eigen::Vector3d flip(mirrored ? -1 : 1, 1, 1);
  std::vector<Eigen::Vector3d> pts;
  for (double x = -1; x <= 1; x += cell)
    for (double y = -1; y <= 1; y += cell)
      for (double z = -1; z <= 1; z += cell) {
        const Eigen::Vector3d p(x, y, z);
        if (std::abs(ObjectDistance(p)) < 0.5 * cell)
          pts.push_back(frame_from_shape * Eigen::Vector3d(flip.cwiseProduct(p)));
      }
  Eigen::Matrix3Xd m(3, pts.size());
  for (size_t i = 0; i < pts.size(); ++i) m.col(i) = pts[i];
  return m;
}

// The truth turned by `deg` about `axis`, shifted, at `scale`.
Sim3d TurnedFrom(const Sim3d& truth, double deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& shift,
                 double scale) {
  const Eigen::Quaterniond d(Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()));
  return Sim3d(scale, d * truth.rotation, d * truth.translation + shift);
}

// The scale rule on the fields: the target is the object at 1.3 x, the start (as the point stages
// leave it) 14 % small and 2 deg off. The fields' refinement corrects the scale, its cost falls,
// and refined again it stays: kept, though it moved more than kMaxFieldScaleChange (which refused
// it before).
TEST(RegistrationChain, FieldRefinementKeepsAFarScaleOnItsOwnEvidence) {
  torch::set_num_threads(2);
  const Sim3d src_from_shape(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                             Eigen::Vector3d(0.2, -0.1, 0.3));
  const Sim3d tgt_from_shape(1.3, Eigen::Quaterniond(Eigen::AngleAxisd(-1.9, Eigen::Vector3d(-2, 1, 0.5).normalized())),
                             Eigen::Vector3d(-0.3, 0.25, 0.1));
  const Sim3d truth = tgt_from_shape * src_from_shape.Inverse();
  const double cell = 0.08;
  const DensityField src = ObjectField(src_from_shape), tgt = ObjectField(tgt_from_shape);
  const Eigen::Matrix3Xd ps = ObjectSurface(src_from_shape, cell), pt = ObjectSurface(tgt_from_shape, cell);
  FieldAlignmentOptions o;
  o.max_samples = 3000;
  o.estimate_scale = true;
  const Sim3d start = TurnedFrom(truth, 2.0, Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(0.02, 0, -0.01), 1.3 / 1.16);
  Json json;
  const Sim3d r = RefineOnFields(src, tgt, ps, pt, start, o, cell, &json);
  std::printf("[scale rule] %s\n", json["scale_check"].dump().c_str());
  EXPECT_GT(std::abs(std::log(json["scale"].get<double>() / start.scale)), std::log(kMaxFieldScaleChange));
  EXPECT_TRUE(json["scale_check"]["accepted"].get<bool>());
  EXPECT_FALSE(json.contains("rejected"));
  EXPECT_NEAR(r.scale / truth.scale, 1.0, 0.01);
  EXPECT_LT(RotationErrorDeg(r.rotation, truth.rotation), 0.3);

  // The target the object's mirror image, which no similarity aligns: the refinement moves the
  // scale 12 % and its cost falls by 40 %, but refined again the pose turns on by 10 deg: a slide,
  // not where the fields agree. The start is returned.
  Json wrong;
  const Sim3d w = RefineOnFields(src, ObjectField(tgt_from_shape, true), ps, ObjectSurface(tgt_from_shape, cell, true),
                                 start, o, cell, &wrong);
  std::printf("[scale rule, mirror image] %s\n", wrong["scale_check"].dump().c_str());
  ASSERT_TRUE(wrong.contains("scale_check"));
  EXPECT_FALSE(wrong["scale_check"]["accepted"].get<bool>());
  EXPECT_TRUE(wrong["rejected"].get<bool>());
  EXPECT_EQ(w.scale, start.scale);
  EXPECT_EQ(w.translation, start.translation);
}

FieldAlignmentResult AlignResult(double scale, double initial_cost, double final_cost, double turn_deg = 0) {
  FieldAlignmentResult f;
  f.scale = scale;
  f.initial_cost = initial_cost;
  f.final_cost = final_cost;
  f.iterations = 12;
  f.target_from_source.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(turn_deg * M_PI / 180, Eigen::Vector3d::UnitZ()));
  return f;
}

// The rule itself: a scale within kMaxFieldScaleChange is kept as before; a farther one needs the
// cost to fall by kMinFieldCostDrop and a second refinement that stays put.
TEST(RegistrationChain, AFarFieldScaleNeedsALowerCostAndASecondRefinementThatStays) {
  const FieldAlignmentResult none;  // the second refinement did not run
  EXPECT_TRUE(AcceptFieldScaleChange(1.0, AlignResult(1.08, 0.2, 0.2), none));
  const FieldAlignmentResult far = AlignResult(1.25, 0.2, 0.15);
  EXPECT_TRUE(AcceptFieldScaleChange(1.0, far, AlignResult(1.255, 0.15, 0.149, 0.1)));
  EXPECT_TRUE(AcceptFieldScaleChange(1.0, AlignResult(0.8, 0.2, 0.15), AlignResult(0.801, 0.15, 0.149)));
  // A first refinement stopped short of the optimum goes on turning a little: still settled.
  EXPECT_TRUE(AcceptFieldScaleChange(1.0, far, AlignResult(1.255, 0.15, 0.149, 0.8)));
  // The cost did not fall enough: the evidence does not improve.
  EXPECT_FALSE(AcceptFieldScaleChange(1.0, AlignResult(1.25, 0.2, 0.19), AlignResult(1.25, 0.19, 0.19)));
  EXPECT_FALSE(AcceptFieldScaleChange(1.0, AlignResult(1.25, 0.2, 0.25), AlignResult(1.25, 0.25, 0.25)));
  // AlignResult again, the scale or the rotation keeps moving: a slide, not a settled optimum.
  EXPECT_FALSE(AcceptFieldScaleChange(1.0, far, AlignResult(1.35, 0.15, 0.12)));
  EXPECT_FALSE(AcceptFieldScaleChange(1.0, far, AlignResult(1.25, 0.15, 0.14, 3.0)));
  EXPECT_FALSE(AcceptFieldScaleChange(1.0, far, none));
}

}  // namespace
}  // namespace nerfreg
