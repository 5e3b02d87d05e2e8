#include "nerfreg/reg/field_alignment.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

void FieldAlignmentOptions::Check() const {
  if (!(occupancy_scale > 0)) ThrowInputError("--field-occupancy-scale", "", "> 0");
  if (!(sample_spread > 0)) ThrowInputError("field alignment", "sample_spread", "> 0");
  if (max_samples < 10) ThrowInputError("field alignment", "max_samples", ">= 10");
  if (!(gradient_step > 0)) ThrowInputError("field alignment", "gradient_step", "> 0");
  if (iterations < 0) ThrowInputError("--field-iterations", "", ">= 0");
  if (!(tolerance_deg >= 0)) ThrowInputError("field alignment", "tolerance_deg", ">= 0");
  if (min_overlap_samples < 10) ThrowInputError("field alignment", "min_overlap_samples", ">= 10");
}

DensityField BlockDensityField(NerfBlock& block) {
  DensityField f;
  f.density = [&block](const torch::Tensor& x) { return QueryDensity(block, x); };
  const auto& o = block.field_options;
  const Eigen::AlignedBox3d field_box(Eigen::Vector3d(o.aabb_min[0], o.aabb_min[1], o.aabb_min[2]),
                                      Eigen::Vector3d(o.aabb_max[0], o.aabb_max[1], o.aabb_max[2]));
  // A moved block's box is rotated in its frame: the axis-aligned box around it (density is 0
  // outside the field's own box anyway).
  for (int corner = 0; corner < 8; ++corner) {
    f.box.extend(block.world_from_field * field_box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner)));
  }
  return f;
}

std::function<torch::Tensor(const torch::Tensor&)> SeenFromGrid(const RegGrid& grid, int dilation) {
  grid.Check();
  if (dilation < 0) throw std::invalid_argument("SeenFromGrid: dilation must be >= 0");
  torch::NoGradGuard no_grad;
  const std::int64_t d = grid.Resolution();
  torch::Tensor seen = grid.mask.to(torch::kFloat32).view({1, 1, d, d, d});
  if (dilation > 0) seen = torch::max_pool3d(seen, 2 * dilation + 1, 1, dilation);
  seen = seen.view({-1}).gt(0.5).contiguous();
  const auto mn = torch::tensor({float(grid.aabb_min.x()), float(grid.aabb_min.y()), float(grid.aabb_min.z())});
  const float cell = static_cast<float>(grid.CellSize());
  return [seen, mn, cell, d](const torch::Tensor& x) {
    torch::NoGradGuard guard;
    const auto ijk = ((x.to(torch::kFloat32) - mn) / cell).floor().to(torch::kInt64);  // [N, 3]
    const auto inside = ((ijk >= 0) & (ijk < d)).all(1);
    const auto c = ijk.clamp(0, d - 1);
    const auto flat = (c.select(1, 0) * d + c.select(1, 1)) * d + c.select(1, 2);
    return seen.index_select(0, flat) & inside;
  };
}

