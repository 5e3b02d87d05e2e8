#pragma once
// Renders a mesh into a NeRF dataset, and optionally into K blocks each in its own random frame
// (the DReg-NeRF data pipeline, spec dreg-nerf.md sections 1-2; the layout is cli.md's):
//   DIR/transforms.json, DIR/images/r_XXX.png          all views, world frame, with a test split
//   DIR/block_k/transforms.json, DIR/block_k/images/   block k's views in block k's frame
//   DIR/ground_truth.json                               {"blocks": [{"block_from_world", "scale", ...}]}
//   DIR/render_options.json                             the effective options
//   DIR/splats.ply, DIR/block_k/splats.ply              with write_splats (3DGS PLY)
// The dataset is written into a temporary folder renamed into place at the end, so an
// interrupted run leaves nothing half-written.
#include <string>

#include "nerfreg/render/blocks.h"
#include "nerfreg/render/mesh.h"
#include "nerfreg/render/renderer.h"
#include "nerfreg/render/surface_splats.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct RenderDatasetOptions {
  // "orbit" (objects, RGBA), "forward" (scenes, RGB: look-at views, ForwardTrajectory), "llff"
  // (scenes, RGB: a hand-held capture with nearly parallel axes, HandheldTrajectory) or "room"
  // (a room, RGB: a walk through it, RoomWalkTrajectory).
  std::string trajectory = "orbit";
  int views = 0;              // 0: 120 for orbit, 20 for forward and llff, 30 for room
  int width = 0, height = 0;  // 0: 100x100 for orbit, 128x96 for the others
  // forward: half-extent of the camera spiral; llff: of the hand-held path in x (0: the options'
  // default, 0.35 forward, 0.25 llff)
  double forward_spread = 0;
  unsigned trajectory_seed = 0;  // llff, room: the phases of the path and the wobble
  int blocks = 1;                // K >= 2 writes block_k folders and ground_truth.json
  int test_every = 20;           // every n-th view of a block (or of all views if K = 1) is a test view
  unsigned seed = 0;             // block split and block frames
  BlockFrameOptions block_frame;
  RenderOptions render;
  // Photo-like degradations (forward scenes and orbits alike): the cameras' radial distortion
  // (OpenCV k1, k2: rendered through it and written with the intrinsics), Gaussian pixel noise of
  // this standard deviation (in [0, 1] units, seeded by `seed`), and JPEG files of this quality
  // (0: PNG).
  double k1 = 0, k2 = 0;
  double noise_sigma = 0;
  int jpeg_quality = 0;
  bool write_depth = false;  // depth maps as DIR/depth/r_XXX.npy (z-depth, 0 = no surface)
  // 3D Gaussian splats of the surface the views saw (render/surface_splats.h): DIR/splats.ply from
  // every view (world frame) and, with blocks, DIR/block_k/splats.ply from block k's views in its frame.
  bool write_splats = false;
  SurfaceSplatOptions splats;
  bool force = false;  // replace an existing DIR
  void Check() const;  // throws InputError naming the option
  Json ToJson() const;
};

struct RenderDatasetSummary {
  int views = 0;
  int blocks = 0;
  double seconds = 0;
};

RenderDatasetSummary RenderDataset(const TriangleMesh& mesh, const RenderDatasetOptions& options,
                                   const std::string& out_dir);

}  // namespace nerfreg
