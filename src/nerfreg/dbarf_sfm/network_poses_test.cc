#include "nerfreg/dbarf_sfm/network_poses.h"

#include <gtest/gtest.h>

#include "nerfreg/dbarf/dbarf_model.h"
#include "nerfreg/dbarf_data/dbarf_scene.h"
#include "nerfreg/dbarf/test_scene.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

Rigid3d LookAt(const Eigen::Vector3d& center, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - center).normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, z.cross(x), z;
  const Eigen::Matrix3d r = world_from_cam.transpose();
  return Rigid3d(r, -(r * center));
}

TEST(NetworkPoses, RegistrationFromExactRelativePosesRecoversTheTargetAndTheNetworkScale) {
  const Rigid3d target = LookAt({0.3, 0.1, -4}, {0, 0, 0});
  std::vector<Rigid3d> src_from_world, src_from_tgt;
  for (const Eigen::Vector3d c :
       {Eigen::Vector3d(-1, 0, -4), Eigen::Vector3d(1, 0.3, -4.2), Eigen::Vector3d(0, -0.8, -3.7)}) {
    src_from_world.push_back(LookAt(c, {0.1, 0, 0.2}));
    Rigid3d rel = src_from_world.back() * target.Inverse();
    rel.translation /= 2.5;  // the network's units: 2.5 SfM units each
    src_from_tgt.push_back(rel);
  }
  const NetworkRegistration r = RegisterFromRelativePoses(src_from_world, src_from_tgt);
  EXPECT_NEAR(r.scale, 2.5, 1e-9);
  EXPECT_EQ(r.pairs, 3);
  EXPECT_LT(r.pair_rotation_error_deg, 1e-6);
  EXPECT_LT(r.pair_direction_error_deg, 1e-6);
  EXPECT_LT(RotationErrorDeg(r.tgt_from_world.rotation, target.rotation), 1e-6);
  EXPECT_LT((r.tgt_from_world.translation - target.translation).norm(), 1e-9);
}

TEST(NetworkPoses, ANetworkThatPredictsIdentityIsCaughtOnTheSharedEdges) {
  // Sources 20 deg apart: a network that always answers "no motion" claims they coincide, and the
  // pair check (its relative rotation between the sources against the SfM's) says so.
  std::vector<Rigid3d> src_from_world = {LookAt({-1.5, 0, -4}, {0, 0, 0}), LookAt({1.5, 0, -4}, {0, 0, 0})};
  const NetworkRegistration r = RegisterFromRelativePoses(src_from_world, {Rigid3d(), Rigid3d()});
  EXPECT_EQ(r.pairs, 1);
  EXPECT_NEAR(r.pair_rotation_error_deg, RotationErrorDeg(src_from_world[1].rotation, src_from_world[0].rotation),
              1e-9);
  EXPECT_GT(r.pair_rotation_error_deg, 20.0);
  // No translation: no direction, and no scale fitted from it (the depth range's units are kept).
  EXPECT_EQ(r.pair_direction_error_deg, 180.0);
  EXPECT_EQ(r.scale, 1.0);
  EXPECT_THROW(RegisterFromRelativePoses({}, {}), std::invalid_argument);
}

