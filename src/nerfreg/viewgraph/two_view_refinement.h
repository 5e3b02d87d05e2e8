#pragma once
// The relative pose of two calibrated views refined on their correspondences: what OpenCV's
// estimators leave out. RANSAC keeps its best minimal sample's model, and USAC's final
// least-squares fit is an eight-point fit, which a planar scene leaves undetermined (the points'
// design matrix has a three-dimensional null space).
#include <vector>

#include <Eigen/Core>

namespace nerfreg {

// Sampson distance of the correspondence (xi, xj) to the essential matrix e (x_j^T e x_i = 0), in
// normalised image units: the first-order distance to the nearest pair that satisfies it. Signed.
double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj);

// Refines j_from_i (rotation `rot`, unit translation `trans`, both updated) on the Sampson
// distances of the correspondences xi[k] <-> xj[k] (normalised coordinates), robust with a Cauchy
// loss of the given scale (normalised units): Ceres' Levenberg-Marquardt, the rotation as a
// quaternion on its manifold and the translation on the unit sphere (five degrees of freedom),
// automatic derivatives. Fewer than 5 correspondences: unchanged.
void RefineRelativePose(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        Eigen::Matrix3d* rot, Eigen::Vector3d* trans);

// The cost RefineRelativePose minimises, evaluated by the same Ceres problem: sum of
// log(1 + (d / scale)^2) over the Sampson distances d (trans is normalised first).
double RelativePoseCost(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans);

}  // namespace nerfreg
