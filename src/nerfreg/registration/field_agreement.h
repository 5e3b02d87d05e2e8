#pragma once
// The candidate choice: every candidate's pose scored on one common sample set with one measure
// (FieldAgreement, registration/registration_result.h), so candidates of different methods compare
// and the kept one's confidence means the same whichever method found it (docs/registration.md,
// "Confidence").
#include <Eigen/Core>
#include <vector>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/field_alignment.h"
#include "nerfreg/registration/registration_result.h"

namespace nerfreg {

// The common samples: a band across each block's surface (its occupied points, each with two
// Gaussian offsets of 0.25 and 0.5 x `spread`), at most max_samples per block, drawn once with
// `seed`; source samples in the source frame, target samples in the target frame.
struct FieldAgreementSamples {
  Eigen::Matrix3Xd source;  // [3, Ns]
  Eigen::Matrix3Xd target;  // [3, Nt]
};
FieldAgreementSamples DrawFieldAgreementSamples(const Eigen::Matrix3Xd& source_points,
                                                const Eigen::Matrix3Xd& target_points, double spread, int max_samples,
                                                unsigned seed);

FieldAgreement ScoreFieldAgreement(const DensityField& source, const DensityField& target,
                                   const FieldAgreementSamples& samples, const Sim3d& target_from_source,
                                   double occupancy_scale);

// auto's choice: every pose scored on the same samples; the index of the highest confidence (the
// first on ties). `scores` (optional) gets each pose's agreement. Throws std::invalid_argument on
// no poses.
size_t ChooseCandidate(const DensityField& source, const DensityField& target, const FieldAgreementSamples& samples,
                       const std::vector<Sim3d>& target_from_source, double occupancy_scale,
                       std::vector<FieldAgreement>* scores = nullptr);

}  // namespace nerfreg