// The SfM's confidence checks an image against the edges its solution was made from: wrong edges
// that rotation averaging left out (here the identity, as wrong matches of a repeated pattern
// across a wide baseline gave on Castle-simu) are counted, not allowed to outvote right poses.
// Counted as before (every edge used), the same right pose would be doubted.
TEST(NetworkPoses, SfmConfidenceChecksTheEdgesTheSolutionUsedAndCountsTheOthers) {
  SfmResult sfm;
  const int n = 5;
  for (int k = 0; k < n; ++k) {
    const double a = 0.35 * k;  // 20 deg apart on an arc
    sfm.cam_from_world.push_back(LookAt({4 * std::sin(a), 0.2 * k, -4 * std::cos(a)}, {0, 0, 0}));
    sfm.cameras.push_back(Camera::Pinhole(64, 48, 60, 60, 32, 24));
  }
  sfm.posed.assign(n, true);
  sfm.view_graph.keypoints.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      ViewGraphEdge e;
      e.i = i, e.j = j;
      const bool right = j == i + 1;  // neighbours: right; wider pairs: the identity, wrong
      const Rigid3d j_from_i = sfm.cam_from_world[j] * sfm.cam_from_world[i].Inverse();
      e.j_from_i = right ? Rigid3d(j_from_i.rotation, j_from_i.translation.normalized())
                         : Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0));
      sfm.view_graph.edges.push_back(e);
      sfm.edge_used.push_back(right);
    }
  }
  const std::vector<ImagePoseConfidence> used = SfmConfidence(sfm, sfm.cameras);
  ASSERT_EQ(used.size(), static_cast<size_t>(n));
  EXPECT_EQ(used[0].edges, 1);
  EXPECT_EQ(used[0].edges_left_out, 3);
  EXPECT_EQ(used[2].edges, 2);
  EXPECT_EQ(used[2].edges_left_out, 2);
  for (const ImagePoseConfidence& c : used) {
    EXPECT_LT(c.rotation_residual_deg, 1e-6);
    EXPECT_LT(c.direction_residual_deg, 1e-6);
  }
  sfm.edge_used.clear();  // every edge counted
  const std::vector<ImagePoseConfidence> all = SfmConfidence(sfm, sfm.cameras);
  EXPECT_EQ(all[0].edges, 4);
  EXPECT_GT(all[0].rotation_residual_deg, 30.0);  // the wrong edges' median: a right pose doubted
}

// A photo the SfM cannot pose, placed by the network with relative poses 16 deg off on one source
// (as a view 40 deg below an orbit was): its edges between the posed sources disagree, and auto
// reports it not posed, with the reason, instead of counting it. Exact edges are kept.
TEST(NetworkPoses, ANetworkPoseWhoseEdgesDisagreeIsNotPosed) {
  const Rigid3d target = LookAt({0.3, -2.5, -3}, {0, 0, 0});
  std::vector<Rigid3d> src_from_world, exact, wrong;
  for (const Eigen::Vector3d c :
       {Eigen::Vector3d(-1, 0, -4), Eigen::Vector3d(1, 0.3, -4.2), Eigen::Vector3d(0, -0.8, -3.7)}) {
    src_from_world.push_back(LookAt(c, {0.1, 0, 0.2}));
    exact.push_back(src_from_world.back() * target.Inverse());
    wrong.push_back(exact.back());
  }
  wrong[1].rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(16 * M_PI / 180, Eigen::Vector3d::UnitX())) * wrong[1].rotation;
  const ImagePosesOptions options;
  auto confidence = [](const NetworkRegistration& r) {
    ImagePoseConfidence c;
    c.edges = r.pairs;
    c.rotation_residual_deg = r.pair_rotation_error_deg;
    c.direction_residual_deg = r.pair_direction_error_deg;
    return c;
  };
  const NetworkRegistration good = RegisterFromRelativePoses(src_from_world, exact);
  EXPECT_EQ(NetworkPoseRejection(confidence(good), options), "");
  const NetworkRegistration bad = RegisterFromRelativePoses(src_from_world, wrong);
  EXPECT_GT(bad.pair_rotation_error_deg, 10.0);
  const std::string reason = NetworkPoseRejection(confidence(bad), options);
  EXPECT_NE(reason.find("disagrees"), std::string::npos) << reason;
  ImagePoseConfidence collapsed = confidence(good);
  collapsed.problem = "its camera centre coincides with a.png's (a collapsed solution)";
  EXPECT_NE(NetworkPoseRejection(collapsed, options).find("collapsed"), std::string::npos);
  EXPECT_NE(NetworkPoseRejection(ImagePoseConfidence(), options), "");  // nothing to check it by
}

