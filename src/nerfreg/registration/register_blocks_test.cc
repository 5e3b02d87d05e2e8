#include "nerfreg/registration/register_blocks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "nerfreg/data/splat_test_util.h"
#include "nerfreg/geometry/alignment.h"
#include "nerfreg/registration/point_registration.h"
#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

// An asymmetric object as a smooth density (as reg/field_alignment_test.cc): two ellipsoids and a
// box, sigma = 60 * sigmoid(-d / 0.02), a surface ~0.05 thick like a trained block's.
double ShapeDistance(const Eigen::Vector3d& x) {
  const double e1 = ((x - Eigen::Vector3d(0.3, 0.0, 0.1)).cwiseQuotient(Eigen::Vector3d(0.5, 0.3, 0.25))).norm() - 1;
  const double e2 = ((x - Eigen::Vector3d(-0.4, 0.35, -0.1)).cwiseQuotient(Eigen::Vector3d(0.2, 0.45, 0.2))).norm() - 1;
  const Eigen::Vector3d q = (x - Eigen::Vector3d(-0.1, -0.4, 0.3)).cwiseAbs() - Eigen::Vector3d(0.3, 0.12, 0.2);
  const double box = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  return std::min({e1 * 0.25, e2 * 0.2, box});
}

// A ball of radius 0.4 beside where the shape is (another object).
double BallDistance(const Eigen::Vector3d& x) { return (x - Eigen::Vector3d(0.9, 0.9, 0.0)).norm() - 0.4; }

// The object seen in a frame where x_frame = frame_from_shape * x_shape.
DensityField Field(double (*distance)(const Eigen::Vector3d&), const Sim3d& frame_from_shape) {
  DensityField f;
  const Sim3d shape_from_frame = frame_from_shape.Inverse();
  f.density = [shape_from_frame, distance](const torch::Tensor& x) {
    const torch::Tensor c = x.to(torch::kDouble).contiguous();
    torch::Tensor out = torch::empty({c.size(0)}, torch::kFloat);
    const double* p = c.data_ptr<double>();
    float* o = out.data_ptr<float>();
    for (int64_t i = 0; i < c.size(0); ++i) {
      const double d = distance(shape_from_frame * Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
      o[i] = static_cast<float>(60.0 / (1.0 + std::exp(d / 0.02)));
    }
    return out;
  };
  f.box = Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-4), Eigen::Vector3d::Constant(4));
  return f;
}

// Points within half a cell of the surface (what a block's occupied points give), in the frame.
Eigen::Matrix3Xd SurfacePoints(double (*distance)(const Eigen::Vector3d&), const Sim3d& frame_from_shape, double cell) {
  std::vector<Eigen::Vector3d> pts;
  for (double x = -1.5; x <= 1.5; x += cell)
    for (double y = -1.5; y <= 1.5; y += cell)
      for (double z = -1.5; z <= 1.5; z += cell) {
        const Eigen::Vector3d p(x, y, z);
        if (std::abs(distance(p)) < 0.5 * cell) pts.push_back(frame_from_shape * p);
      }
  Eigen::Matrix3Xd m(3, pts.size());
  for (size_t i = 0; i < pts.size(); ++i) m.col(i) = pts[i];
  return m;
}

Sim3d Pose(double deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  return Sim3d(1.0, Eigen::Quaterniond(Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized())), t);
}

