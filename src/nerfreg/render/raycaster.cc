#include "nerfreg/render/raycaster.h"

#include <embree3/rtcore.h>

#include <limits>
#include <stdexcept>

namespace nerfreg {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
};

RayCaster::RayCaster(const TriangleMesh& mesh) : impl_(new Impl), mesh_(mesh) {
  impl_->device = rtcNewDevice("threads=1");  // we parallelise over rays ourselves
  if (!impl_->device) throw std::runtime_error("Embree: rtcNewDevice failed");
  impl_->scene = rtcNewScene(impl_->device);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), mesh.vertices.size()));
  for (size_t k = 0; k < mesh.vertices.size(); ++k)
    for (int c = 0; c < 3; ++c) v[3 * k + c] = mesh.vertices[k](c);
  auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), mesh.triangles.size()));
  for (size_t k = 0; k < mesh.triangles.size(); ++k)
    for (int c = 0; c < 3; ++c) idx[3 * k + c] = static_cast<unsigned>(mesh.triangles[k](c));
  rtcCommitGeometry(geom);
  rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(impl_->scene);
}

RayCaster::~RayCaster() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
}

RayHit RayCaster::Cast(const Eigen::Vector3f& o, const Eigen::Vector3f& d, float t_near, float t_far) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = o.x();
  rh.ray.org_y = o.y();
  rh.ray.org_z = o.z();
  rh.ray.dir_x = d.x();
  rh.ray.dir_y = d.y();
  rh.ray.dir_z = d.z();
  rh.ray.tnear = t_near;
  rh.ray.tfar = t_far;
  rh.ray.time = 0;
  rh.ray.mask = static_cast<unsigned>(-1);  // without this every ray misses
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);
  RayHit hit;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
    hit.t = std::numeric_limits<float>::infinity();
    return hit;
  }
  hit.t = rh.ray.tfar;
  hit.triangle = static_cast<int>(rh.hit.primID);
  hit.u = rh.hit.u;
  hit.v = rh.hit.v;
  hit.normal = Eigen::Vector3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
  const float n = hit.normal.norm();
  if (n > 0) hit.normal /= n;
  return hit;
}

std::vector<RayHit> RayCaster::CastMany(const std::vector<Eigen::Vector3f>& origins,
                                        const std::vector<Eigen::Vector3f>& directions) const {
  if (origins.size() != directions.size()) throw std::invalid_argument("CastMany: size mismatch");
  std::vector<RayHit> hits(origins.size());
  const long n = static_cast<long>(origins.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (long k = 0; k < n; ++k) hits[k] = Cast(origins[k], directions[k]);
  return hits;
}

}  // namespace nerfreg
