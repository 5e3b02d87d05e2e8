#include "nerfreg/reg/splat_field.h"

#include <ATen/Parallel.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <tuple>

#include "nerfreg/util/error.h"

namespace nerfreg {

void SplatFieldOptions::Check() const {
  if (!(density_scale > 0)) ThrowInputError("--splat-density-scale", "", "> 0");
  if (!(blur >= 0)) ThrowInputError("--splat-blur", "", ">= 0");
  if (!(truncation > 0 && truncation <= 10)) ThrowInputError("splat field", "truncation", "in (0, 10]");
}

namespace {
constexpr double kShC0 = 0.28209479177387814;
// A splat overlapping more cells than this is visited by every query instead.
constexpr std::int64_t kMaxCellsPerSplat = 512;
}  // namespace

SplatField::SplatField(const Splats& splats, const SplatFieldOptions& options) : options_(options) {
  options.Check();
  splats.CheckShapes();
  const std::int64_t n = splats.size();
  gaussians_.resize(n);
  std::vector<Eigen::Vector3d> half_extent(n);
  std::vector<double> radius(n);
  for (std::int64_t i = 0; i < n; ++i) {
    Gaussian& g = gaussians_[i];
    g.mean = splats.position.col(i).cast<double>();
    const Eigen::Vector4d q = splats.rotation.col(i).cast<double>();
    const Eigen::Matrix3d r = Eigen::Quaterniond(q(0), q(1), q(2), q(3)).normalized().toRotationMatrix();
    const Eigen::Vector3d variance = (2.0 * splats.log_scale.col(i).cast<double>()).array().exp();
    const Eigen::Matrix3d cov =
        r * variance.asDiagonal() * r.transpose() + options.blur * options.blur * Eigen::Matrix3d::Identity();
    g.precision = cov.inverse();
    g.weight = options.density_scale / (1.0 + std::exp(-static_cast<double>(splats.opacity(i))));
    g.rgb = (0.5 + kShC0 * splats.f_dc.col(i).cast<double>().array()).cwiseMax(0.0).cwiseMin(1.0);
    // The box of the ellipsoid d^T S^-1 d <= t^2: half-widths t sqrt(S_kk).
    half_extent[i] = options.truncation * cov.diagonal().cwiseSqrt();
    radius[i] = half_extent[i].maxCoeff();
    bounds_.extend(g.mean - half_extent[i]);
    bounds_.extend(g.mean + half_extent[i]);
  }
  if (n == 0) return;
  std::vector<double> sorted = radius;
  std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
  // Twice the median radius, but no finer than the bounds over 2^20 cells a side (keys stay small).
  cell_ = std::max(2.0 * sorted[n / 2], bounds_.sizes().maxCoeff() / double(1 << 20));
  std::vector<std::pair<CellKey, std::uint32_t>> entries;
  entries.reserve(static_cast<size_t>(n) * 8);
  for (std::int64_t i = 0; i < n; ++i) {
    const CellKey lo = Cell(gaussians_[i].mean - half_extent[i]), hi = Cell(gaussians_[i].mean + half_extent[i]);
    const std::int64_t cells = (hi.i - lo.i + 1) * (hi.j - lo.j + 1) * (hi.k - lo.k + 1);
    if (cells > kMaxCellsPerSplat) {
      large_.push_back(static_cast<std::uint32_t>(i));
      continue;
    }
    for (std::int64_t a = lo.i; a <= hi.i; ++a)
      for (std::int64_t b = lo.j; b <= hi.j; ++b)
        for (std::int64_t c = lo.k; c <= hi.k; ++c) entries.push_back({{a, b, c}, static_cast<std::uint32_t>(i)});
  }
  std::sort(entries.begin(), entries.end(), [](const auto& x, const auto& y) {
    return std::tie(x.first.i, x.first.j, x.first.k, x.second) < std::tie(y.first.i, y.first.j, y.first.k, y.second);
  });
  members_.resize(entries.size());
  cells_.reserve(entries.size() / 4 + 1);
  for (size_t e = 0; e < entries.size(); ++e) {
    members_[e] = entries[e].second;
    auto [it, inserted] =
        cells_.try_emplace(entries[e].first, static_cast<std::uint32_t>(e), static_cast<std::uint32_t>(e));
    it->second.second = static_cast<std::uint32_t>(e + 1);
  }
}

SplatField::CellKey SplatField::Cell(const Eigen::Vector3d& p) const {
  return {static_cast<std::int64_t>(std::floor(p.x() / cell_)), static_cast<std::int64_t>(std::floor(p.y() / cell_)),
          static_cast<std::int64_t>(std::floor(p.z() / cell_))};
}

void SplatField::Accumulate(const Gaussian& g, const Eigen::Vector3d& p, double* sigma,
                            Eigen::Vector3d* rgb_sum) const {
  const Eigen::Vector3d d = p - g.mean;
  const double m = d.dot(g.precision * d);
  if (m > options_.truncation * options_.truncation) return;
  const double w = g.weight * std::exp(-0.5 * m);
  *sigma += w;
  *rgb_sum += w * g.rgb;
}

Eigen::VectorXd SplatField::Density(const Eigen::Matrix3Xd& points, Eigen::Matrix3Xd* rgb) const {
  const std::int64_t n = points.cols();
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(n);
  if (rgb) rgb->setZero(3, n);
  at::parallel_for(0, n, 256, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t q = begin; q < end; ++q) {
      const Eigen::Vector3d p = points.col(q);
      if (gaussians_.empty() || !bounds_.contains(p)) continue;
      double s = 0;
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      const auto it = cells_.find(Cell(p));
      if (it != cells_.end()) {
        for (std::uint32_t e = it->second.first; e < it->second.second; ++e)
          Accumulate(gaussians_[members_[e]], p, &s, &c);
      }
      for (std::uint32_t i : large_) Accumulate(gaussians_[i], p, &s, &c);
      sigma(q) = s;
      if (rgb && s > 0) rgb->col(q) = c / s;
    }
  });
  return sigma;
}

double SplatField::DensityBySum(const Eigen::Vector3d& point) const {
  double s = 0;
  Eigen::Vector3d c;
  for (const Gaussian& g : gaussians_) Accumulate(g, point, &s, &c);
  return s;
}

}  // namespace nerfreg
