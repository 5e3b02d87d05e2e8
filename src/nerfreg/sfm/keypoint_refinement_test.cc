#include "nerfreg/sfm/keypoint_refinement.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

namespace nerfreg {
namespace {

// A smooth random texture: a sum of sinusoids of 4-16 px wavelengths.
struct Texture {
  std::vector<Eigen::Vector3d> waves;  // (kx, ky, phase)
  explicit Texture(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> angle(0, 2 * M_PI), wavelength(4, 16);
    for (int k = 0; k < 24; ++k) {
      const double a = angle(rng), f = 2 * M_PI / wavelength(rng);
      waves.emplace_back(f * std::cos(a), f * std::sin(a), angle(rng));
    }
  }
  float operator()(const Eigen::Vector2d& p) const {
    double v = 0;
    for (const Eigen::Vector3d& w : waves) v += std::sin(w.x() * p.x() + w.y() * p.y() + w.z());
    return static_cast<float>(0.5 + 0.5 * v / std::sqrt(static_cast<double>(waves.size())));
  }
};

// The texture seen through p_image = linear p_texture + shift (keypoint convention: pixel (c, r)'s
// centre at (c + 0.5, r + 0.5)).
Image Render(const Texture& texture, const Eigen::Matrix2d& linear, const Eigen::Vector2d& shift) {
  Image im(200, 160, 1);
  const Eigen::Matrix2d inverse = linear.inverse();
  for (int r = 0; r < im.height; ++r)
    for (int c = 0; c < im.width; ++c) im.at(c, r, 0) = texture(inverse * (Eigen::Vector2d(c + 0.5, r + 0.5) - shift));
  return im;
}

struct TwoViews {
  std::vector<Image> images;
  ViewGraph graph;
  Eigen::Matrix2d linear;  // image 1 from image 0: p1 = linear p0 + shift
  Eigen::Vector2d shift;
};

// Image 1 sees image 0's texture scaled by 1.06, turned 4 deg and moved; image 1's keypoints are
// the true positions of image 0's, each off by up to `noise_px` in x and y.
TwoViews MakeTwoViews(double noise_px, bool flat = false) {
  TwoViews v;
  const double a = 4 * M_PI / 180;
  v.linear << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
  v.linear *= 1.06;
  v.shift = Eigen::Vector2d(-3.3, 6.8);
  const Texture texture(5);
  v.images = {Render(texture, Eigen::Matrix2d::Identity(), Eigen::Vector2d::Zero()),
              Render(texture, v.linear, v.shift)};
  if (flat)
    for (Image& im : v.images) std::fill(im.data.begin(), im.data.end(), 0.5f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> off(-noise_px, noise_px);
  v.graph.names = {"a.png", "b.png"};
  v.graph.keypoints.resize(2);
  ViewGraphEdge edge;
  edge.i = 0;
  edge.j = 1;
  for (double y = 40.3; y < 130; y += 15)
    for (double x = 40.7; x < 170; x += 15) {
      const Eigen::Vector2d p(x, y);
      edge.inlier_matches.emplace_back(v.graph.keypoints[0].size(), v.graph.keypoints[1].size());
      v.graph.keypoints[0].push_back(p);
      v.graph.keypoints[1].push_back(v.linear * p + v.shift + Eigen::Vector2d(off(rng), off(rng)));
    }
  edge.num_inliers = edge.num_matches = static_cast<int>(edge.inlier_matches.size());
  v.graph.edges = {edge};
  return v;
}

// How far each pair's keypoints are from seeing the same texture point (pixels of image 1).
std::vector<double> Disagreement(const TwoViews& v, const std::vector<std::vector<Eigen::Vector2d>>& keypoints) {
  std::vector<double> d;
  for (size_t k = 0; k < keypoints[0].size(); ++k)
    d.push_back((v.linear * keypoints[0][k] + v.shift - keypoints[1][k]).norm());
  return d;
}

TEST(KeypointRefinement, AlignsTheKeypointsOfAnAffinelyWarpedViewToATenthOfAPixel) {
  const TwoViews v = MakeTwoViews(0.8);
  std::vector<std::vector<Eigen::Vector2d>> keypoints = v.graph.keypoints;
  const std::vector<double> before = Disagreement(v, keypoints);
  const KeypointRefinementSummary s = RefineTrackKeypoints(v.images, v.graph, BuildTracks(v.graph, {}, TrackOptions{}),
                                                           KeypointRefinementOptions{}, &keypoints);
  const std::vector<double> after = Disagreement(v, keypoints);
  const int n = static_cast<int>(before.size());
  EXPECT_EQ(s.num_tracks, n);
  EXPECT_EQ(s.num_moved + s.num_refused, n);
  EXPECT_GE(s.num_moved, n - 2);
  EXPECT_GT(*std::max_element(before.begin(), before.end()), 0.6);
  EXPECT_GT(s.median_shift_px, 0.3);
  // One image's keypoints moved onto the other's texture points: measured 0.040 px at most with
  // the default 8 steps (SIFT-like errors of up to 0.8 px in x and y before).
  double worst = 0;
  for (int k = 0; k < n; ++k)
    if (keypoints[0][k] == v.graph.keypoints[0][k] && keypoints[1][k] != v.graph.keypoints[1][k]) {
      EXPECT_LT(after[k], 0.1) << k << ": " << before[k] << " px before";
      worst = std::max(worst, after[k]);
    }
  std::printf("moved %d of %d, worst disagreement %.4f px\n", s.num_moved, n, worst);
}

// The photos of a posing run are held packed (8 bits a channel): the refinement reads the same grey
// levels from them as from their float images, so it moves the keypoints to the same places.
TEST(KeypointRefinement, PackedImagesMoveTheKeypointsAsTheirFloatImages) {
  const TwoViews v = MakeTwoViews(0.8);
  std::vector<PackedImage> packed;
  std::vector<Image> unpacked;
  for (const Image& im : v.images) {
    packed.push_back(PackImage(im, 8));
    unpacked.push_back(UnpackImage(packed.back()));
  }
  const std::vector<Track> tracks = BuildTracks(v.graph, {}, TrackOptions{});
  std::vector<std::vector<Eigen::Vector2d>> from_float = v.graph.keypoints, from_packed = v.graph.keypoints;
  const KeypointRefinementSummary a =
      RefineTrackKeypoints(unpacked, v.graph, tracks, KeypointRefinementOptions{}, &from_float);
  const KeypointRefinementSummary b =
      RefineTrackKeypoints(packed, v.graph, tracks, KeypointRefinementOptions{}, &from_packed);
  EXPECT_GT(a.num_moved, a.num_tracks / 2);
  EXPECT_EQ(a.num_moved, b.num_moved);
  EXPECT_EQ(from_float, from_packed);
}

TEST(KeypointRefinement, LeavesKeypointsWhereTheImagesHaveNoTexture) {
  const TwoViews v = MakeTwoViews(0.8, /*flat=*/true);
  std::vector<std::vector<Eigen::Vector2d>> keypoints = v.graph.keypoints;
  const KeypointRefinementSummary s = RefineTrackKeypoints(v.images, v.graph, BuildTracks(v.graph, {}, TrackOptions{}),
                                                           KeypointRefinementOptions{}, &keypoints);
  EXPECT_EQ(s.num_moved, 0);
  EXPECT_EQ(s.num_refused, s.num_tracks);
  EXPECT_EQ(keypoints, v.graph.keypoints);
}

TEST(KeypointRefinement, RefusesAlignmentsBeyondTheShiftLimit) {
  const TwoViews v = MakeTwoViews(0.8);
  std::vector<std::vector<Eigen::Vector2d>> keypoints = v.graph.keypoints;
  KeypointRefinementOptions options;
  options.max_shift_px = 0.05;
  const KeypointRefinementSummary s =
      RefineTrackKeypoints(v.images, v.graph, BuildTracks(v.graph, {}, TrackOptions{}), options, &keypoints);
  EXPECT_GT(s.num_refused, s.num_tracks / 2);
  for (size_t k = 0; k < keypoints[1].size(); ++k)
    EXPECT_LE((keypoints[1][k] - v.graph.keypoints[1][k]).norm(), 0.05 + 1e-9);
}

TEST(KeypointRefinement, ChecksItsOptionsAndCounts) {
  KeypointRefinementOptions o;
  EXPECT_NO_THROW(o.Check());
  for (int w : {3, 14}) {
    KeypointRefinementOptions bad;
    bad.window_px = w;
    EXPECT_THROW(bad.Check(), std::invalid_argument) << w;
  }
  KeypointRefinementOptions bad;
  bad.max_shift_px = 0;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  bad = {};
  bad.num_threads = 0;
  EXPECT_THROW(bad.Check(), std::invalid_argument);
  const TwoViews v = MakeTwoViews(0.5);
  std::vector<std::vector<Eigen::Vector2d>> keypoints = v.graph.keypoints;
  const std::vector<Image> one = {v.images[0]};
  EXPECT_THROW(RefineTrackKeypoints(one, v.graph, {}, o, &keypoints), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
