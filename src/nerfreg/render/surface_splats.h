#pragma once
// 3D Gaussian splats of a mesh's surface as the views of a rendered dataset saw it: something to
// register and to apply transforms to without a 3DGS trainer, with a known truth (`render
// --splats`: splats.ply for all views, block_k/splats.ply for block k's views in block k's frame).
//
// Each view casts a ray through every pixel (of a stride); a hit becomes a flat Gaussian on the
// surface: in-plane standard deviation 0.6 voxel, across it `thickness` times that, oriented by
// the surface normal, coloured by the rendered pixel (the DC term; degree 0), opacity `opacity`.
// One splat per voxel of `voxel` side is kept (the first view to reach it), so overlapping views
// do not pile splats up. Like a trained capture, a block's splats cover only what its views saw.
#include <Eigen/Core>
#include <vector>

#include "nerfreg/data/splat_ply.h"
#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/render/raycaster.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

struct SurfaceSplatOptions {
  double voxel = 0.02;     // scene units: one splat per voxel
  int pixel_stride = 1;    // a ray through every n-th pixel of each row and column
  double thickness = 0.2;  // the normal standard deviation, as a fraction of the in-plane one
  double opacity = 0.95;   // in (0, 1); stored as its logit
  void Check() const;      // throws InputError naming the option
};

class SurfaceSplatter {
 public:
  // Keeps a reference to `caster`: it must outlive this.
  SurfaceSplatter(const RayCaster& caster, const SurfaceSplatOptions& options);
  // The surface one view sees; `rgba` is its render ([H, W, 3 or 4], the camera's size), whose
  // pixels colour the splats. `view` names it for Build.
  void AddView(int view, const Camera& camera, const Rigid3d& cam_from_world, const Image& rgba);
  // The splats of the given views (all when empty), moved into another frame by `frame_from_world`
  // (positions, orientations and scales: a Sim(3)).
  Splats Build(const std::vector<int>& views, const Sim3d& frame_from_world = Sim3d()) const;

 private:
  struct Hit {
    int view;
    Eigen::Vector3f point, normal, rgb;
  };
  const RayCaster& caster_;
  SurfaceSplatOptions options_;
  std::vector<Hit> hits_;
};

}  // namespace nerfreg
