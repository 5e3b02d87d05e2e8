#pragma once
// The bundle adjustment's residual: a world point projected into an image (pinhole + OpenCV
// radial-tangential distortion) minus its keypoint, in pixels. Two forms of the same function:
// - ReprojectionResidual, a template for ceres::AutoDiffCostFunction (the reference);
// - ReprojectionCost, the same with derivatives written out, which the adjustment uses: automatic
//   derivatives carry 9 or 12 dual parts through every operation, and the Jacobians were half of
//   the adjustment's time on 192 forward-facing views.
// Include from .cc files only: the libraries link Ceres privately.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>

#include "nerfreg/geometry/camera.h"

namespace nerfreg {

// Parameter blocks: camera (6: angle-axis rotation, translation of cam_from_world), point (3: in
// world), and with refined intrinsics, intrinsics (3: focal fx, k1, k2 of the image's camera group);
// fy / fx, the principal point and the other distortion coefficients are the image's own constants.
// Points at or behind z = 1e-6 are projected as if at z = 1e-6 (a finite residual; triangulation
// removes them later).
struct ReprojectionResidual {
  ReprojectionResidual(const Eigen::Vector2d& uv, const Camera& c)
      : uv(uv),
        aspect(c.fy / c.fx),
        cx(c.cx),
        cy(c.cy),
        p1(c.p1),
        p2(c.p2),
        k3(c.k3),
        k4(c.k4),
        fx(c.fx),
        k1(c.k1),
        k2(c.k2) {}
  // With the intrinsics block.
  template <typename T>
  bool operator()(const T* camera, const T* point, const T* intrinsics, T* residual) const {
    return Residual(camera, point, intrinsics[0], intrinsics[1], intrinsics[2], residual);
  }
  // With the image's own focal, k1, k2 held.
  template <typename T>
  bool operator()(const T* camera, const T* point, T* residual) const {
    return Residual(camera, point, T(fx), T(k1), T(k2), residual);
  }
  template <typename T>
  bool Residual(const T* camera, const T* point, const T& focal, const T& k1_, const T& k2_, T* residual) const {
    T p[3];
    ceres::AngleAxisRotatePoint(camera, point, p);
    for (int k = 0; k < 3; ++k) p[k] += camera[3 + k];
    const T z = p[2] > T(1e-6) ? p[2] : T(1e-6);
    const T u = p[0] / z, v = p[1] / z;
    const T r2 = u * u + v * v;
    const T radial = T(1) + r2 * (k1_ + r2 * (k2_ + r2 * (T(k3) + r2 * T(k4))));
    const T ud = u * radial + T(2 * p1) * u * v + T(p2) * (r2 + T(2) * u * u);
    const T vd = v * radial + T(p1) * (r2 + T(2) * v * v) + T(2 * p2) * u * v;
    residual[0] = focal * ud + T(cx) - T(uv.x());
    residual[1] = focal * T(aspect) * vd + T(cy) - T(uv.y());
    return true;
  }
  Eigen::Vector2d uv;
  double aspect, cx, cy, p1, p2, k3, k4;
  double fx, k1, k2;  // used where the intrinsics are held
};

// ReprojectionResidual with analytic Jacobians; refine_intrinsics adds the intrinsics block.
class ReprojectionCost : public ceres::CostFunction {
 public:
  ReprojectionCost(const Eigen::Vector2d& uv, const Camera& camera, bool refine_intrinsics);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  ReprojectionResidual r_;
  bool refine_intrinsics_;
};

}  // namespace nerfreg
