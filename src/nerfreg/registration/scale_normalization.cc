#include "nerfreg/registration/scale_normalization.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "nerfreg/util/error.h"

namespace nerfreg {

void CheckScaleInRange(double scale, const std::string& file, const std::string& field) {
  if (!(scale >= kMinSim3Scale && scale <= kMaxSim3Scale)) {
    ThrowInputError(file, field, fmt::format("a scale in [{:g}, {:g}], got {:g}", kMinSim3Scale, kMaxSim3Scale, scale));
  }
}

double OccupiedRadius(const Eigen::Matrix3Xd& points, Eigen::Vector3d* centroid) {
  if (points.cols() < 2) {
    if (centroid) *centroid = points.cols() == 1 ? Eigen::Vector3d(points.col(0)) : Eigen::Vector3d::Zero();
    return 0;
  }
  const Eigen::Vector3d mean = points.rowwise().mean();
  const Eigen::VectorXd d = (points.colwise() - mean).colwise().norm();
  std::vector<double> sorted(d.data(), d.data() + d.size());
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double cut = 3 * sorted[sorted.size() / 2];
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Index kept = 0;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    if (d[i] <= cut) {
      sum += points.col(i);
      ++kept;
    }
  }
  const Eigen::Vector3d c = sum / static_cast<double>(kept);
  double squares = 0;
  for (Eigen::Index i = 0; i < points.cols(); ++i)
    if (d[i] <= cut) squares += (points.col(i) - c).squaredNorm();
  if (centroid) *centroid = c;
  return std::sqrt(squares / static_cast<double>(kept));
}

Sim3d NormalizationFor(const Eigen::Matrix3Xd& points, const std::string& file) {
  Eigen::Vector3d c;
  const double r = OccupiedRadius(points, &c);
  if (!(r > 0)) ThrowInputError(file, "occupied cells", "an input with occupied cells that span a volume");
  const double k = kNormalizedRadius / r;
  CheckScaleInRange(1 / k, file, "occupied extent (RMS radius)");
  return Sim3d(k, Eigen::Quaterniond::Identity(), -k * c);
}

Json NormalizationJson(const Sim3d& n, double radius) {
  const Eigen::Vector3d c = -n.translation / n.scale;
  return {{"scale", n.scale}, {"centroid", {c.x(), c.y(), c.z()}}, {"radius", radius}};
}

}  // namespace nerfreg
