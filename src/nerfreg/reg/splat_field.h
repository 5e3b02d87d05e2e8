#pragma once
// A set of 3D Gaussian splats as a field registration can query like a NeRF block's: a density and
// a colour at any point.
//
// Density: sigma(x) = density_scale * sum_i sigmoid(opacity_i) exp(-1/2 d^T S_i^-1 d), d = x - mu_i,
// with S_i = R_i diag(exp(2 scale_i)) R_i^T + blur^2 I, truncated where d^T S_i^-1 d > truncation^2.
// Why the blur: trained splats are thin discs (3DGS's own renderer widens them by a fixed
// screen-space variance, its "dilation"); a shell a few millimetres thick is missed by grid
// extraction's jittered samples and gives field alignment's finite differences nothing to follow.
// A blur of a grid cell's fraction makes the surface a band as wide as a trained NeRF's. Why the
// scale: registration's thresholds (min_density 5 for occupied points, 0.7 for grids, occupancy
// 1 - exp(-0.05 sigma)) are in NeRF densities, per unit length; a surface of overlapping splats sums
// to a few units, a trained block's surface to tens or hundreds.
//
// Colour: the view-independent DC term, 0.5 + C0 f_dc clamped to [0, 1], averaged with each splat's
// density contribution as weight (0 where the density is 0).
//
// Speed: every splat is listed in the cells of a spatial hash that its truncation box overlaps; a
// query visits one cell. The cell is twice the median truncation radius, so a typical splat sits
// in at most 8 cells; a splat spanning more than 512 cells is kept in a list every query visits.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "nerfreg/data/splat_ply.h"

namespace nerfreg {

struct SplatFieldOptions {
  double density_scale = 20.0;  // sigma per unit of summed opacity, 1 / scene units
  double blur = 0.01;           // scene units: standard deviation added to every axis
  double truncation = 3.0;      // Mahalanobis radius beyond which a splat contributes nothing
  void Check() const;           // throws InputError naming the option
};

class SplatField {
 public:
  SplatField(const Splats& splats, const SplatFieldOptions& options = SplatFieldOptions());

  // points [3, N] -> sigma [N], and (optional) rgb [3, N]. Parallel over points.
  Eigen::VectorXd Density(const Eigen::Matrix3Xd& points, Eigen::Matrix3Xd* rgb = nullptr) const;
  // The same at one point by the direct sum over every splat (the reference the tests compare to).
  double DensityBySum(const Eigen::Vector3d& point) const;

  // The union of the splats' truncation boxes (empty for no splats): density is 0 outside.
  const Eigen::AlignedBox3d& Bounds() const { return bounds_; }
  std::int64_t size() const { return static_cast<std::int64_t>(gaussians_.size()); }
  const SplatFieldOptions& options() const { return options_; }

 private:
  struct Gaussian {
    Eigen::Vector3d mean;
    Eigen::Matrix3d precision;  // S^-1
    double weight;              // density_scale * sigmoid(opacity)
    Eigen::Vector3d rgb;        // the DC colour
  };
  struct CellKey {
    std::int64_t i, j, k;
    bool operator==(const CellKey& o) const { return i == o.i && j == o.j && k == o.k; }
  };
  struct CellHash {
    size_t operator()(const CellKey& c) const {
      return static_cast<size_t>(c.i * 73856093LL) ^ static_cast<size_t>(c.j * 19349663LL) ^
             static_cast<size_t>(c.k * 83492791LL);
    }
  };
  CellKey Cell(const Eigen::Vector3d& p) const;
  // Adds splat g's contribution at p to (sigma, rgb_sum).
  void Accumulate(const Gaussian& g, const Eigen::Vector3d& p, double* sigma, Eigen::Vector3d* rgb_sum) const;

  SplatFieldOptions options_;
  std::vector<Gaussian> gaussians_;
  Eigen::AlignedBox3d bounds_;
  double cell_ = 1.0;
  std::unordered_map<CellKey, std::pair<std::uint32_t, std::uint32_t>, CellHash> cells_;  // -> [begin, end) in members_
  std::vector<std::uint32_t> members_;
  std::vector<std::uint32_t> large_;
};

}  // namespace nerfreg
