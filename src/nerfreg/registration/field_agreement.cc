#include "nerfreg/registration/field_agreement.h"

#include <random>
#include <stdexcept>

namespace nerfreg {

FieldAgreementSamples DrawFieldAgreementSamples(const Eigen::Matrix3Xd& source_points,
                                                const Eigen::Matrix3Xd& target_points, double spread, int max_samples,
                                                unsigned seed) {
  std::mt19937 rng(seed);
  FieldAgreementSamples s;
  s.source = SurfaceBandSamples(source_points, spread, max_samples, rng);
  s.target = SurfaceBandSamples(target_points, spread, max_samples, rng);
  return s;
}

namespace {

// o = 1 - exp(-scale * sigma) at p ([3, N], the field's frame).
Eigen::VectorXd Occupancy(const DensityField& f, const Eigen::Matrix3Xd& p, double scale) {
  if (p.cols() == 0) return Eigen::VectorXd();
  torch::NoGradGuard no_grad;
  const torch::Tensor x =
      torch::from_blob(const_cast<double*>(p.data()), {p.cols(), 3}, torch::kDouble).to(torch::kFloat).contiguous();
  const torch::Tensor sigma = f.density(x).to(torch::kDouble).contiguous().view({-1});
  TORCH_CHECK(sigma.size(0) == p.cols(), "ScoreFieldAgreement: the density field returned ", sigma.size(0),
              " values for ", p.cols(), " points");
  const Eigen::VectorXd s = Eigen::Map<const Eigen::VectorXd>(sigma.data_ptr<double>(), sigma.size(0));
  return (1.0 - (-scale * s.array().max(0.0)).exp()).matrix();
}

}  // namespace

FieldAgreement ScoreFieldAgreement(const DensityField& source, const DensityField& target,
                                   const FieldAgreementSamples& samples, const Sim3d& target_from_source,
                                   double occupancy_scale) {
  const Sim3d source_from_target = target_from_source.Inverse();
  double ab = 0, aa_bb = 0, squared = 0;
  int inside = 0;
  // Samples of `own` (their frame) carried into `other` by `other_from_own`.
  auto accumulate = [&](const DensityField& own, const DensityField& other, const Eigen::Matrix3Xd& p,
                        const Sim3d& other_from_own) {
    Eigen::Matrix3Xd moved(3, p.cols());
    for (Eigen::Index i = 0; i < p.cols(); ++i) moved.col(i) = other_from_own * Eigen::Vector3d(p.col(i));
    const Eigen::VectorXd a = Occupancy(own, p, occupancy_scale), b = Occupancy(other, moved, occupancy_scale);
    for (Eigen::Index i = 0; i < p.cols(); ++i) {
      const bool in = other.box.contains(Eigen::Vector3d(moved.col(i)));
      const double bi = in ? b(i) : 0.0;
      ab += a(i) * bi;
      aa_bb += a(i) * a(i) + bi * bi;
      if (in) {
        squared += (a(i) - bi) * (a(i) - bi);
        ++inside;
      }
    }
  };
  accumulate(source, target, samples.source, target_from_source);
  accumulate(target, source, samples.target, source_from_target);
  FieldAgreement g;
  g.samples = static_cast<int>(samples.source.cols() + samples.target.cols());
  g.inside_fraction = g.samples > 0 ? double(inside) / g.samples : 0;
  g.cost = inside > 0 ? squared / inside : 0;
  g.confidence = aa_bb > 0 ? 2 * ab / aa_bb : 0;
  return g;
}

size_t ChooseCandidate(const DensityField& source, const DensityField& target, const FieldAgreementSamples& samples,
                       const std::vector<Sim3d>& poses, double occupancy_scale, std::vector<FieldAgreement>* scores) {
  if (poses.empty()) throw std::invalid_argument("ChooseCandidate: no candidate poses");
  size_t best = 0;
  std::vector<FieldAgreement> s;
  for (size_t k = 0; k < poses.size(); ++k) {
    s.push_back(ScoreFieldAgreement(source, target, samples, poses[k], occupancy_scale));
    if (s[k].confidence > s[best].confidence) best = k;
  }
  if (scores) *scores = std::move(s);
  return best;
}

}  // namespace nerfreg
