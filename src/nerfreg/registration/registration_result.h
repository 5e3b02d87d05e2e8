#pragma once
// One result type for every registration method and stage (the network on grids, FPFH + RANSAC /
// FGR, each ICP, the field refinement, the candidates of `reg register`, the rows of `reg eval
// --pairs`, the edges of `reg register-many`): the pose is a Sim3d target_from_source throughout,
// converted from the lower libraries' own results (DregRegistration, ClassicalRegistrationResult,
// FieldAlignmentResult) once, where a stage reads them.
#include <string>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

// How well two density fields agree at a pose, on one fixed sample set (FieldAgreementSamples,
// registration/field_agreement.h). `confidence` is the soft Dice coefficient of the two
// occupancies o = 1 - exp(-scale * sigma) over every sample: 2 sum(a b) / sum(a^2 + b^2), a the
// sample's occupancy in its own block, b the other block's at the sample moved there (0 where it
// falls outside the other block's box, which vouches for nothing there). In [0, 1]: 1 when the
// fields coincide (a block with itself at the identity), near 0 when occupied samples land in
// empty space. docs/registration.md.
struct FieldAgreement {
  double confidence = 0;
  double cost = 0;             // mean (a - b)^2 over the samples inside the other box (AlignFields' cost)
  double inside_fraction = 0;  // share of samples inside the other block's box
  int samples = 0;             // samples in all
};
Json FieldAgreementJson(const FieldAgreement& agreement);

// The points a method registered, which the later stages (the field refinement's samples) and the
// overlays reuse: the grids' surface masks, or the inputs' occupied points.
enum class RegistrationCloud { kGridMask, kOccupied };

struct RegistrationResult {
  Sim3d target_from_source;  // x_target = target_from_source * x_source
  // The method and the stages it went through, e.g. "dreg+icp+block+field", "ransac-grid+icp".
  std::string method;
  // The method's own score, in [0, 1]: the network's confidence or the FPFH fitness (fraction of
  // inliers); not comparable across methods. 0 when nothing could be registered (empty grids).
  double method_score = 0;
  // Once scored on the common samples (ScoreFieldAgreement): agreement.confidence, the same
  // measure for every method; 0 before.
  double confidence = 0;
  FieldAgreement agreement;
  double seconds = 0;                        // this registration's stages (inputs already loaded)
  int source_points = 0, target_points = 0;  // points the method registered (grids: masked voxels)
  int half_turn = -1;                        // grid ICP: the half-turn kept (-1: none, 0-8: the axis)
  RegistrationCloud cloud = RegistrationCloud::kGridMask;
  Json field;                     // the field refinement's record (null without it)
  Json details = Json::object();  // what T.json records of the method (seconds, points, block_icp, ...)

  // {method, confidence, method_score, agreement, field, target_from_source}: a candidate as T.json
  // lists those not chosen.
  Json ToJson() const;
};

}  // namespace nerfreg