// The network's edges (target -> source, src_from_tgt) go the right way into the averaging: exact
// relative poses in any unit give the cameras back, and the confidence comes from the view graph
// where it has edges (the independent check), from the network's own edges elsewhere.
TEST(NetworkPoses, ExactNetworkEdgesAverageToTheCamerasAndTheGraphChecksThem) {
  std::vector<Rigid3d> truth;
  for (int k = 0; k < 6; ++k) truth.push_back(LookAt({-1.0 + 0.4 * k, 0.3 * (k % 2), -4 + 0.2 * (k % 3)}, {0, 0, 0}));
  std::vector<NetworkRelativePose> poses;
  for (int t = 0; t < 6; ++t)
    for (int s : {t - 2, t - 1, t + 1, t + 2}) {
      if (s < 0 || s >= 6) continue;
      Rigid3d rel = truth[s] * truth[t].Inverse();
      rel.translation *= 0.01;  // a network whose unit is 100 scene units
      poses.push_back({t, s, rel});
    }
  ViewGraph graph;
  graph.names = {"0", "1", "2", "3", "4", "5"};
  graph.keypoints.resize(6);
  // One essential matrix, 10 deg off the truth, between images 0 and 1.
  ViewGraphEdge e;
  e.i = 0;
  e.j = 1;
  e.j_from_i = truth[1] * truth[0].Inverse();
  e.j_from_i.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitY())) * e.j_from_i.rotation;
  e.j_from_i.translation.normalize();
  graph.edges.push_back(e);
  const NetworkEdgeAverage a = AverageNetworkEdges(6, poses, graph, {});
  // The output frame: camera 0 at the identity, mean distance of the others to it 1.
  double mean = 0;
  for (int k = 1; k < 6; ++k) mean += (truth[k].Inverse().translation - truth[0].Inverse().translation).norm() / 5;
  for (int k = 0; k < 6; ++k) {
    ASSERT_TRUE(a.averaged.posed[k]);
    const Rigid3d k_from_0 = a.averaged.cam_from_world[k];  // world = camera 0
    const Rigid3d true_k_from_0 = truth[k] * truth[0].Inverse();
    EXPECT_LT(RotationErrorDeg(k_from_0.rotation, true_k_from_0.rotation), 1e-4) << k;
    EXPECT_LT((k_from_0.translation * mean - true_k_from_0.translation).norm(), 1e-4) << k;
  }
  EXPECT_NEAR(a.scale, 100.0 / mean, 1e-3);
  EXPECT_NEAR(a.confidence[0].rotation_residual_deg, 10.0, 1e-3);  // the essential matrix's error
  EXPECT_EQ(a.confidence[0].edges, 1);
  EXPECT_NEAR(a.confidence[1].rotation_residual_deg, 10.0, 1e-3);
  EXPECT_LT(a.confidence[3].rotation_residual_deg, 1e-4);  // no graph edge: the network's own edges
  EXPECT_LT(a.confidence[3].direction_residual_deg, 1e-3);
  EXPECT_EQ(a.confidence[3].edges, 8);  // 4 as target, 4 as source
}

// Two "places": images 0, 2, 4 show one texture, 1, 3 another, each slightly shifted.
torch::Tensor TwoPlaces() {
  const testing_scene::PlaneScene a = testing_scene::PlaneScene::Tilted(3.0);
  const testing_scene::PlaneScene b = testing_scene::PlaneScene::Ridge(2.0);
  std::vector<torch::Tensor> images;
  for (int k = 0; k < 5; ++k) {
    const torch::Tensor shift =
        Matrix4ToTensor(Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.05 * k, 0, 0)).ToMatrix());
    images.push_back(k % 2 == 0 ? a.Render(shift)[0] : 1.0 - b.Render(shift)[0]);
  }
  return torch::stack(images);  // [5, 3, 48, 64]
}

TEST(NetworkPoses, AppearanceNeighboursRankImagesOfTheSamePlaceFirst) {
  const auto n = AppearanceNeighbours(TwoPlaces());
  ASSERT_EQ(n.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    ASSERT_EQ(n[k].size(), 4u);
    EXPECT_EQ(n[k][0] % 2, k % 2) << k;
    EXPECT_EQ(std::count(n[k].begin(), n[k].end(), k), 0);
  }
  EXPECT_EQ(n[0][0], 2);  // the nearest shift of the same place
}