// auto's choice: a candidate at the truth and one a half-turn off (the network's typical failure
// on near-symmetric objects), scored on the same samples: the truth is kept, whatever the order,
// and its confidence is that of one field with itself (~1).
TEST(RegisterBlocks, ChooseCandidateKeepsTheTruthOverItsHalfTurn) {
  const Sim3d source_from_shape = Pose(40, {1, 2, 0.5}, {0.2, -0.1, 0.3});
  const Sim3d target_from_shape = Pose(-70, {0.3, -1, 1}, {-0.1, 0.2, 0.05});
  const Sim3d truth = target_from_shape * source_from_shape.Inverse();
  const DensityField source = Field(ShapeDistance, source_from_shape), target = Field(ShapeDistance, target_from_shape);
  const FieldAgreementSamples samples =
      DrawFieldAgreementSamples(SurfacePoints(ShapeDistance, source_from_shape, 0.06),
                                SurfacePoints(ShapeDistance, target_from_shape, 0.06), 0.11, 3000, 0);
  // The half-turn about the object's long axis through its centre, as a flipped dreg answer is.
  const Eigen::Vector3d centre = target_from_shape * Eigen::Vector3d(0.1, 0, 0.1);
  const Sim3d half_turn = Pose(180, target_from_shape.rotation * Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero());
  const Sim3d about_centre = Sim3d(1.0, Eigen::Quaterniond::Identity(), centre) * half_turn *
                             Sim3d(1.0, Eigen::Quaterniond::Identity(), -centre);
  const Sim3d wrong = about_centre * truth;
  std::vector<FieldAgreement> scores;
  EXPECT_EQ(ChooseCandidate(source, target, samples, {wrong, truth}, 0.05, &scores), 1u);
  ASSERT_EQ(scores.size(), 2u);
  EXPECT_GT(scores[1].confidence, 0.95);
  EXPECT_LT(scores[0].confidence, scores[1].confidence - 0.2) << scores[0].confidence;
  EXPECT_LT(scores[1].cost, scores[0].cost);
  EXPECT_EQ(ChooseCandidate(source, target, samples, {truth, wrong}, 0.05), 0u);
  EXPECT_THROW(ChooseCandidate(source, target, samples, {}, 0.05), std::invalid_argument);
}

// The confidence is comparable across pairs: a field with itself scores ~1, two different objects
// (the shape against a ball) score low at poses that do not lay one inside the other.
TEST(RegisterBlocks, ConfidenceIsHighForOneObjectAndLowForTwo) {
  const Sim3d id;
  const DensityField shape = Field(ShapeDistance, id), ball = Field(BallDistance, id);
  const Eigen::Matrix3Xd shape_points = SurfacePoints(ShapeDistance, id, 0.06);
  const FieldAgreementSamples self = DrawFieldAgreementSamples(shape_points, shape_points, 0.11, 3000, 1);
  EXPECT_GT(ScoreFieldAgreement(shape, shape, self, id, 0.05).confidence, 0.99);
  const FieldAgreementSamples other =
      DrawFieldAgreementSamples(shape_points, SurfacePoints(BallDistance, id, 0.06), 0.11, 3000, 1);
  for (const Sim3d& pose : {id, Pose(90, {0, 0, 1}, {0.5, 0.5, 0}), Pose(30, {1, 0, 0}, {-0.5, 0.2, 0.4})}) {
    const FieldAgreement g = ScoreFieldAgreement(shape, ball, other, pose, 0.05);
    EXPECT_LT(g.confidence, 0.5) << pose.ToMatrix();
    EXPECT_EQ(g.samples, other.source.cols() + other.target.cols());
  }
}

