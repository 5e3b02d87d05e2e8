#include "nerfreg/render/procedural.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace nerfreg