TEST(NetworkPoses, SourcesComeFromTheViewGraphAndFromAppearanceWhereItHasTooFewEdges) {
  ViewGraph graph;
  graph.names = {"a", "b", "c", "d", "e"};
  graph.keypoints.resize(5);
  graph.edges.push_back({0, 1, 50, 40, Rigid3d(), {}});
  graph.edges.push_back({0, 2, 50, 90, Rigid3d(), {}});
  graph.edges.push_back({3, 0, 50, 20, Rigid3d(), {}});
  const std::vector<std::vector<int>> appearance = {
      {4, 1, 2, 3}, {0, 2, 3, 4}, {0, 1, 3, 4}, {4, 2, 1, 0}, {3, 2, 1, 0}};
  NetworkPosesOptions o;
  o.num_sources = 3;
  o.min_graph_neighbours = 2;
  EXPECT_EQ(ChooseSources(0, graph, appearance, {}, o), (std::vector<int>{2, 1, 3}));  // by inliers
  EXPECT_EQ(ChooseSources(3, graph, appearance, {}, o), (std::vector<int>{0, 4, 2}));  // one edge: topped up
  EXPECT_EQ(ChooseSources(4, graph, appearance, {}, o), (std::vector<int>{3, 2, 1}));  // no edge at all
  // Only allowed images (e.g. those the SfM posed).
  EXPECT_EQ(ChooseSources(4, graph, appearance, {true, true, false, false, false}, o), (std::vector<int>{1, 0}));
}

// Coincident camera centres (a collapsed solution) are named per image; distinct ones are not.
TEST(NetworkPoses, CoincidentCentresNameTheCollapsedImages) {
  std::vector<Rigid3d> cams;
  for (int k = 0; k < 5; ++k) cams.push_back(Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.5 * k, 0, 0)));
  std::vector<bool> posed(5, true);
  EXPECT_EQ(CoincidentCentres(cams, posed), std::vector<int>(5, -1));
  cams[3].translation = cams[1].translation + Eigen::Vector3d(1e-4, 0, 0);  // image 3 collapsed onto 1
  EXPECT_EQ(CoincidentCentres(cams, posed), (std::vector<int>{-1, 3, -1, 1, -1}));
  posed[1] = false;  // an unposed image is nobody's twin
  EXPECT_EQ(CoincidentCentres(cams, posed), std::vector<int>(5, -1));
}

// The output's depth range follows the network's depths where they have a spread, and falls back
// to --near / --far where they collapsed (constant, or pinned to a bound).
TEST(NetworkPoses, DepthRangeFromTheNetworkUnlessItsDepthCollapsed) {
  NetworkPosesOptions o;  // near 7, far 40
  double near = 0, far = 0;
  EXPECT_TRUE(NetworkDepthRange({4, 5, 6}, {25, 26, 27}, 2.0, o, &near, &far));
  EXPECT_DOUBLE_EQ(near, 0.7 * 2.0 * 5);
  EXPECT_DOUBLE_EQ(far, 1.4 * 2.0 * 26);
  // Only ever wider than --near / --far: a network depth whose near end is behind the default's
  // keeps the default there.
  EXPECT_TRUE(NetworkDepthRange({11, 12, 13}, {25, 26, 27}, 1.0, o, &near, &far));
  EXPECT_DOUBLE_EQ(near, 7);
  EXPECT_DOUBLE_EQ(far, 40);
  EXPECT_FALSE(NetworkDepthRange({39.9, 40, 40}, {40, 40, 40}, 1.0, o, &near, &far));  // at the far bound
  EXPECT_DOUBLE_EQ(near, 7);
  EXPECT_DOUBLE_EQ(far, 40);
  EXPECT_FALSE(NetworkDepthRange({20, 21}, {22, 23}, 1.0, o, &near, &far));  // nearly constant
  EXPECT_FALSE(NetworkDepthRange({7, 7}, {7.5, 7.5}, 1.0, o, &near, &far));  // at the near bound
  EXPECT_FALSE(NetworkDepthRange({}, {}, 1.0, o, &near, &far));
  EXPECT_DOUBLE_EQ(near, 7);
}