// A box, symmetric under a half-turn about each of its axes.
double BoxDistance(const Eigen::Vector3d& x) {
  const Eigen::Vector3d q = x.cwiseAbs() - Eigen::Vector3d(0.6, 0.35, 0.2);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// The source's occupied points turned by `deg` about their principal axis `axis` through their
// centroid, as TurnedPoses turns them: x -> R (x - c) + c.
Sim3d TurnAboutAxis(const Eigen::Matrix3Xd& points, int axis, double deg) {
  Eigen::Vector3d c;
  const Eigen::Matrix3d axes = PrincipalAxes(points, &c);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(deg * M_PI / 180, axes.col(axis)).toRotationMatrix();
  return Sim3d(1.0, Eigen::Quaterniond(r), c - r * c);
}

// The turn check on an asymmetric object: from a pose a half-turn off, one turn comes back to the
// truth and scores clearly higher (it would replace the pose); from the truth, every turn that
// does not come back scores well below it. On a box, which looks the same turned, a turn scores
// as well as the truth: the margin JudgeRegistration reads is below kTurnAmbiguityMargin.
TEST(RegisterBlocks, TurnedPosesFindTheTruthFromAHalfTurnAndSeeASymmetry) {
  const Sim3d source_from_shape = Pose(40, {1, 2, 0.5}, {0.2, -0.1, 0.3});
  const Sim3d target_from_shape = Pose(-70, {0.3, -1, 1}, {-0.1, 0.2, 0.05});
  const Sim3d truth = target_from_shape * source_from_shape.Inverse();
  for (auto* distance : {ShapeDistance, BoxDistance}) {
    const bool box = distance == BoxDistance;
    const DensityField source = Field(distance, source_from_shape), target = Field(distance, target_from_shape);
    const Eigen::Matrix3Xd source_points = SurfacePoints(distance, source_from_shape, 0.06);
    const Eigen::Matrix3Xd target_points = SurfacePoints(distance, target_from_shape, 0.06);
    const FieldAgreementSamples samples = DrawFieldAgreementSamples(source_points, target_points, 0.11, 3000, 0);
    const double at_truth = ScoreFieldAgreement(source, target, samples, truth, 0.05).confidence;
    EXPECT_GT(at_truth, 0.95);
    double other = -1;
    for (const TurnedPose& t : TurnedPoses(source, target, source_points, target_points, samples, truth, 0.05, 0.05)) {
      if (RotationErrorDeg(t.target_from_source.rotation, truth.rotation) > 2)
        other = std::max(other, t.agreement.confidence);
    }
    if (box) {
      EXPECT_GT(other, at_truth - kTurnAmbiguityMargin) << "a box turned by half agrees with itself";
      continue;
    }
    EXPECT_LT(other, at_truth - kTurnAmbiguityMargin) << at_truth;
    const Sim3d wrong = truth * TurnAboutAxis(source_points, 1, 180);
    const double at_wrong = ScoreFieldAgreement(source, target, samples, wrong, 0.05).confidence;
    const std::vector<TurnedPose> turned =
        TurnedPoses(source, target, source_points, target_points, samples, wrong, 0.05, 0.05);
    ASSERT_EQ(turned.size(), 9u);
    const TurnedPose& best = *std::max_element(turned.begin(), turned.end(), [](const auto& a, const auto& b) {
      return a.agreement.confidence < b.agreement.confidence;
    });
    EXPECT_LT(RotationErrorDeg(best.target_from_source.rotation, truth.rotation), 1.0);
    EXPECT_GT(best.agreement.confidence, at_wrong + kTurnSwitchMargin) << at_wrong;
  }
}

// A confident pose that a turn matches nearly as well is untrusted, with the reason; a clear
// margin, or no check (NaN), leaves it registered.
TEST(RegisterBlocks, APoseATurnMatchesNearlyAsWellIsUntrusted) {
  BlockRegistrationResult r;
  r.agreeing_candidates = 2;
  r.confidence = 0.66;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  r.turn_margin = kTurnAmbiguityMargin - 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
  EXPECT_NE(r.status_reason.find("turned about one of its axes"), std::string::npos) << r.status_reason;
  r.turn_margin = kTurnAmbiguityMargin + 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  EXPECT_TRUE(r.status_reason.empty());
  // Colour tells the turns apart: trusted again, but only by the margin.
  r.turn_margin = kTurnAmbiguityMargin - 0.01;
  r.turn_colour_margin = kTurnColourMargin + 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  r.turn_colour_margin = std::numeric_limits<double>::quiet_NaN();  // colour could not tell them apart
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
  EXPECT_NE(r.status_reason.find("colours do not tell"), std::string::npos) << r.status_reason;
}

// A box's splats, two samplings in two frames: its shape looks the same turned by half about each
// of its axes. Coloured by octant, the turn check's colour step keeps the truth and trusts it; in
// one colour it cannot tell the turns apart and the result is untrusted.
Splats BoxSplats(const Sim3d& frame_from_shape, bool two_colours, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d half(0.6, 0.35, 0.2);
  const int n = 1500;
  Splats s;
  s.Resize(n, 0, false);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d p(u(rng) * half.x(), u(rng) * half.y(), u(rng) * half.z());
    const int axis = i % 3;
    p(axis) = (u(rng) > 0 ? 1 : -1) * half(axis);  // on a face
    // Each channel bright on one side of an axis (SH degree 0: rgb = 0.5 + C0 f_dc): every half
    // turn about an axis swaps the sides of the other two.
    Eigen::Vector3f colour(1.5f, -1.5f, -1.5f);
    if (two_colours)
      for (int k = 0; k < 3; ++k) colour(k) = p(k) > 0 ? 1.5f : -1.5f;
    s.position.col(i) = (frame_from_shape * p).cast<float>();
    s.f_dc.col(i) = colour;
    s.log_scale.col(i).setConstant(std::log(0.035f));
    s.opacity(i) = 3.f;
    s.rotation.col(i) = Eigen::Vector4f(1, 0, 0, 0);
  }
  return s;
}