namespace {

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

Eigen::VectorXd Occupancy(const DensityField& f, const Eigen::Matrix3Xd& p, double scale) {
  if (p.cols() == 0) return Eigen::VectorXd();
  const torch::Tensor x =
      torch::from_blob(const_cast<double*>(p.data()), {p.cols(), 3}, torch::kDouble).to(torch::kFloat).contiguous();
  const torch::Tensor sigma = f.density(x).to(torch::kDouble).contiguous().view({-1});
  TORCH_CHECK(sigma.size(0) == p.cols(), "AlignFields: the density field returned ", sigma.size(0), " values for ",
              p.cols(), " points");
  const Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(sigma.data_ptr<double>(), sigma.size(0));
  return (1.0 - (-scale * s.array().max(0.0)).exp()).matrix();
}

// Occupancy at p and its central-difference gradient (one batched query of 7 points per sample).
void OccupancyAndGradient(const DensityField& f, const Eigen::Matrix3Xd& p, double scale, double h, Eigen::VectorXd* o,
                          Eigen::Matrix3Xd* g) {
  const Eigen::Index n = p.cols();
  Eigen::Matrix3Xd all(3, 7 * n);
  all.leftCols(n) = p;
  for (int a = 0; a < 3; ++a) {
    all.middleCols((1 + 2 * a) * n, n) = p;
    all.middleCols((1 + 2 * a) * n, n).row(a).array() += h;
    all.middleCols((2 + 2 * a) * n, n) = p;
    all.middleCols((2 + 2 * a) * n, n).row(a).array() -= h;
  }
  const Eigen::VectorXd occ = Occupancy(f, all, scale);
  *o = occ.head(n);
  g->resize(3, n);
  for (int a = 0; a < 3; ++a) {
    g->row(a) = ((occ.segment((1 + 2 * a) * n, n) - occ.segment((2 + 2 * a) * n, n)) / (2 * h)).transpose();
  }
}

// The columns of p whose `keep` entry is true.
Eigen::Matrix3Xd Columns(const Eigen::Matrix3Xd& p, const std::vector<bool>& keep) {
  Eigen::Matrix3Xd out(3, std::count(keep.begin(), keep.end(), true));
  Eigen::Index k = 0;
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    if (keep[i]) out.col(k++) = p.col(i);
  }
  return out;
}

// seen(p) as flags (p in that field's frame).
std::vector<bool> Seen(const DensityField& f, const Eigen::Matrix3Xd& p) {
  std::vector<bool> out(p.cols(), false);
  if (p.cols() == 0) return out;
  const torch::Tensor x =
      torch::from_blob(const_cast<double*>(p.data()), {p.cols(), 3}, torch::kDouble).to(torch::kFloat).contiguous();
  const torch::Tensor s = f.seen(x).to(torch::kBool).contiguous().view({-1});
  TORCH_CHECK(s.size(0) == p.cols(), "AlignFields: seen returned ", s.size(0), " values for ", p.cols(), " points");
  const bool* d = s.data_ptr<bool>();
  for (Eigen::Index i = 0; i < p.cols(); ++i) out[i] = d[i];
  return out;
}

struct Linearisation {
  double cost = 0;  // mean squared residual over weighted samples
  int samples = 0;
  Matrix6 h = Matrix6::Zero();
  Vector6 b = Vector6::Zero();
  // With a scale: the normal equations' row of the log-scale increment (h_s: its coupling with
  // the SE(3) increment, h_ss its own), and its gradient b_s.
  Vector6 h_s = Vector6::Zero();
  double h_ss = 0, b_s = 0;
};

}  // namespace

