#include "nerfreg/reg/field_alignment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

// An asymmetric object as a smooth density: two ellipsoids and a box (signed distances, min),
// sigma = 60 * sigmoid(-d / 0.02), i.e. a surface ~0.05 thick like a trained block's.
double ShapeDistance(const Eigen::Vector3d& x) {
  const double e1 = ((x - Eigen::Vector3d(0.3, 0.0, 0.1)).cwiseQuotient(Eigen::Vector3d(0.5, 0.3, 0.25))).norm() - 1;
  const double e2 = ((x - Eigen::Vector3d(-0.4, 0.35, -0.1)).cwiseQuotient(Eigen::Vector3d(0.2, 0.45, 0.2))).norm() - 1;
  const Eigen::Vector3d q = (x - Eigen::Vector3d(-0.1, -0.4, 0.3)).cwiseAbs() - Eigen::Vector3d(0.3, 0.12, 0.2);
  const double box = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  return std::min({e1 * 0.25, e2 * 0.2, box});
}

// The object seen in a frame where it sits at shape_to_frame (x_frame = shape_to_frame * x_shape).
DensityField ShapeField(const Rigid3d& frame_from_shape, const Eigen::AlignedBox3d& box) {
  DensityField f;
  const Rigid3d shape_from_frame = frame_from_shape.Inverse();
  f.density = [shape_from_frame](const torch::Tensor& x) {
    const torch::Tensor c = x.to(torch::kDouble).contiguous();
    torch::Tensor out = torch::empty({c.size(0)}, torch::kFloat);
    const double* p = c.data_ptr<double>();
    for (int64_t i = 0; i < c.size(0); ++i) {
      const double d = ShapeDistance(shape_from_frame * Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
      out[i] = static_cast<float>(60.0 / (1.0 + std::exp(d / 0.02)));
    }
    return out;
  };
  f.box = box;
  return f;
}

// Points within half a cell of the surface on a cubic lattice (what a grid's mask gives).
Eigen::Matrix3Xd SurfacePoints(const Rigid3d& frame_from_shape, double cell) {
  std::vector<Eigen::Vector3d> pts;
  for (double x = -1; x <= 1; x += cell)
    for (double y = -1; y <= 1; y += cell)
      for (double z = -1; z <= 1; z += cell) {
        const Eigen::Vector3d p(x, y, z);
        if (std::abs(ShapeDistance(p)) < 0.5 * cell) pts.push_back(frame_from_shape * p);
      }
  Eigen::Matrix3Xd m(3, pts.size());
  for (size_t i = 0; i < pts.size(); ++i) m.col(i) = pts[i];
  return m;
}

const Eigen::AlignedBox3d kBigBox(Eigen::Vector3d::Constant(-3), Eigen::Vector3d::Constant(3));

Rigid3d Perturb(const Rigid3d& t, double deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& shift) {
  const Eigen::Quaterniond d(Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()));
  return Rigid3d(d * t.rotation, d * t.translation + shift);
}

