#pragma once
// Scale-free registration (ScaleMode::kFree): two captures made separately never share a unit
// (every SfM run, dataparser and splat trainer picks its own), while the grid extraction's fixed
// cube, the classical features' radii and the 3D CNN all assume the size the project's objects
// have. So each input is first moved into a normalised frame of its own, centred on its occupied
// points' centroid and scaled so that their RMS distance from it is kNormalizedRadius; the
// methods run there, where the two inputs differ in scale only by what each capture saw, and the
// point stages estimate that residual scale (RANSAC and ICP with scaling). The pose found between
// the normalised frames is then carried back: target_from_source = target_from_normalized *
// normalized_target_from_normalized_source * normalized_from_source.
#include <Eigen/Core>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg/registration_input.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// The RMS radius (scene units) of an input's occupied points in its normalised frame. Chosen so
// that the procedural and mesh objects the defaults were tuned on (2.5 across) keep about their
// size: normalisation then leaves such inputs nearly as they were.
inline constexpr double kNormalizedRadius = 1.0;

// Throws InputError(file, field, "a scale in [0.001, 1000], got X") unless scale is in
// [kMinSim3Scale, kMaxSim3Scale] (geometry/rigid3.h).
void CheckScaleInRange(double scale, const std::string& file, const std::string& field);

// The RMS distance of `points` ([3, N]) from their centroid, after dropping the points farther
// than 3 x the median distance (floaters); centroid: the kept points' mean. Rotation invariant.
// 0 for fewer than 2 points.
double OccupiedRadius(const Eigen::Matrix3Xd& points, Eigen::Vector3d* centroid = nullptr);

// normalized_from_input: x -> k (x - c), with c and the radius r of OccupiedRadius(points) and
// k = kNormalizedRadius / r. Throws InputError naming `file` ("occupied cells") when the points
// span nothing (r == 0), and when 1 / k is outside [kMinSim3Scale, kMaxSim3Scale].
Sim3d NormalizationFor(const Eigen::Matrix3Xd& points, const std::string& file);

// Moves `input` by `normalized_from_input` for its lifetime and back when it ends (also on an
// exception), so a borrowed input is left as it was.
class ScopedNormalization {
 public:
  ScopedNormalization(RegistrationInput& input, const Sim3d& normalized_from_input)
      : input_(input), normalized_from_input_(normalized_from_input) {
    input_.Move(normalized_from_input_);
  }
  ~ScopedNormalization() { input_.Move(normalized_from_input_.Inverse()); }
  ScopedNormalization(const ScopedNormalization&) = delete;
  ScopedNormalization& operator=(const ScopedNormalization&) = delete;

 private:
  RegistrationInput& input_;
  Sim3d normalized_from_input_;
};

// {scale, centroid, radius}: what T.json records of one input's normalisation.
Json NormalizationJson(const Sim3d& normalized_from_input, double radius);

}  // namespace nerfreg