// The whole network method with whatever weights are given (here untrained ones): every image is a
// target once, every (target, source) pair an edge, and the images are posed by the network.
TEST(NetworkPoses, NetworkMethodPosesEveryImageFromTheWeightsGiven) {
  ScopedTempDir dir;
  torch::manual_seed(0);
  const std::string weights = dir.File("w.pt");
  SaveDbarfWeights(DbarfModel(DbarfOptions::Cpu()), weights);
  const testing_scene::PlaneScene plane = testing_scene::PlaneScene::Ridge(3.0);
  std::vector<Image> images;
  std::vector<Camera> cameras;
  std::vector<std::string> names;
  for (int k = 0; k < 5; ++k) {
    const Rigid3d cam_from_plane(Eigen::Matrix3d(Eigen::AngleAxisd(0.03 * k, Eigen::Vector3d::UnitY())),
                                 Eigen::Vector3d(-0.2 * k, 0.02 * k, 0));
    images.push_back(TensorToImage(plane.Render(Matrix4ToTensor(cam_from_plane.ToMatrix()))[0]));
    const float f = plane.intrinsics[0][0].item<float>();
    cameras.push_back(Camera::Pinhole(64, 48, f, f, 32, 24));
    names.push_back("im" + std::to_string(k) + ".png");
  }
  ImagePosesOptions o;
  o.method = "network";
  o.weights = weights;
  o.network.match_images = false;  // appearance neighbours only: no SIFT on 64 x 48 renders
  o.network.num_sources = 2;
  const ImagePosesResult r = EstimateImagePoses(images, cameras, names, o);
  EXPECT_EQ(r.method_used, "network");
  EXPECT_EQ(r.num_network_edges, 5 * 2);
  int posed = 0;
  for (int k = 0; k < 5; ++k) {
    if (!r.posed[k]) continue;
    ++posed;
    EXPECT_EQ(r.posed_by[k], "network");
    EXPECT_GT(r.confidence[k].edges, 0);
    EXPECT_EQ(r.confidence[k].observations, -1);
  }
  EXPECT_EQ(posed + static_cast<int>(r.not_posed.size()), 5);
  EXPECT_TRUE(r.sfm.points.empty());
  EXPECT_GT(r.far, r.near);
  EXPECT_GT(r.near, 0);

  // The photometric bundle adjustment after the averaging: no SIFT anywhere (no keypoints), the
  // cameras move, and the output frame stays the classical one (first posed camera at the
  // identity, mean distance of the others to it 1).
  o.network.bundle_adjust = true;
  o.network.photometric_ba.iterations_per_level = 10;
  const ImagePosesResult b = EstimateImagePoses(images, cameras, names, o);
  for (const auto& keypoints : b.sfm.view_graph.keypoints) EXPECT_TRUE(keypoints.empty());
  EXPECT_TRUE(b.sfm.view_graph.edges.empty());
  EXPECT_EQ(b.posed, r.posed);
  int first = -1, others = 0;
  double moved = 0, distance = 0;
  for (int k = 0; k < 5; ++k) {
    if (!b.posed[k]) continue;
    if (first < 0) first = k;
    moved += (b.cam_from_world[k].ToMatrix() - r.cam_from_world[k].ToMatrix()).norm();
    if (k != first) distance += b.cam_from_world[k].Inverse().translation.norm(), ++others;
  }
  // (Untrained weights may leave too few consistent edges to pose anything; then there is nothing
  // to adjust.)
  if (first >= 0 && others > 0) {
    EXPECT_GT(moved, 1e-4);
    EXPECT_LT((b.cam_from_world[first].ToMatrix() - Eigen::Matrix4d::Identity()).norm(), 1e-6);
    EXPECT_NEAR(distance / others, 1.0, 1e-6);
    EXPECT_GT(b.far, b.near);
    EXPECT_GT(b.near, 0);
  }
  o.network.bundle_adjust = false;

  // auto: the SfM cannot relate these small smooth renders (too few SIFT matches), so the network
  // poses them all.
  o.method = "auto";
  const ImagePosesResult a = EstimateImagePoses(images, cameras, names, o);
  EXPECT_EQ(a.method_used, "network");
  for (int k = 0; k < 5; ++k)
    if (a.posed[k]) EXPECT_EQ(a.posed_by[k], "network");

  // Bad options are one-line input errors naming the option.
  o.method = "sfm";
  EXPECT_NE(InputErrorOf([&] { EstimateImagePoses(images, cameras, names, o); }).find("--method"), std::string::npos);
  o.method = "network";
  o.weights = dir.File("missing.pt");
  EXPECT_NE(InputErrorOf([&] { EstimateImagePoses(images, cameras, names, o); }).find("missing.pt"), std::string::npos);
}

