#include "nerfreg/render/surface_splats.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unordered_set>

#include "nerfreg/geometry/conventions.h"
#include "nerfreg/util/error.h"

namespace nerfreg {

void SurfaceSplatOptions::Check() const {
  if (!(voxel > 0)) ThrowInputError("--splat-voxel", "", "> 0");
  if (pixel_stride < 1) ThrowInputError("--splat-stride", "", ">= 1");
  if (!(thickness > 0 && thickness <= 1)) ThrowInputError("splats", "thickness", "in (0, 1]");
  if (!(opacity > 0 && opacity < 1)) ThrowInputError("splats", "opacity", "in (0, 1)");
}

SurfaceSplatter::SurfaceSplatter(const RayCaster& caster, const SurfaceSplatOptions& options)
    : caster_(caster), options_(options) {
  options.Check();
}

void SurfaceSplatter::AddView(int view, const Camera& camera, const Rigid3d& cam_from_world, const Image& rgba) {
  if (rgba.width != camera.width || rgba.height != camera.height || rgba.channels < 3) {
    throw std::invalid_argument("SurfaceSplatter::AddView: the image is not the camera's size or not RGB(A)");
  }
  const Eigen::Vector3f centre = CameraCenter(cam_from_world).cast<float>();
  const Eigen::Matrix3d world_from_cam = cam_from_world.RotationMatrix().transpose();
  std::vector<Eigen::Vector3f> origins, dirs;
  std::vector<std::pair<int, int>> pixels;
  for (int y = 0; y < camera.height; y += options_.pixel_stride) {
    for (int x = 0; x < camera.width; x += options_.pixel_stride) {
      // Only pixels the surface covers whole: silhouette pixels mix in the background.
      if (rgba.channels == 4 && rgba.at(x, y, 3) < 0.99f) continue;
      const Eigen::Vector3d d = world_from_cam * camera.CamFromImg(Eigen::Vector2d(x + 0.5, y + 0.5));
      origins.push_back(centre);
      dirs.push_back(d.normalized().cast<float>());
      pixels.emplace_back(x, y);
    }
  }
  const std::vector<RayHit> hits = caster_.CastMany(origins, dirs);
  for (size_t k = 0; k < hits.size(); ++k) {
    if (!hits[k].hit()) continue;
    Hit h;
    h.view = view;
    h.point = origins[k] + hits[k].t * dirs[k];
    // Facing the camera (the caster's normal is unoriented).
    h.normal = hits[k].normal.dot(dirs[k]) > 0 ? Eigen::Vector3f(-hits[k].normal) : hits[k].normal;
    const auto [x, y] = pixels[k];
    h.rgb = Eigen::Vector3f(rgba.at(x, y, 0), rgba.at(x, y, 1), rgba.at(x, y, 2));
    hits_.push_back(h);
  }
}

Splats SurfaceSplatter::Build(const std::vector<int>& views, const Sim3d& frame_from_world) const {
  const std::unordered_set<int> wanted(views.begin(), views.end());
  std::unordered_set<std::int64_t> taken;
  std::vector<const Hit*> kept;
  for (const Hit& h : hits_) {
    if (!views.empty() && !wanted.count(h.view)) continue;
    // Voxels of the world frame (the same surface samples whatever frame the splats are moved to).
    const Eigen::Vector3i v = (h.point.cast<double>() / options_.voxel).array().floor().cast<int>();
    const std::int64_t key = ((std::int64_t(v.x()) & 0x1FFFFF) << 42) | ((std::int64_t(v.y()) & 0x1FFFFF) << 21) |
                             (std::int64_t(v.z()) & 0x1FFFFF);
    if (taken.insert(key).second) kept.push_back(&h);
  }
  constexpr double kC0 = 0.28209479177387814;
  const double sigma = 0.6 * options_.voxel;
  const double log_in_plane = std::log(sigma * frame_from_world.scale);
  const double log_across = std::log(sigma * options_.thickness * frame_from_world.scale);
  const float logit = static_cast<float>(std::log(options_.opacity / (1 - options_.opacity)));
  Splats s;
  s.Resize(static_cast<std::int64_t>(kept.size()), 0, /*normals=*/true);
  for (size_t i = 0; i < kept.size(); ++i) {
    const Hit& h = *kept[i];
    const Eigen::Vector3d n = frame_from_world.rotation * h.normal.cast<double>().normalized();
    // The splat's z axis along the normal: its third scale is the thin one.
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), n).normalized();
    s.position.col(i) = (frame_from_world * h.point.cast<double>()).cast<float>();
    s.normal.col(i) = n.cast<float>();
    s.f_dc.col(i) = ((h.rgb.cast<double>().array() - 0.5) / kC0).cast<float>();
    s.opacity(i) = logit;
    s.log_scale.col(i) = Eigen::Vector3f(log_in_plane, log_in_plane, log_across);
    s.rotation.col(i) = Eigen::Vector4f(q.w(), q.x(), q.y(), q.z());
  }
  return s;
}

}  // namespace nerfreg
