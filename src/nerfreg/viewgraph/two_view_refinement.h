#pragma once
// The relative pose of two calibrated views refined on their correspondences: what OpenCV's
// estimators leave out. RANSAC keeps its best minimal sample's model, and USAC's final
// least-squares fit is an eight-point fit, which a planar scene leaves undetermined (the points'
// design matrix has a three-dimensional null space).
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace nerfreg {

// Sampson distance of the correspondence (xi, xj) to the essential matrix e (x_j^T e x_i = 0), in
// normalised image units: the first-order distance to the nearest pair that satisfies it. Signed.
double SampsonDistance(const Eigen::Matrix3d& e, const Eigen::Vector2d& xi, const Eigen::Vector2d& xj);

// Refines j_from_i (rotation `rot`, unit translation `trans`, both updated) on the Sampson
// distances of the correspondences xi[k] <-> xj[k] (normalised coordinates), robust with a Cauchy
// loss of the given scale (normalised units): Levenberg-Marquardt (Ceres' TinySolver) over five
// degrees of freedom, a rotation step exp(w) and a step in the unit translation's tangent plane,
// derivatives by Ceres' jets. Fewer than 5 correspondences, or a step that does not lower the
// cost: unchanged.
void RefineRelativePose(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        Eigen::Matrix3d* rot, Eigen::Vector3d* trans);

// The cost RefineRelativePose minimises: sum of log(1 + (d / scale)^2) over the Sampson distances
// d (trans is normalised first).
double RelativePoseCost(const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj, double scale,
                        const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans);

// The relative pose an essential matrix e (x_j^T e x_i = 0) gives: among its four decompositions
// (cv::decomposeEssentialMat's), the one with the most correspondences in front of both cameras
// and nearer than 50 units (|t| = 1), counted over those with (*mask)[k] != 0, which the mask is
// left with. cv::recoverPose's rule and tie order, with each correspondence triangulated in closed
// form (the depths of the two rays' closest points) in place of its per-point SVD, which took 70 %
// of a pair's two-view geometry on ViSP's cube. Returns the count; mask: (N) of xi's N.
int RecoverPoseFromEssential(const Eigen::Matrix3d& e, const std::vector<Eigen::Vector2d>& xi,
                             const std::vector<Eigen::Vector2d>& xj, std::vector<uint8_t>* mask, Eigen::Matrix3d* rot,
                             Eigen::Vector3d* trans);

}  // namespace nerfreg