TEST(RegisterBlocks, ColourTellsTheTurnsOfASymmetricShapeApart) {
  const Sim3d source_from_shape = Pose(40, {1, 2, 0.5}, {0.2, -0.1, 0.3});
  const Sim3d target_from_shape = Pose(-70, {0.3, -1, 1}, {-0.1, 0.2, 0.05});
  const Sim3d truth = target_from_shape * source_from_shape.Inverse();
  BlockRegistrationOptions o;  // ransac, refined on the fields, the scale free
  o.field.max_samples = 2000;  // the test's time
  o.voxel = 0.1;
  o.max_points = 1000;
  o.seed = 0;
  for (const bool two_colours : {true, false}) {
    SplatInput source(BoxSplats(source_from_shape, two_colours, 1), SplatFieldOptions());
    SplatInput target(BoxSplats(target_from_shape, two_colours, 2), SplatFieldOptions());
    const BlockRegistrationResult r = RegisterBlocks(source, target, o, nullptr);
    const double rot = RotationErrorDeg(r.target_from_source.rotation, truth.rotation);
    std::printf("box %s: %.2f deg, status %s, turn margin %.3f, colour %s\n",
                two_colours ? "by octant" : "in one colour", rot, r.status.c_str(), r.turn_margin,
                r.turns.contains("colour") ? r.turns["colour"].dump().c_str() : "-");
    ASSERT_TRUE(r.turns.contains("colour")) << "the shape looks alike turned: " << r.turns.dump();
    EXPECT_LT(r.turn_margin, kTurnAmbiguityMargin) << r.turns.dump();
    if (two_colours) {
      EXPECT_EQ(r.status, "registered") << r.status_reason;
      EXPECT_LT(rot, 2.0) << r.turns.dump();
      EXPECT_GE(r.turn_colour_margin, kTurnColourMargin);
      EXPECT_TRUE(r.reverse.is_null()) << "registered one way: the other way does not run";
    } else {
      EXPECT_EQ(r.status, "untrusted");
      EXPECT_NE(r.status_reason.find("colours do not tell"), std::string::npos) << r.status_reason;
      // The other way (target onto source) ran, and a box in one colour cannot register that way
      // either.
      ASSERT_TRUE(r.reverse.is_object());
      EXPECT_FALSE(r.reverse["kept"].get<bool>());
      EXPECT_EQ(r.reverse["other_way"]["status"], "untrusted");
      EXPECT_NE(r.status_reason.find("the other way (target onto source) is untrusted too"), std::string::npos)
          << r.status_reason;
    }
  }
}

TEST(RegisterBlocks, NamesRoundTripAndBadNamesAreInputErrors) {
  for (auto m :
       {RegistrationMethod::kAuto, RegistrationMethod::kDreg, RegistrationMethod::kRansac, RegistrationMethod::kFgr})
    EXPECT_EQ(RegistrationMethodFromName(RegistrationMethodName(m)), m);
  for (auto r : {RegistrationRefinement::kNone, RegistrationRefinement::kIcp, RegistrationRefinement::kField})
    EXPECT_EQ(RegistrationRefinementFromName(RegistrationRefinementName(r)), r);
  for (auto s : {DregSolver::kProcrustes, DregSolver::kRansac}) EXPECT_EQ(DregSolverFromName(DregSolverName(s)), s);
  EXPECT_EQ(RegistrationMethodName(RegistrationMethod::kAuto), "auto");
  try {
    RegistrationMethodFromName("icp");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "--method: expected auto, dreg, ransac or fgr, got icp");
  }
}

