#pragma once
// Ray casting against a triangle mesh with Embree 3 directly (Debian's Open3D 0.16
// RaycastingScene::CastRays returns inf for every ray). The Embree scene is built once.
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "nerfreg/render/mesh.h"

namespace nerfreg {

struct RayHit {
  float t = 0;                                       // distance along the (unit) direction; +inf when missed
  int triangle = -1;                                 // -1 when missed
  float u = 0, v = 0;                                // barycentrics of vertices 1 and 2 (Embree's convention)
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // unit geometric normal (unoriented)
  bool hit() const { return triangle >= 0; }
};

class RayCaster {
 public:
  // Keeps a reference to `mesh`: it must outlive the caster.
  explicit RayCaster(const TriangleMesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  RayHit Cast(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_near = 0.f,
              float t_far = std::numeric_limits<float>::infinity()) const;
  // Casts many rays in parallel (OpenMP). origins, directions: [N] each.
  std::vector<RayHit> CastMany(const std::vector<Eigen::Vector3f>& origins,
                               const std::vector<Eigen::Vector3f>& directions) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  const TriangleMesh& mesh_;
};

}  // namespace nerfreg