// Network edges a few degrees off, and exact essential matrices between neighbours: averaged
// together at a weight (auto where the SfM poses too few images), the cameras follow the essential
// matrices; the network's edges alone leave them off.
TEST(NetworkPoses, EssentialMatrixEdgesAveragedWithTheNetworksAnchorTheCameras) {
  std::vector<Rigid3d> truth;
  for (int k = 0; k < 6; ++k) truth.push_back(LookAt({-1.0 + 0.4 * k, 0.3 * (k % 2), -4 + 0.2 * (k % 3)}, {0, 0, 0}));
  std::vector<NetworkRelativePose> poses;
  for (int t = 0; t < 6; ++t)
    for (int s : {t - 2, t - 1, t + 1, t + 2}) {
      if (s < 0 || s >= 6) continue;
      Rigid3d rel = truth[s] * truth[t].Inverse();
      // 3 deg about an axis that changes with the edge: errors that do not cancel around cycles.
      const Eigen::Vector3d axis = Eigen::Vector3d(1 + t, 2 - s, 0.5 * (t + s)).normalized();
      rel.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(3 * M_PI / 180, axis)) * rel.rotation;
      poses.push_back({t, s, rel});
    }
  ViewGraph graph;
  graph.names = {"0", "1", "2", "3", "4", "5"};
  graph.keypoints.resize(6);
  for (int i = 0; i + 1 < 6; ++i) {
    ViewGraphEdge e;
    e.i = i;
    e.j = i + 1;
    e.j_from_i = truth[i + 1] * truth[i].Inverse();
    e.j_from_i.translation.normalize();
    graph.edges.push_back(e);
  }
  const auto max_error = [&](const NetworkEdgeAverage& a) {
    double worst = 0;
    for (int k = 0; k < 6; ++k) {
      EXPECT_TRUE(a.averaged.posed[k]);
      worst = std::max(
          worst, RotationErrorDeg(a.averaged.cam_from_world[k].rotation, (truth[k] * truth[0].Inverse()).rotation));
    }
    return worst;
  };
  const double network_only = max_error(AverageNetworkEdges(6, poses, graph, {}));
  const double anchored = max_error(AverageNetworkEdges(6, poses, graph, {}, 10.0));
  EXPECT_GT(network_only, 1.0);
  EXPECT_LT(anchored, 0.5 * network_only);
  EXPECT_LT(anchored, 1.0);
}

// Images no pose can be trusted for, whatever the network says: flat grey, a copy of another, and
// one of another place (no view-graph edge, unlike anything else).
TEST(NetworkPoses, InputProblemsNameTexturelessIdenticalAndUnrelatedImages) {
  const testing_scene::PlaneScene a = testing_scene::PlaneScene::Tilted(3.0);
  const testing_scene::PlaneScene b = testing_scene::PlaneScene::Ridge(2.0);
  std::vector<torch::Tensor> images;
  for (int k = 0; k < 4; ++k) {
    const torch::Tensor shift =
        Matrix4ToTensor(Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.05 * k, 0, 0)).ToMatrix());
    images.push_back(a.Render(shift)[0]);
  }
  images.push_back(1.0 - b.Render(Matrix4ToTensor(Eigen::Matrix4d::Identity()))[0]);  // 4: another place
  images.push_back(torch::full_like(images[0], 0.5));                                 // 5: flat
  images.push_back(images[1].clone());                                                // 6: a copy of 1
  const torch::Tensor stacked = torch::stack(images);                                 // [7, 3, 48, 64]
  const std::vector<std::string> names = {"a0", "a1", "a2", "a3", "b", "grey", "copy"};
  ViewGraph graph;
  graph.names = names;
  graph.keypoints.resize(7);
  for (int i = 0; i < 3; ++i) graph.edges.push_back({i, i + 1, 50, 50, Rigid3d(), {}});
  const std::vector<std::string> p = ImageInputProblems(stacked, graph, true, names);
  EXPECT_EQ(p,
            (std::vector<std::string>{"", "identical to copy", "", "", "unrelated", "textureless", "identical to a1"}));
  // Without matching there is no view graph to say an image is unrelated.
  EXPECT_EQ(ImageInputProblems(stacked, graph, false, names)[4], "");
  // The same from the images as read, one at a time (dbarf poses never stacks a folder).
  std::vector<Image> read;
  for (const torch::Tensor& im : images) read.push_back(TensorToImage(im));
  EXPECT_EQ(ImageInputProblems(read, graph, true, names), p);
  EXPECT_EQ(ImageInputProblems(read, graph, false, names)[4], "");
}

}  // namespace
}  // namespace nerfreg