TEST(RegisterBlocks, OptionsCheckNamesTheFlag) {
  auto message = [](const BlockRegistrationOptions& o) {
    try {
      o.Check();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  BlockRegistrationOptions o;
  EXPECT_EQ(message(o), "no error");
  o.field.iterations = -1;
  EXPECT_EQ(message(o), "--field-iterations: expected >= 0");
  o = BlockRegistrationOptions();
  o.method = RegistrationMethod::kDreg;
  o.grid.resolution = 24;
  EXPECT_NE(message(o).find("--grid-resolution"), std::string::npos);
  o.method = RegistrationMethod::kRansac;  // no network: any resolution the grid allows
  EXPECT_EQ(message(o), "no error");
  o = BlockRegistrationOptions();
  o.dreg_passes = 0;
  EXPECT_NE(message(o).find("--dreg-passes"), std::string::npos);
  o = BlockRegistrationOptions();
  o.voxel = 0;
  EXPECT_NE(message(o).find("--voxel"), std::string::npos);
}

// The options T.json records read back as the same options.
TEST(RegisterBlocks, OptionsRoundTripThroughJson) {
  BlockRegistrationOptions o;
  o.method = RegistrationMethod::kAuto;
  o.refine = RegistrationRefinement::kIcp;
  o.min_confidence = 0.45;
  o.field.iterations = 7;
  o.field.occupancy_scale = 0.08;
  o.field.max_samples = 1234;
  o.grid.resolution = 48;
  o.weights = "models/x.pt";
  o.config = "cpu";
  o.min_density = 3.5;
  o.voxel = 0.04;
  o.max_points = 0;
  o.icp_points = IcpPoints::kMask;
  o.flips = false;
  o.icp_distance = 1.5;
  o.seed = 4000000000u;
  o.dreg_solver = DregSolver::kRansac;
  o.dreg_passes = 3;
  o.block_icp = false;
  o.check_turns = false;
  o.reverse_untrusted = false;
  const Json j = Json::parse(o.ToJson().dump());  // through text, as T.json is read
  const BlockRegistrationOptions r = BlockRegistrationOptions::FromJson(j, "T.json");
  EXPECT_EQ(r.ToJson(), o.ToJson());
  EXPECT_EQ(r.method, o.method);
  EXPECT_EQ(r.refine, o.refine);
  EXPECT_EQ(r.field.iterations, 7);
  EXPECT_DOUBLE_EQ(r.field.occupancy_scale, 0.08);
  EXPECT_EQ(r.seed, 4000000000u);
  EXPECT_EQ(r.dreg_solver, DregSolver::kRansac);
  EXPECT_FALSE(r.flips);
  EXPECT_FALSE(r.block_icp);
  EXPECT_FALSE(r.check_turns);
  EXPECT_FALSE(r.reverse_untrusted);
  EXPECT_TRUE(BlockRegistrationOptions().reverse_untrusted);  // the default
  // A T.json written before the turn check and the other way: neither ran, though today's defaults
  // run both.
  Json older = BlockRegistrationOptions().ToJson();
  ASSERT_TRUE(older["check_turns"].get<bool>() && older["reverse_untrusted"].get<bool>());
  older.erase("check_turns");
  older.erase("reverse_untrusted");
  const BlockRegistrationOptions old = BlockRegistrationOptions::FromJson(older, "T.json");
  EXPECT_FALSE(old.check_turns);
  EXPECT_FALSE(old.reverse_untrusted);
  Json bad = j;
  bad["refine"] = "sometimes";
  EXPECT_THROW(BlockRegistrationOptions::FromJson(bad, "T.json"), InputError);
  bad = j;
  bad.erase("voxel");
  EXPECT_THROW(BlockRegistrationOptions::FromJson(bad, "T.json"), InputError);
}

// The scale mode is recorded; a T.json written before it (no "scale") was rigid.
TEST(RegisterBlocks, ScaleModeRoundTripsAndOlderFilesReadAsFixed) {
  EXPECT_EQ(BlockRegistrationOptions().scale, ScaleMode::kFree);
  BlockRegistrationOptions o;
  o.scale = ScaleMode::kFixed;
  Json j = o.ToJson();
  EXPECT_EQ(j["scale"], "fixed");
  EXPECT_EQ(BlockRegistrationOptions::FromJson(j, "T.json").scale, ScaleMode::kFixed);
  j["scale"] = "free";
  EXPECT_EQ(BlockRegistrationOptions::FromJson(j, "T.json").scale, ScaleMode::kFree);
  j.erase("scale");
  EXPECT_EQ(BlockRegistrationOptions::FromJson(j, "T.json").scale, ScaleMode::kFixed);
  j["scale"] = "elastic";
  EXPECT_THROW(BlockRegistrationOptions::FromJson(j, "T.json"), InputError);
}

// Untrusted: nothing confirmed the kept pose and its confidence is low for the inputs' kinds.
TEST(RegisterBlocks, AResultIsUntrustedWhenNothingConfirmsALowConfidence) {
  BlockRegistrationResult r;
  r.source_kind = r.target_kind = "splats";
  r.agreeing_candidates = 0;
  r.confidence = kUntrustedConfidence - 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
  EXPECT_NE(r.status_reason.find("no other candidate ended at the kept pose"), std::string::npos) << r.status_reason;
  EXPECT_EQ(r.ToJson()["status"], "untrusted");
  r.agreeing_candidates = 1;  // confirmed
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  EXPECT_TRUE(r.status_reason.empty());
  r.agreeing_candidates = -1;  // one candidate: the confidence alone
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
  r.confidence = kUntrustedConfidence;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  // A block against splats agrees less when right: its own threshold.
  r.target_kind = "nerf";
  r.agreeing_candidates = 0;
  r.confidence = kUntrustedConfidenceMixed + 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  r.confidence = kUntrustedConfidenceMixed - 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
}

// Agreement does not override a very low confidence: candidates can end in the same wrong pose
// (object 6001's captures scaled by 2 with --scale fixed: one candidate agreed at 0.16, 4.9 deg
// off). A confirmed pose needs its kind's floor; an unconfirmed one the higher threshold.
TEST(RegisterBlocks, AConfirmedPoseStillNeedsAConfidenceFloor) {
  BlockRegistrationResult r;
  r.source_kind = r.target_kind = "splats";
  r.agreeing_candidates = 1;
  r.confidence = 0.16;  // the measured wrong confirmed pose
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
  EXPECT_NE(r.status_reason.find("confidence 0.16 < 0.50 although 1 other candidate ended at the kept pose"),
            std::string::npos)
      << r.status_reason;
  r.agreeing_candidates = 2;
  r.confidence = kConfirmedConfidenceFloor - 0.01;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "untrusted");
  EXPECT_NE(r.status_reason.find("although 2 other candidates ended"), std::string::npos) << r.status_reason;
  // Confirmed and at the floor, though below the unconfirmed threshold: registered.
  r.confidence = kConfirmedConfidenceFloor;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");
  EXPECT_TRUE(r.status_reason.empty());
  // The same confidence unconfirmed (0 agreeing, or one candidate): untrusted by the threshold.
  for (int agreeing : {0, -1}) {
    r.agreeing_candidates = agreeing;
    JudgeRegistration(&r);
    EXPECT_EQ(r.status, "untrusted") << agreeing;
    EXPECT_EQ(r.status_reason.find("although"), std::string::npos) << r.status_reason;
  }
  // Unconfirmed and high: registered.
  r.confidence = kUntrustedConfidence + 0.1;
  JudgeRegistration(&r);
  EXPECT_EQ(r.status, "registered");

  // A block against splats: its own, lower floor and threshold, in either direction.
  for (const char* block_side : {"source", "target"}) {
    r.source_kind = r.target_kind = "splats";
    (std::string(block_side) == "source" ? r.source_kind : r.target_kind) = "nerf";
    r.agreeing_candidates = 1;
    r.confidence = kConfirmedConfidenceFloorMixed;
    JudgeRegistration(&r);
    EXPECT_EQ(r.status, "registered") << block_side;
    r.confidence = kConfirmedConfidenceFloorMixed - 0.01;
    JudgeRegistration(&r);
    EXPECT_EQ(r.status, "untrusted") << block_side;
    EXPECT_NE(r.status_reason.find("< 0.27 although 1 other candidate"), std::string::npos) << r.status_reason;
    r.agreeing_candidates = 0;
    r.confidence = kUntrustedConfidenceMixed;
    JudgeRegistration(&r);
    EXPECT_EQ(r.status, "registered") << block_side;
    r.confidence = kConfirmedConfidenceFloorMixed;  // enough when confirmed, not alone
    JudgeRegistration(&r);
    EXPECT_EQ(r.status, "untrusted") << block_side;
  }
  // Floors below the unconfirmed thresholds, mixed below same-kind.
  EXPECT_LT(kConfirmedConfidenceFloor, kUntrustedConfidence);
  EXPECT_LT(kConfirmedConfidenceFloorMixed, kUntrustedConfidenceMixed);
  EXPECT_LT(kConfirmedConfidenceFloorMixed, kConfirmedConfidenceFloor);
}

Eigen::Matrix4d Matrix4FromJson(const Json& j) { return JsonField(j, "T.json").Matrix(4, 4); }

// A result as the job makes it: `pose`, judged `status`, with two candidates (the kept one first).
BlockRegistrationResult JudgedResult(const Sim3d& pose, const std::string& status, double confidence) {
  BlockRegistrationResult r;
  r.target_from_source = pose;
  r.method = "ransac+icp+field";
  r.confidence = confidence;
  r.status = status;
  r.status_reason = status == "untrusted" ? "confidence low" : "";
  r.seconds = 2;
  r.source_kind = "nerf";
  r.target_kind = "splats";
  r.source_cloud = Eigen::Matrix3Xd::Zero(3, 4);
  r.target_cloud = Eigen::Matrix3Xd::Ones(3, 7);
  r.normalization = {{"source", {{"scale", 2.0}}}, {"target", {{"scale", 0.5}}}};
  RegistrationResult kept = r, other = r;
  other.target_from_source = Pose(90, {0, 0, 1}, {1, 0, 0}) * pose;
  other.method = "dreg+icp+field";
  r.candidates = {kept, other};
  r.chosen = 0;
  return r;
}

// An untrusted result is registered the other way (target onto source); where that one is
// registered, its inverse is kept, and only there. `one_way` is the job each way; here it returns
// judged results, so each branch of the rule is seen.
TEST(RegisterBlocks, AnUntrustedResultIsRegisteredTheOtherWay) {
  const Sim3d forward_pose = Pose(25, {1, 0, 0}, {0.3, 0, 0});
  const Sim3d back_pose(2.5, Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.2, 1, -0.3).normalized())),
                        Eigen::Vector3d(-0.2, 0.5, 0.1));  // target -> source
  std::vector<bool> calls;
  auto ways = [&](const std::string& forward_status, const std::string& back_status) {
    return [&, forward_status, back_status](bool reversed) {
      calls.push_back(reversed);
      return reversed ? JudgedResult(back_pose, back_status, 0.66) : JudgedResult(forward_pose, forward_status, 0.43);
    };
  };

  // Untrusted one way, registered the other: the other way's pose, inverted.
  calls.clear();
  BlockRegistrationResult r = RegisterEitherWay(ways("untrusted", "registered"), true);
  EXPECT_EQ(calls, (std::vector<bool>{false, true}));
  EXPECT_EQ(r.status, "registered");
  EXPECT_TRUE(r.target_from_source.ToMatrix().isApprox(back_pose.Inverse().ToMatrix(), 1e-12));
  EXPECT_NEAR(r.target_from_source.scale, 1 / 2.5, 1e-12);
  EXPECT_TRUE((r.target_from_source * back_pose).ToMatrix().isApprox(Eigen::Matrix4d::Identity(), 1e-12));
  EXPECT_EQ(r.method, "ransac+icp+field+reverse");
  EXPECT_EQ(r.Chosen().method, r.method);
  EXPECT_TRUE(r.candidates[1].target_from_source.ToMatrix().isApprox(
      (Pose(90, {0, 0, 1}, {1, 0, 0}) * back_pose).Inverse().ToMatrix(), 1e-12));
  EXPECT_DOUBLE_EQ(r.confidence, 0.66);
  EXPECT_DOUBLE_EQ(r.seconds, 4);  // both ways
  // The inputs' roles swapped back: the kept result is about the user's source and target.
  EXPECT_EQ(r.source_kind, "splats");
  EXPECT_EQ(r.target_kind, "nerf");
  EXPECT_EQ(r.source_cloud.cols(), 7);
  EXPECT_EQ(r.target_cloud.cols(), 4);
  EXPECT_EQ(r.normalization["source"]["scale"], 0.5);
  ASSERT_TRUE(r.reverse.is_object());
  EXPECT_TRUE(r.reverse["kept"].get<bool>());
  EXPECT_EQ(r.reverse["other_way"]["status"], "untrusted");
  EXPECT_TRUE(Matrix4FromJson(r.reverse["other_way"]["target_from_source"]).isApprox(forward_pose.ToMatrix(), 1e-12));
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings[0].find("source -> target was untrusted (confidence 0.43)"), std::string::npos);
  const Json j = r.ToJson();
  EXPECT_EQ(j["status"], "registered");
  EXPECT_TRUE(j["reverse"]["kept"].get<bool>());
  EXPECT_TRUE(Matrix4FromJson(j["target_from_source"]).isApprox(back_pose.Inverse().ToMatrix(), 1e-12));

  // Untrusted both ways: the first way's result, saying so.
  calls.clear();
  r = RegisterEitherWay(ways("untrusted", "untrusted"), true);
  EXPECT_EQ(calls, (std::vector<bool>{false, true}));
  EXPECT_EQ(r.status, "untrusted");
  EXPECT_TRUE(r.target_from_source.ToMatrix().isApprox(forward_pose.ToMatrix(), 1e-12));
  EXPECT_EQ(r.method, "ransac+icp+field");
  EXPECT_EQ(r.status_reason, "confidence low; the other way (target onto source) is untrusted too (confidence 0.66)");
  EXPECT_FALSE(r.reverse["kept"].get<bool>());
  EXPECT_DOUBLE_EQ(r.seconds, 4);

  // Registered the first way, or the other way not asked for: one way only.
  for (const auto& [forward_status, reverse] :
       {std::pair<std::string, bool>{"registered", true}, std::pair<std::string, bool>{"untrusted", false}}) {
    calls.clear();
    r = RegisterEitherWay(ways(forward_status, "registered"), reverse);
    EXPECT_EQ(calls, (std::vector<bool>{false}));
    EXPECT_EQ(r.status, forward_status);
    EXPECT_TRUE(r.target_from_source.ToMatrix().isApprox(forward_pose.ToMatrix(), 1e-12));
    EXPECT_TRUE(r.reverse.is_null());
  }

  // Reversed twice is the result itself (poses, clouds, kinds).
  const BlockRegistrationResult once = ReversedResult(JudgedResult(back_pose, "registered", 0.7));
  const BlockRegistrationResult twice = ReversedResult(once);
  EXPECT_TRUE(twice.target_from_source.ToMatrix().isApprox(back_pose.ToMatrix(), 1e-12));
  EXPECT_EQ(twice.source_kind, "nerf");
  EXPECT_EQ(twice.source_cloud.cols(), 4);
}

// A capture with nothing dense (splats all but transparent) is a named error, not a pose, in
// either scale mode.
TEST(RegisterBlocks, AnInputWithoutOccupiedCellsIsANamedError) {
  Splats empty = RandomSplats(200, 0, 1);
  empty.opacity.setConstant(-30.f);
  SplatInput source(empty, SplatFieldOptions()), target(RandomSplats(200, 0, 2), SplatFieldOptions());
  for (const ScaleMode mode : {ScaleMode::kFree, ScaleMode::kFixed}) {
    BlockRegistrationOptions o;
    o.method = RegistrationMethod::kRansac;
    o.scale = mode;
    try {
      RegisterBlocks(source, target, o, nullptr);
      FAIL() << "no error for an empty capture";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("source: occupied cells: expected at least 10 cells", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace nerfreg