Eigen::Matrix3Xd SurfaceBandSamples(const Eigen::Matrix3Xd& points, double spread, int max_samples, std::mt19937& rng) {
  std::vector<Eigen::Index> order(points.cols());
  for (Eigen::Index i = 0; i < points.cols(); ++i) order[i] = i;
  const Eigen::Index keep = std::min<Eigen::Index>(points.cols(), std::max(1, max_samples / 2));
  if (keep < points.cols()) {
    std::shuffle(order.begin(), order.end(), rng);
    order.resize(keep);
  }
  std::normal_distribution<double> n(0, 1);
  Eigen::Matrix3Xd out(3, 2 * keep);
  for (Eigen::Index k = 0; k < keep; ++k) {
    const Eigen::Vector3d p = points.col(order[k]);
    out.col(2 * k) = p + 0.25 * spread * Eigen::Vector3d(n(rng), n(rng), n(rng));
    out.col(2 * k + 1) = p + 0.5 * spread * Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  return out;
}

FieldAlignmentResult AlignFields(const DensityField& source, const DensityField& target,
                                 const Eigen::Matrix3Xd& source_points, const Eigen::Matrix3Xd& target_points,
                                 const Rigid3d& initial, const FieldAlignmentOptions& o, double scale) {
  o.Check();
  if (!(scale > 0)) throw std::invalid_argument("AlignFields: scale must be > 0");
  Timer timer;
  FieldAlignmentResult result;
  result.target_from_source = initial;
  std::mt19937 rng(o.seed);
  Eigen::Matrix3Xd ys = SurfaceBandSamples(source_points, o.sample_spread, o.max_samples, rng);  // source frame
  Eigen::Matrix3Xd xt = SurfaceBandSamples(target_points, o.sample_spread, o.max_samples, rng);  // target frame
  if (o.overlap_only && source.seen && target.seen) {
    const Eigen::Matrix3d r0 = initial.RotationMatrix();
    const Eigen::Vector3d t0 = initial.translation;
    const std::vector<bool> keep_s = Seen(target, ((scale * r0) * ys).colwise() + t0);
    const std::vector<bool> keep_t = Seen(source, (r0.transpose() * (xt.colwise() - t0)) / scale);
    const auto kept = std::count(keep_s.begin(), keep_s.end(), true) + std::count(keep_t.begin(), keep_t.end(), true);
    if (kept >= o.min_overlap_samples) {
      result.overlap_fraction = double(kept) / double(ys.cols() + xt.cols());
      ys = Columns(ys, keep_s);
      xt = Columns(xt, keep_t);
    }
  }
  // A density is per unit length: the source's, in target units, is sigma / scale. Converted at the
  // start's scale (with estimate_scale, the scale moves by at most a few percent).
  const double source_occupancy = o.occupancy_scale / scale;
  const Eigen::VectorXd os = Occupancy(source, ys, source_occupancy);
  const Eigen::VectorXd ot = Occupancy(target, xt, o.occupancy_scale);
  const double h = o.gradient_step * o.sample_spread;

  // The cost at (r, t), and with `jacobian` its normal equations. A trial step needs the cost only:
  // one density query per sample instead of seven (LM rejects many steps before it stops).
  auto linearise = [&](const Eigen::Matrix3d& r, const Eigen::Vector3d& t, double scale, bool jacobian) {
    Linearisation l;
    double sum = 0;
    // Samples carried into `field` at `mapped`, against their own occupancy `reference`;
    // jacobian_row(i, g) is d residual_i / d increment given the field's gradient g there;
    // scale_row(i, g) the same for the log-scale increment.
    auto accumulate = [&](const DensityField& field, double occupancy_scale, const Eigen::Matrix3Xd& mapped,
                          const Eigen::VectorXd& reference, auto jacobian_row, auto scale_row) {
      Eigen::VectorXd occ;
      Eigen::Matrix3Xd grad;
      if (jacobian) {
        OccupancyAndGradient(field, mapped, occupancy_scale, h, &occ, &grad);
      } else {
        occ = Occupancy(field, mapped, occupancy_scale);
      }
      for (Eigen::Index i = 0; i < mapped.cols(); ++i) {
        if (!field.box.contains(Eigen::Vector3d(mapped.col(i)))) continue;
        const double res = occ(i) - reference(i);
        sum += res * res;
        ++l.samples;
        if (!jacobian) continue;
        const Vector6 j = jacobian_row(i, Eigen::Vector3d(grad.col(i)));
        l.h.noalias() += j * j.transpose();
        l.b.noalias() += j * res;
        if (!o.estimate_scale) continue;
        const double js = scale_row(i, Eigen::Vector3d(grad.col(i)));
        l.h_s.noalias() += j * js;
        l.h_ss += js * js;
        l.b_s += js * res;
      }
    };
    // Source samples in the target field: residual o_t(T y) - o_s(y), J = [z x g, g] (and g . z
    // for the log-scale: the increment scales z about the origin).
    const Eigen::Matrix3Xd z = ((scale * r) * ys).colwise() + t;
    accumulate(
        target, o.occupancy_scale, z, os,
        [&](Eigen::Index i, const Eigen::Vector3d& g) {
          Vector6 j;
          j << Eigen::Vector3d(z.col(i)).cross(g), g;
          return j;
        },
        [&](Eigen::Index i, const Eigen::Vector3d& g) { return g.dot(z.col(i)); });
    // Target samples in the source field: residual o_s(T^-1 x) - o_t(x), with the source gradient
    // carried into the target frame (g_t = R g / scale), J = [g_t x x, -g_t].
    const Eigen::Matrix3Xd p = (r.transpose() * (xt.colwise() - t)) / scale;
    accumulate(
        source, source_occupancy, p, ot,
        [&](Eigen::Index i, const Eigen::Vector3d& g) {
          const Eigen::Vector3d gt = r * g / scale;
          Vector6 j;
          j << gt.cross(Eigen::Vector3d(xt.col(i))), -gt;
          return j;
        },
        [&](Eigen::Index i, const Eigen::Vector3d& g) { return -(r * g / scale).dot(xt.col(i)); });
    l.cost = l.samples > 0 ? sum / l.samples : 0;
    return l;
  };

  Eigen::Matrix3d r = initial.RotationMatrix();
  Eigen::Vector3d t = initial.translation;
  double s = scale;
  Linearisation cur = linearise(r, t, s, true);
  result.initial_cost = result.final_cost = cur.cost;
  result.samples = cur.samples;
  if (cur.samples < 10) {
    result.seconds = timer.Seconds();
    return result;
  }
  double lambda = 1e-3;
  for (int it = 0; it < o.iterations; ++it) {
    Vector6 dx;
    double ds = 0;  // the log-scale increment
    if (o.estimate_scale) {
      Eigen::Matrix<double, 7, 7> a;
      a << cur.h, cur.h_s, cur.h_s.transpose(), cur.h_ss;
      a.diagonal() *= 1 + lambda;
      a.diagonal().array() += 1e-12;
      Eigen::Matrix<double, 7, 1> b;
      b << cur.b, cur.b_s;
      const Eigen::Matrix<double, 7, 1> d = -a.ldlt().solve(b);
      dx = d.head<6>();
      ds = d(6);
    } else {
      Matrix6 a = cur.h;
      a.diagonal() *= 1 + lambda;
      a.diagonal().array() += 1e-12;
      dx = -a.ldlt().solve(cur.b);
    }
    if (!dx.allFinite() || !std::isfinite(ds)) break;
    const double angle = dx.head<3>().norm();
    const Eigen::Matrix3d dr =
        angle > 0 ? Eigen::AngleAxisd(angle, dx.head<3>() / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    // The increment acts on the left: x -> exp(ds) dr x + dt.
    const Eigen::Matrix3d r_new = dr * r;
    const Eigen::Vector3d t_new = o.estimate_scale ? Eigen::Vector3d(std::exp(ds) * (dr * t) + dx.tail<3>())
                                                   : Eigen::Vector3d(dr * t + dx.tail<3>());
    const double s_new = o.estimate_scale ? std::exp(ds) * s : s;
    const Linearisation trial = linearise(r_new, t_new, s_new, false);
    result.iterations = it + 1;
    // Accept only what lowers the cost on at least half the samples (a step that moves the
    // samples out of the other box must not win by leaving them out).
    if (trial.samples >= cur.samples / 2 && trial.cost < cur.cost) {
      r = r_new;
      t = t_new;
      s = s_new;
      lambda = std::max(lambda / 3, 1e-7);
      const bool converged = angle * 180 / M_PI < o.tolerance_deg && dx.tail<3>().norm() < 1e-5 && std::abs(ds) < 1e-5;
      if (converged || it + 1 == o.iterations) {
        cur.cost = trial.cost;
        cur.samples = trial.samples;
        break;
      }
      cur = linearise(r, t, s, true);
    } else {
      lambda *= 4;
      if (lambda > 1e6) break;
    }
  }
  result.target_from_source = Rigid3d(Eigen::Quaterniond(r), t);
  result.scale = s;
  result.final_cost = cur.cost;
  result.samples = cur.samples;
  result.seconds = timer.Seconds();
  return result;
}

}  // namespace nerfreg
