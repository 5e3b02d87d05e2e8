#include "nerfreg/render/procedural.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <tuple>

#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

TEST(Procedural, ObjectsAreReproducibleAndVaried) {
  const TriangleMesh a = ProceduralObject(7), b = ProceduralObject(7), c = ProceduralObject(8);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  for (size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices[i], b.vertices[i]);
  EXPECT_TRUE(a.vertices.size() != c.vertices.size() || a.vertices[0] != c.vertices[0]);
  Eigen::Vector3f mn, mx;
  a.Bounds(&mn, &mx);
  EXPECT_NEAR((mx - mn).maxCoeff(), 2.5f, 1e-4);
  EXPECT_TRUE(a.HasColors());
  EXPECT_NO_THROW(a.Check("procedural"));
}

TEST(Procedural, ForwardScenesHaveABackdropBehindTheObjects) {
  const TriangleMesh s = ProceduralForwardScene(3);
  Eigen::Vector3f mn, mx;
  s.Bounds(&mn, &mx);
  EXPECT_NEAR(mx.y(), 2.0f, 1e-5);  // the backdrop is the farthest surface
  EXPECT_GT(mx.x() - mn.x(), 10.f);
  EXPECT_TRUE(s.HasColors());
}

TEST(Procedural, MeshesGetABackdropForForwardScenes) {
  TriangleMesh box = MakeBox({0.5f, 0.5f, 0.5f}, {1, 0, 0});
  const TriangleMesh scene = WithBackdrop(box);
  EXPECT_EQ(scene.triangles.size(), MakeBackdrop(12.f, 9.f, 120, 90, 2.f).triangles.size() + box.triangles.size());
  EXPECT_TRUE(scene.HasColors());
  Eigen::Vector3f mn, mx;
  scene.Bounds(&mn, &mx);
  EXPECT_NEAR(mx.y(), 2.0f, 1e-5);
}

// The materials change the backdrop's colours only: low-texture one colour, repetitive a tile grid
// of three (light, dark, grout) whose every tile repeats; the objects are the seed's in each.
TEST(Procedural, MaterialsChangeOnlyTheBackdropsColours) {
  const TriangleMesh textured = ProceduralForwardScene(3);
  const TriangleMesh low = ProceduralForwardScene(3, 2.0f, ParseSceneMaterial("low-texture"));
  const TriangleMesh tiles = ProceduralForwardScene(3, 2.0f, SceneMaterial::kRepetitive);
  ASSERT_EQ(low.vertices.size(), textured.vertices.size());
  ASSERT_EQ(tiles.vertices.size(), textured.vertices.size());
  const size_t backdrop = MakeBackdrop(12.f, 9.f, 120, 90, 2.f).vertices.size();
  std::set<std::tuple<float, float, float>> low_colours, tile_colours, textured_colours;
  for (size_t k = 0; k < textured.vertices.size(); ++k) {
    EXPECT_EQ(low.vertices[k], textured.vertices[k]);
    if (k >= backdrop) {
      EXPECT_EQ(low.vertex_colors[k], textured.vertex_colors[k]);
      EXPECT_EQ(tiles.vertex_colors[k], textured.vertex_colors[k]);
      continue;
    }
    const auto key = [](const Eigen::Vector3f& c) { return std::make_tuple(c.x(), c.y(), c.z()); };
    low_colours.insert(key(low.vertex_colors[k]));
    tile_colours.insert(key(tiles.vertex_colors[k]));
    textured_colours.insert(key(textured.vertex_colors[k]));
  }
  EXPECT_EQ(low_colours.size(), 1u);
  EXPECT_EQ(tile_colours.size(), 3u);
  EXPECT_GT(textured_colours.size(), 1000u);
  // A tile 6 cells (0.6) along repeats the colours exactly.
  for (size_t k = 0; k + 12 < 121; ++k) EXPECT_EQ(tiles.vertex_colors[k], tiles.vertex_colors[k + 12]) << k;
  EXPECT_LT(MaterialTextureModulation(SceneMaterial::kLowTexture), MaterialTextureModulation(SceneMaterial::kTextured));
  EXPECT_THROW(ParseSceneMaterial("marble"), InputError);
}

// Layered depth: the backdrop is the farthest surface at backdrop_depth from the camera plane, one
// object reaches into the nearest layer and others lie between; the scene is the seed's.
TEST(Procedural, LayeredScenesSpanTheDepthRange) {
  const LayeredSceneOptions o;
  const TriangleMesh s = ProceduralLayeredScene(5);
  Eigen::Vector3f mn, mx;
  s.Bounds(&mn, &mx);
  EXPECT_NEAR(mx.y() - o.camera_y, o.backdrop_depth, 1e-4);
  EXPECT_TRUE(s.HasColors());
  EXPECT_NO_THROW(s.Check("layered"));
  // The backdrop fills the widest view (half-width depth * tan, plus the path's extent) at its depth.
  EXPECT_GT(mx.x(), o.backdrop_depth * o.tan_half_fov_x + 1.f);
  EXPECT_LT(mn.x(), -o.backdrop_depth * o.tan_half_fov_x - 1.f);
  EXPECT_GT(mx.z(), o.backdrop_depth * o.tan_half_fov_x * o.aspect + 1.f);
  // Depths of the objects' vertices (everything in front of the backdrop's plane).
  std::vector<float> depths;
  for (const auto& v : s.vertices)
    if (v.y() < mx.y() - 1e-3f) depths.push_back(v.y() - o.camera_y);
  ASSERT_FALSE(depths.empty());
  const auto [lo, hi] = std::minmax_element(depths.begin(), depths.end());
  EXPECT_GT(*lo, 0.5f * o.near_depth);  // in front of the cameras
  EXPECT_LT(*lo, 1.3f * o.near_depth);  // the nearest layer is occupied
  EXPECT_GT(*hi, 3 * o.near_depth);     // and a farther one
  EXPECT_LT(*hi, o.backdrop_depth);
  const TriangleMesh again = ProceduralLayeredScene(5);
  ASSERT_EQ(again.vertices.size(), s.vertices.size());
  for (size_t k = 0; k < s.vertices.size(); ++k) ASSERT_EQ(again.vertices[k], s.vertices[k]) << k;
  const TriangleMesh other = ProceduralLayeredScene(6);
  EXPECT_TRUE(other.vertices.size() != s.vertices.size() || other.vertices.back() != s.vertices.back());
}

}  // namespace
}  // namespace nerfreg
