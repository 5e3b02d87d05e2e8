#include "nerfreg/sfm/tracks.h"

#include <gtest/gtest.h>

#include <set>

#include "nerfreg/sfm/synthetic_scene_test_util.h"

namespace nerfreg {
namespace {

TEST(Tracks, ChainPairwiseMatchesIntoOneTrackPerScenePoint) {
  SyntheticSceneOptions o;
  o.num_cameras = 6;
  o.num_points = 200;
  const SyntheticScene s = MakeSyntheticScene(o);
  const std::vector<Track> tracks = BuildTracks(s.graph, {}, TrackOptions{});
  // Every point seen by >= 2 images linked by an edge gives exactly one track, and each track's
  // keypoints all see the same point.
  std::set<int> seen;
  for (const Track& t : tracks) {
    ASSERT_GE(t.elements.size(), 2u);
    const int p = s.keypoint_point[t.elements[0].image][t.elements[0].keypoint];
    ASSERT_GE(p, 0);
    for (const auto& e : t.elements) EXPECT_EQ(s.keypoint_point[e.image][e.keypoint], p);
    EXPECT_TRUE(seen.insert(p).second) << "point " << p << " split over two tracks";
  }
  int expected = 0;
  for (int p = 0; p < o.num_points; ++p) {
    int views = 0;
    for (int c = 0; c < o.num_cameras; ++c)
      for (int q : s.keypoint_point[c]) views += q == p;
    expected += views >= 2;
  }
  EXPECT_EQ(static_cast<int>(tracks.size()), expected);
}

TEST(Tracks, AMatchJoiningTwoKeypointsOfOneImageIsRefusedAndUnusableEdgesIgnored) {
  ViewGraph g;
  g.names = {"a", "b", "c"};
  g.keypoints = {{{1, 1}, {2, 2}}, {{1, 1}, {2, 2}}, {{1, 1}, {2, 2}}};
  ViewGraphEdge ab{0, 1, 2, 2, Rigid3d(), {{0, 0}, {1, 1}}};
  ViewGraphEdge bc{1, 2, 2, 2, Rigid3d(), {{0, 0}, {1, 1}}};
  ViewGraphEdge ca{0, 2, 1, 1, Rigid3d(), {{0, 1}}};  // a0-b0-c0 and a1-b1-c1, then a0-c1: conflict
  g.edges = {ca, ab, bc};
  // The weak edge's match would put a0 and a1 (and c0 and c1) in one track: it is refused.
  const auto all = BuildTracks(g, {}, TrackOptions{});
  ASSERT_EQ(all.size(), 2u);
  for (const Track& t : all) {
    ASSERT_EQ(t.elements.size(), 3u);
    EXPECT_EQ(t.elements[0].keypoint, t.elements[1].keypoint);
    EXPECT_EQ(t.elements[1].keypoint, t.elements[2].keypoint);
  }
  // Only the conflicting edge usable: one two-view track a0-c1.
  const auto only_ca = BuildTracks(g, {true, false, false}, TrackOptions{});
  ASSERT_EQ(only_ca.size(), 1u);
  EXPECT_EQ(only_ca[0].elements[1].image, 2);
  EXPECT_EQ(only_ca[0].elements[1].keypoint, 1);
  TrackOptions three;
  three.min_length = 3;
  EXPECT_EQ(BuildTracks(g, {false, true, false}, three).size(), 0u);
  ViewGraph bad = g;
  bad.edges[1].inlier_matches.push_back({5, 0});
  EXPECT_THROW(BuildTracks(bad, {}, TrackOptions{}), std::invalid_argument);
}

}  // namespace
}  // namespace nerfreg
