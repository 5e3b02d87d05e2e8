#include "nerfreg/registration/grid_registration.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <vector>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/reg_data/synthetic_grids.h"
#include "nerfreg/util/error.h"
#include "nerfreg/render/mesh.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {
namespace {

struct KnownPair {
  RegGrid source, target;
  Eigen::Matrix4d target_from_source;
};

// One block's grid of the spider, and the same grid seen from a frame turned by 70 degrees and
// shifted (resampled, so its sample points differ as a second block's would).
KnownPair SameGridMoved() {
  TriangleMesh mesh = LoadMesh("/usr/share/assimp/models/OBJ/spider.obj");
  NormalizeMesh(&mesh);
  SyntheticPairOptions o;
  o.views = 60;
  o.image_size = 64;
  const GridPair p = SyntheticGridPair(mesh, o, 3);
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(70 * M_PI / 180, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.15, -0.1, 0.05);
  KnownPair k{p.source, TransformRegGrid(p.source, R, t), Eigen::Matrix4d::Identity()};
  k.target_from_source.topLeftCorner<3, 3>() = R;
  k.target_from_source.topRightCorner<3, 1>() = t;
  return k;
}

void ExpectRecovered(const RegistrationResult& r, const Eigen::Matrix4d& gt, double max_deg, double max_trans) {
  const Sim3d& est = r.target_from_source;
  const Sim3d truth = Sim3d::FromMatrix(gt, 1e-3);
  EXPECT_LT(RotationErrorDeg(est.rotation, truth.rotation), max_deg) << r.method;
  EXPECT_LT(TranslationError(est.translation, truth.translation), max_trans) << r.method;
}

TEST(RegisterGrids, ClassicalRecoversAKnownTransformOfTheSameGrid) {
  torch::set_num_threads(2);
  const KnownPair k = SameGridMoved();
  GridRegistrationOptions o;
  o.method = RegistrationMethod::kRansac;
  const RegistrationResult r = RegisterGrids(k.source, k.target, o, nullptr);
  ExpectRecovered(r, k.target_from_source, 2.0, 0.05);
  EXPECT_GT(r.method_score, 0.5);
  EXPECT_EQ(r.method, "ransac+icp");
}

// ICP on the occupied voxels (the default) or on the surface mask: both recover the move; the
// features see the mask either way. Here a third of the target's mask is dropped (as a block's
// surface field drops what its cameras saw poorly): the occupied voxels still hold that surface.
TEST(RegisterGrids, IcpOnTheOccupiedVoxelsOrOnTheMask) {
  torch::set_num_threads(2);
  KnownPair k = SameGridMoved();
  torch::manual_seed(4);
  k.target.mask = k.target.mask & (torch::rand(k.target.mask.sizes()) > 0.33);
  ASSERT_GT(k.target.OccupiedXyz().size(0), k.target.MaskedXyz().size(0) * 4 / 3);
  GridRegistrationOptions o;
  o.method = RegistrationMethod::kRansac;
  const RegistrationResult occupied = RegisterGrids(k.source, k.target, o, nullptr);
  EXPECT_EQ(occupied.method, "ransac+icp");
  ExpectRecovered(occupied, k.target_from_source, 2.0, 0.05);
  o.icp_points = IcpPoints::kMask;
  const RegistrationResult mask = RegisterGrids(k.source, k.target, o, nullptr);
  EXPECT_EQ(mask.method, "ransac+icp[mask]");
  ExpectRecovered(mask, k.target_from_source, 2.0, 0.05);
  EXPECT_THROW(IcpPointsFromName("all"), InputError);
}

// ICP's correspondence distance (in ICP voxels) is the one asked for: from a pose 6 deg off, the
// default (2 voxels) closes the gap; a distance far under one cell finds no pairs within it, so
// the pose does not move. The row is named apart, and a distance <= 0 is a named error.
TEST(RegisterGrids, IcpDistanceIsTheOneAskedFor) {
  torch::set_num_threads(2);
  const KnownPair k = SameGridMoved();
  Eigen::Matrix4d start_matrix = k.target_from_source;
  start_matrix.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(6 * M_PI / 180, Eigen::Vector3d(0.3, 1, -0.2).normalized()).toRotationMatrix() *
      start_matrix.topLeftCorner<3, 3>();
  const Sim3d start = Sim3d::FromMatrix(start_matrix, 1e-3);
  const Sim3d truth = Sim3d::FromMatrix(k.target_from_source, 1e-3);
  auto error_deg = [&](const Sim3d& m) { return RotationErrorDeg(m.rotation, truth.rotation); };
  ASSERT_NEAR(error_deg(start), 6.0, 0.01);
  GridRegistrationOptions o;
  o.flips = false;
  EXPECT_LT(error_deg(RefineGridPose(k.source, k.target, start, o)), 2.0);
  o.icp_distance = 0.01;
  EXPECT_NEAR(error_deg(RefineGridPose(k.source, k.target, start, o)), 6.0, 0.05);
  o.method = RegistrationMethod::kRansac;
  EXPECT_EQ(o.Name(), "ransac+icp[noflips][d0.01]");
  o.icp_distance = 0;
  EXPECT_THROW(o.Check(), InputError);
}

// The shipped weights (models/dreg_cpu.pt) on held-out pairs (procedural objects of the
// validation range 5000.., never trained on): with ICP they register most of them (97 % of 36
// such pairs with stage 5, docs/notes/2026-11-23-grids-icp-half-turn.md); alone they are coarse
// (results/registration.md, `val_mesh`), but within reach of ICP, which a network normalising
// grids with BatchNorm's running averages at inference was not (its median was 24 deg there).
TEST(RegisterGrids, ShippedWeightsWithIcpRegisterMostHeldOutPairs) {
  torch::set_num_threads(2);
  const std::string weights = std::string(NERFREG_SOURCE_DIR) + "/models/dreg_cpu.pt";
  ASSERT_TRUE(FileExists(weights)) << weights << " is shipped with the repository";
  DregModelOptions mo;
  DregNet net = LoadDregWeights(weights, &mo);
  int success = 0, n = 0;
  std::vector<double> alone_deg;
  for (unsigned seed = 5000; seed < 5006; ++seed) {
    TriangleMesh mesh = ProceduralObject(seed);
    NormalizeMesh(&mesh);
    const GridPair p = SyntheticGridPair(mesh, SyntheticPairOptions{}, seed);
    const Sim3d truth = Sim3d::FromMatrix(p.target_from_source, 1e-3);
    GridRegistrationOptions o;
    o.method = RegistrationMethod::kDreg;
    const RegistrationResult r = RegisterGrids(p.source, p.target, o, &net);
    const Sim3d& est = r.target_from_source;
    success += RotationErrorDeg(est.rotation, truth.rotation) < 5 &&
               TranslationError(est.translation, truth.translation) < 0.125;
    ++n;
    o.icp = false;
    const RegistrationResult coarse = RegisterGrids(p.source, p.target, o, &net);
    alone_deg.push_back(RotationErrorDeg(coarse.target_from_source.rotation, truth.rotation));
  }
  EXPECT_GE(success, 4) << success << " of " << n;
  std::sort(alone_deg.begin(), alone_deg.end());
  EXPECT_LT(0.5 * (alone_deg[2] + alone_deg[3]), 15.0) << "median of the network alone, deg";
}

// A pose turned by a half-turn about one of the object's axes (the network's failure on
// near-symmetric real blocks) is found back by the half-turn check, and kept without it. The
// agreement of the true pose beats the turned one's.
TEST(RegisterGrids, HalfTurnedPoseIsFoundBackByItsColouredVoxels) {
  torch::set_num_threads(2);
  const KnownPair k = SameGridMoved();
  // The source's principal axes through its centroid, as RefineGridPose turns them.
  const Eigen::Matrix3Xd pts = PointsToEigen(k.source.OccupiedXyz());
  const Eigen::Vector3d centroid = pts.rowwise().mean();
  const Eigen::Matrix3Xd centred = pts.colwise() - centroid;
  const Eigen::Matrix3d axes =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(centred * centred.transpose()).eigenvectors();
  Eigen::Matrix4d turn = Eigen::Matrix4d::Identity();
  turn.topLeftCorner<3, 3>() = Eigen::AngleAxisd(M_PI, axes.col(2)).toRotationMatrix();
  turn.topRightCorner<3, 1>() = centroid - turn.topLeftCorner<3, 3>() * centroid;
  Eigen::Matrix4d nudge = Eigen::Matrix4d::Identity();  // and 4 deg, 0.03 off, as a network's pose
  nudge.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(4 * M_PI / 180, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  nudge.topRightCorner<3, 1>() = Eigen::Vector3d(0.03, 0, -0.01);
  const Sim3d start = Sim3d::FromMatrix(nudge * k.target_from_source * turn, 1e-3);
  const Sim3d truth = Sim3d::FromMatrix(k.target_from_source, 1e-3);
  EXPECT_GT(GridAgreement(k.source, k.target, truth), GridAgreement(k.source, k.target, start) + 0.1);

  GridRegistrationOptions o;
  int flip = -2;
  const Sim3d found = RefineGridPose(k.source, k.target, start, o, &flip);
  RegistrationResult r;
  r.target_from_source = found;
  r.method = "half-turns";
  ExpectRecovered(r, k.target_from_source, 2.0, 0.05);
  EXPECT_GE(flip, 0);
  o.flips = false;
  r.target_from_source = RefineGridPose(k.source, k.target, start, o, &flip);
  EXPECT_EQ(flip, -1);
  const Sim3d& kept = r.target_from_source;
  EXPECT_GT(RotationErrorDeg(kept.rotation, truth.rotation), 90.0);
  // From the true pose, no half-turn replaces it.
  o.flips = true;
  RefineGridPose(k.source, k.target, truth, o, &flip);
  EXPECT_EQ(flip, -1);
}

TEST(RegisterGrids, EmptyGridIsIdentityWithZeroConfidence) {
  const KnownPair k = SameGridMoved();
  RegGrid empty = k.target;
  empty.mask.zero_();
  GridRegistrationOptions o;
  o.method = RegistrationMethod::kRansac;
  const RegistrationResult r = RegisterGrids(k.source, empty, o, nullptr);
  EXPECT_EQ(r.method_score, 0);
  EXPECT_TRUE(r.target_from_source.ToMatrix().isIdentity());
  EXPECT_EQ(r.target_points, 0);
}

}  // namespace
}  // namespace nerfreg
