#include "nerfreg/render/renderer.h"

#include <gtest/gtest.h>

#include "nerfreg/geometry/conventions.h"
#include "nerfreg/geometry/rays.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

TEST(Renderer, SphereDepthMatchesTheAnalyticIntersection) {
  const TriangleMesh sphere = MakeSphere(1.0f, {0.8f, 0.5f, 0.2f}, 96, 192);
  RayCaster caster(sphere);
  const Camera cam = Camera::Pinhole(48, 40, 40, 40, 24, 20);
  const Rigid3d cam_from_world = LookAt({0.3, -4, 0.8}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
  RenderOptions opt;
  opt.supersample = 1;
  const RenderResult r = RenderView(caster, sphere, cam, cam_from_world, opt);
  Eigen::Matrix3Xd o, d;
  Eigen::VectorXd z;
  GenerateRays(cam, cam_from_world, &o, &d, &z);
  int hits = 0, misses = 0;
  for (int i = 0; i < cam.width * cam.height; ++i) {
    // |o + t d| = 1: t = -b - sqrt(b^2 - c), b = o.d, c = |o|^2 - 1.
    const double b = o.col(i).dot(d.col(i)), c = o.col(i).squaredNorm() - 1.0;
    const double disc = b * b - c;
    const float depth = r.depth.data[i];
    if (disc > 0.01) {  // clearly inside the silhouette
      const double t = -b - std::sqrt(disc);
      EXPECT_NEAR(depth, t * z(i), 0.01) << i;
      EXPECT_EQ(r.rgba.data[i * 4 + 3], 1.f);
      ++hits;
    } else if (disc < -0.01) {
      EXPECT_EQ(depth, 0.f);
      EXPECT_EQ(r.rgba.data[i * 4 + 3], 0.f);
      ++misses;
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_GT(misses, 100);
}

TEST(Renderer, CubeSilhouetteHasTheProjectedSize) {
  const TriangleMesh box = MakeBox({0.5f, 0.5f, 0.5f}, {0.2f, 0.6f, 0.9f});
  RayCaster caster(box);
  const Camera cam = Camera::Pinhole(101, 101, 70, 70, 50.5, 50.5);
  const Rigid3d cam_from_world = LookAt({0, -4, 0}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
  const RenderResult r = RenderView(caster, box, cam, cam_from_world, RenderOptions{});
  double covered = 0;
  for (int x = 0; x < 101; ++x) covered += r.rgba.at(x, 50, 3);
  EXPECT_NEAR(covered, 2 * 70 * 0.5 / 3.5, 0.6);  // the front face at distance 3.5
  EXPECT_NEAR(r.depth.at(50, 50, 0), 3.5f, 1e-4);
}

TEST(Renderer, ShadingShowsTextureOnUntexturedMeshes) {
  // A mesh without colours gets the procedural albedo: the image is not flat.
  TriangleMesh plain = MakeBox({0.8f, 0.8f, 0.8f}, {1, 1, 1});
  plain.vertex_colors.clear();
  RayCaster caster(plain);
  const Camera cam = Camera::Pinhole(64, 64, 60, 60, 32, 32);
  const RenderResult r =
      RenderView(caster, plain, cam, LookAt({1, -3, 1.5}, {0, 0, 0}, Eigen::Vector3d::UnitZ()), RenderOptions{});
  double mean = 0, var = 0;
  int count = 0;
  for (int y = 24; y < 40; ++y)
    for (int x = 24; x < 40; ++x) {
      mean += r.rgba.at(x, y, 0);
      ++count;
    }
  mean /= count;
  for (int y = 24; y < 40; ++y)
    for (int x = 24; x < 40; ++x) var += std::pow(r.rgba.at(x, y, 0) - mean, 2);
  EXPECT_GT(std::sqrt(var / count), 0.03);
}

TEST(Mesh, LoadsEveryFormatFromTheDebianTestModels) {
  for (const std::string path :
       {"/usr/share/assimp/models/OBJ/spider.obj", "/usr/share/assimp/models/OFF/Wuson.off",
        "/usr/share/assimp/models/PLY/cube.ply", "/usr/share/openscad/testdata/scad/3D/features/import.stl",
        "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"}) {
    const TriangleMesh m = LoadMesh(path);
    EXPECT_GT(m.triangles.size(), 0u) << path;
    TriangleMesh n = m;
    NormalizeMesh(&n);
    Eigen::Vector3f mn, mx;
    n.Bounds(&mn, &mx);
    EXPECT_NEAR((mx - mn).maxCoeff(), 2.5f, 1e-4) << path;
    EXPECT_LT((mx + mn).norm(), 1e-4) << path;
  }
}

TEST(Mesh, UnreadableMeshesAreNamedInputErrors) {
  EXPECT_THROW(LoadMesh("/nonexistent/mesh.obj"), InputError);
  try {
    LoadMesh("/usr/share/assimp/models/OFF/invalid.off");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("invalid.off"), std::string::npos);
  }
  EXPECT_THROW(LoadMesh("/usr/share/assimp/models/Collada/duck.dae"), InputError);  // not a supported extension
}

}  // namespace
}  // namespace nerfreg