TEST(FieldAlignment, RecoversAKnownTransformFromAFewDegreesOff) {
  const Rigid3d src_from_shape(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                               Eigen::Vector3d(0.2, -0.1, 0.3));
  const Rigid3d tgt_from_shape(Eigen::Quaterniond(Eigen::AngleAxisd(-1.9, Eigen::Vector3d(-2, 1, 0.5).normalized())),
                               Eigen::Vector3d(-0.3, 0.25, 0.1));
  const Rigid3d truth = tgt_from_shape * src_from_shape.Inverse();
  const double cell = 0.08;
  const DensityField src = ShapeField(src_from_shape, kBigBox), tgt = ShapeField(tgt_from_shape, kBigBox);
  const Eigen::Matrix3Xd ps = SurfacePoints(src_from_shape, cell), pt = SurfacePoints(tgt_from_shape, cell);
  FieldAlignmentOptions o;
  o.sample_spread = cell;
  o.max_samples = 3000;
  const Rigid3d start = Perturb(truth, 4.0, Eigen::Vector3d(1, -1, 2), Eigen::Vector3d(0.04, -0.03, 0.02));
  const FieldAlignmentResult r = AlignFields(src, tgt, ps, pt, start, o);
  std::printf(
      "[field] %d iterations, cost %.4f -> %.4f, %d samples, %.2f s; rotation error %.4f deg, translation %.5f\n",
      r.iterations, r.initial_cost, r.final_cost, r.samples, r.seconds,
      RotationErrorDeg(r.target_from_source.rotation, truth.rotation),
      (r.target_from_source.translation - truth.translation).norm());
  EXPECT_GT(RotationErrorDeg(start.rotation, truth.rotation), 3.9);
  EXPECT_LT(RotationErrorDeg(r.target_from_source.rotation, truth.rotation), 0.05);
  EXPECT_LT((r.target_from_source.translation - truth.translation).norm(), 1e-3);
  EXPECT_LT(r.final_cost, 0.2 * r.initial_cost);

  // Started at the truth it stays there.
  const FieldAlignmentResult still = AlignFields(src, tgt, ps, pt, truth, o);
  EXPECT_LT(RotationErrorDeg(still.target_from_source.rotation, truth.rotation), 0.01);

  // A fixed scale (a Sim(3) coarse solve): the target is the object at 1.3x, its densities per
  // unit length / 1.3 (the same optical depth across a thicker surface).
  const double s = 1.3;
  DensityField big;
  big.box = kBigBox;
  big.density = [&](const torch::Tensor& x) { return tgt.density(x / s) / s; };
  const Rigid3d truth_scaled(truth.rotation, s * truth.translation);
  const FieldAlignmentResult rs = AlignFields(
      src, big, ps, pt * s, Perturb(truth_scaled, 3.0, Eigen::Vector3d(0, 1, 1), Eigen::Vector3d::Zero()), o, s);
  EXPECT_LT(RotationErrorDeg(rs.target_from_source.rotation, truth.rotation), 0.05);
  EXPECT_EQ(rs.scale, s);  // held

  // The scale refined too, from 5 % off (and 2 deg): it ends near the truth's. The source's
  // densities are converted to target units at the start's scale, 5 % off here, which leaves the
  // scale a few tenths of a percent off.
  FieldAlignmentOptions os = o;
  os.estimate_scale = true;
  const Rigid3d start_scaled = Perturb(truth_scaled, 2.0, Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(0.02, 0, -0.01));
  const FieldAlignmentResult free = AlignFields(src, big, ps, pt * s, start_scaled, os, 0.95 * s);
  std::printf("[field, scale] %d iterations, scale %.4f -> %.5f (truth %.2f), rotation error %.4f deg\n",
              free.iterations, 0.95 * s, free.scale, s,
              RotationErrorDeg(free.target_from_source.rotation, truth.rotation));
  EXPECT_NEAR(free.scale / s, 1.0, 5e-3);
  EXPECT_LT(RotationErrorDeg(free.target_from_source.rotation, truth.rotation), 0.15);
  EXPECT_LT((free.target_from_source.translation - truth_scaled.translation).norm(), 5e-3);
}

// A block knows its box only: samples carried outside the other box carry no weight, so a target
// box that cuts the object in half still pins the pose; boxes that do not meet leave the start.
TEST(FieldAlignment, OnlySamplesInsideTheOtherBoxCount) {
  const Rigid3d id;
  const double cell = 0.08;
  const DensityField src = ShapeField(id, kBigBox);
  const Eigen::AlignedBox3d half(Eigen::Vector3d(-3, -3, -3), Eigen::Vector3d(0.05, 3, 3));
  const DensityField tgt = ShapeField(id, half);
  const Eigen::Matrix3Xd ps = SurfacePoints(id, cell);
  FieldAlignmentOptions o;
  o.sample_spread = cell;
  const Rigid3d start = Perturb(id, 3.0, Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(0.02, 0, 0));
  const FieldAlignmentResult r = AlignFields(src, tgt, ps, ps, start, o);
  EXPECT_LT(RotationErrorDeg(r.target_from_source.rotation, id.rotation), 0.1);
  // Two samples per point each way; those of the part beyond x = 0.05 carried into the target were left out.
  EXPECT_LT(r.samples, 0.9 * 4 * ps.cols());

  const Eigen::AlignedBox3d far(Eigen::Vector3d::Constant(10), Eigen::Vector3d::Constant(11));
  const FieldAlignmentResult none = AlignFields(src, ShapeField(id, far), ps, Eigen::Matrix3Xd(3, 0), start, o);
  EXPECT_EQ(none.iterations, 0);
  EXPECT_EQ(none.target_from_source.ToMatrix(), start.ToMatrix());

  o.occupancy_scale = 0;
  EXPECT_THROW(AlignFields(src, tgt, ps, ps, start, o), InputError);
}

