#include "nerfreg/viewgraph/focal_estimation.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace nerfreg {

void FocalEstimationOptions::Check() const {
  if (!(min_fraction > 0 && max_fraction > min_fraction) || grid_steps < 3 || !(distinct_ratio >= 1) || min_pairs < 1)
    throw std::invalid_argument("FocalEstimationOptions: out of range");
}

double EssentialSingularValueGap(const Eigen::Matrix3d& j_F_i, double focal_px, double cx, double cy) {
  Eigen::Matrix3d k;
  k << focal_px, 0, cx, 0, focal_px, cy, 0, 0, 1;
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(k.transpose() * j_F_i * k).singularValues();
  return s(0) + s(1) > 0 ? (s(0) - s(1)) / (s(0) + s(1)) : 1.0;
}

FocalEstimate EstimateFocalFromFundamentals(const std::vector<Eigen::Matrix3d>& j_F_i, int width, int height,
                                            const FocalEstimationOptions& options) {
  options.Check();
  FocalEstimate estimate;
  estimate.num_pairs = static_cast<int>(j_F_i.size());
  if (estimate.num_pairs < options.min_pairs) return estimate;
  const double side = std::max(width, height), cx = 0.5 * width, cy = 0.5 * height;
  std::vector<double> gaps(j_F_i.size());
  auto cost = [&](double f) {
    for (size_t p = 0; p < j_F_i.size(); ++p) gaps[p] = EssentialSingularValueGap(j_F_i[p], f, cx, cy);
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    return gaps[gaps.size() / 2];
  };
  const double lo = std::log(options.min_fraction * side), hi = std::log(options.max_fraction * side);
  const double step = (hi - lo) / (options.grid_steps - 1);
  int best = 0;
  double best_cost = 1e300;
  for (int g = 0; g < options.grid_steps; ++g) {
    const double c = cost(std::exp(lo + g * step));
    if (c < best_cost) best_cost = c, best = g;
  }
  // Golden-section search on log f within the neighbouring grid cells.
  double a = lo + std::max(0, best - 1) * step, b = lo + std::min(options.grid_steps - 1, best + 1) * step;
  const double ratio = 0.5 * (std::sqrt(5.0) - 1);
  double x1 = b - ratio * (b - a), x2 = a + ratio * (b - a);
  double c1 = cost(std::exp(x1)), c2 = cost(std::exp(x2));
  for (int it = 0; it < 40; ++it) {
    if (c1 < c2)
      b = x2, x2 = x1, c2 = c1, x1 = b - ratio * (b - a), c1 = cost(std::exp(x1));
    else
      a = x1, x1 = x2, c1 = c2, x2 = a + ratio * (b - a), c2 = cost(std::exp(x2));
  }
  estimate.focal_px = std::exp(0.5 * (a + b));
  estimate.cost = cost(estimate.focal_px);
  const bool inside = best > 0 && best < options.grid_steps - 1;
  const double floor = std::max(estimate.cost, 1e-6);
  estimate.distinct = inside && cost(estimate.focal_px / 1.3) > options.distinct_ratio * floor &&
                      cost(estimate.focal_px * 1.3) > options.distinct_ratio * floor;
  return estimate;
}

}  // namespace nerfreg