// A target block that saw only the object's x < 0 half and holds a wrong surface (the object
// shifted by 0.15 in y, as floaters would) where it did not look. Every sample counts by default,
// so the wrong half pulls the pose; with overlap_only the samples the target did not see are left
// out and the pose is the truth's.
TEST(FieldAlignment, OverlapOnlyLeavesOutWhatTheOtherBlockDidNotSee) {
  const Rigid3d id;
  const double cell = 0.08;
  const DensityField src = ShapeField(id, kBigBox);
  const DensityField good = ShapeField(id, kBigBox);
  const DensityField wrong = ShapeField(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0.15, 0)), kBigBox);
  DensityField tgt;
  tgt.box = kBigBox;
  tgt.density = [good, wrong](const torch::Tensor& x) {
    return torch::where(x.select(1, 0) < 0, good.density(x), wrong.density(x));
  };
  // Seen: near the surface, on the x < 0 half only; the source saw all of it.
  auto near_surface = [](const torch::Tensor& x) {
    const torch::Tensor c = x.to(torch::kDouble).contiguous();
    torch::Tensor out = torch::empty({c.size(0)}, torch::kBool);
    const double* p = c.data_ptr<double>();
    for (int64_t i = 0; i < c.size(0); ++i) {
      out[i] = std::abs(ShapeDistance(Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]))) < 0.1;
    }
    return out;
  };
  DensityField src_seen = src;
  src_seen.seen = near_surface;
  tgt.seen = [near_surface](const torch::Tensor& x) { return near_surface(x) & (x.select(1, 0) < 0); };
  const Eigen::Matrix3Xd ps = SurfacePoints(id, cell);
  Eigen::Matrix3Xd pt_all = SurfacePoints(id, cell);  // the target's mask: its seen half
  std::vector<bool> half(pt_all.cols());
  for (Eigen::Index i = 0; i < pt_all.cols(); ++i) half[i] = pt_all(0, i) < 0;
  Eigen::Matrix3Xd pt(3, std::count(half.begin(), half.end(), true));
  for (Eigen::Index i = 0, k = 0; i < pt_all.cols(); ++i) {
    if (half[i]) pt.col(k++) = pt_all.col(i);
  }
  FieldAlignmentOptions o;
  o.sample_spread = cell;
  o.max_samples = 3000;
  const Rigid3d start = Perturb(id, 2.0, Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(0.02, 0, 0));
  const FieldAlignmentResult all = AlignFields(src_seen, tgt, ps, pt, start, o);
  o.overlap_only = true;
  const FieldAlignmentResult seen = AlignFields(src_seen, tgt, ps, pt, start, o);
  const double err_all = RotationErrorDeg(all.target_from_source.rotation, id.rotation);
  const double err_seen = RotationErrorDeg(seen.target_from_source.rotation, id.rotation);
  const double shift_all = all.target_from_source.translation.norm(),
               shift_seen = seen.target_from_source.translation.norm();
  std::printf("[field overlap] all samples: %.3f deg, %.4f; overlap only (%.2f kept): %.3f deg, %.4f\n", err_all,
              shift_all, seen.overlap_fraction, err_seen, shift_seen);
  EXPECT_EQ(all.overlap_fraction, -1);
  EXPECT_GT(seen.overlap_fraction, 0.3);
  EXPECT_LT(seen.overlap_fraction, 0.9);
  // Started 2 deg off: the default is pulled further away (4.7 deg when written), overlap_only
  // lands within 0.2 deg (the finite differences still reach across x = 0 near the cut).
  EXPECT_GT(err_all, 2.0);
  EXPECT_LT(err_seen, 0.25);
  EXPECT_LT(shift_seen, 0.005);
  EXPECT_GT(shift_all, 2 * shift_seen + 0.005);
  // Without `seen` on one field overlap_only changes nothing.
  const FieldAlignmentResult unknown = AlignFields(src, tgt, ps, pt, start, o);
  EXPECT_EQ(unknown.overlap_fraction, -1);
  EXPECT_TRUE(unknown.target_from_source.ToMatrix().isApprox(all.target_from_source.ToMatrix(), 1e-12));
}

TEST(FieldAlignment, SeenFromGridIsTheDilatedMask) {
  RegGrid g;
  const int d = 8;
  g.aabb_min = Eigen::Vector3d::Constant(0);
  g.aabb_max = Eigen::Vector3d::Constant(8);  // cells of 1
  g.xyz = torch::zeros({d, d, d, 3});
  g.rgba = torch::zeros({4, d, d, d});
  g.surface = torch::zeros({d, d, d});
  g.mask = torch::zeros({d, d, d}, torch::kBool);
  g.mask.index_put_({4, 4, 4}, true);
  const auto at = [](double x, double y, double z) { return torch::tensor({{float(x), float(y), float(z)}}); };
  const auto seen0 = SeenFromGrid(g, 0), seen1 = SeenFromGrid(g, 1);
  EXPECT_TRUE(seen0(at(4.5, 4.5, 4.5)).item<bool>());
  EXPECT_FALSE(seen0(at(3.5, 4.5, 4.5)).item<bool>());
  EXPECT_TRUE(seen1(at(3.5, 4.5, 4.5)).item<bool>());
  EXPECT_TRUE(seen1(at(5.9, 3.1, 5.5)).item<bool>());
  EXPECT_FALSE(seen1(at(6.1, 4.5, 4.5)).item<bool>());
  EXPECT_FALSE(seen1(at(-0.5, 4.5, 4.5)).item<bool>());  // outside the box
  EXPECT_EQ(seen1(torch::rand({10, 3}) * 8).size(0), 10);
}

}  // namespace
}  // namespace nerfreg
