#pragma once
// Camera trajectories for rendered datasets. World frame: +z up (as in Blender).
#include <vector>

#include "nerfreg/geometry/camera.h"
#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct OrbitOptions {
  int num_views = 120;                         // two full turns at 6 deg per view
  double camera_angle_x = 0.6911112070083618;  // horizontal field of view, rad
  int width = 100, height = 100;
  // The DReg-NeRF rig: the camera starts at (0, 4, 0.5) (radius 4.03, elevation 7.1 deg) looking
  // at the origin; after frame i the rig tilts up by X = max_tilt * (cos(3 i deg) + 1) / 2 rad
  // and turns by 6 deg in azimuth.
  double radius = 4.031128874149275;            // |(0, 4, 0.5)|
  double base_elevation = 0.12435499454676144;  // atan2(0.5, 4), rad
  double max_tilt = 0.7;                        // rad
  double azimuth_step_deg = 6.0;
  double tilt_period_step_deg = 3.0;
  void Check() const;
};

// Elevation and azimuth (rad) of orbit frame i: frame 0 at (base, 0); frame i >= 1 at
// (base + X_{i-1}, i * step) with X_j = max_tilt (cos(3 j deg) + 1) / 2.
void OrbitAngles(const OrbitOptions& options, int i, double* elevation, double* azimuth);

struct PosedCamera {
  Camera camera;
  Rigid3d cam_from_world;
};

std::vector<PosedCamera> OrbitTrajectory(const OrbitOptions& options);

struct ForwardOptions {
  int num_views = 20;
  int width = 128, height = 96;
  double focal_factor = 1.1;  // focal length = factor * width
  double distance = 4.0;      // cameras at y = -distance, looking along +y at the scene
  double spread = 0.35;       // half-extent of the planar spiral of camera centres
  double look_depth = 3.0;    // cameras look at (0, look_depth - distance, 0) offsets
  void Check() const;
};

// Forward-facing views converging on a point: camera centres on a planar spiral in the x-z plane
// at y = -distance, each looking at a point look_depth ahead pulled towards the centre (a look-at
// set, a few degrees between views).
std::vector<PosedCamera> ForwardTrajectory(const ForwardOptions& options);

// A hand-held forward-facing capture as LLFF's: nearly parallel optical axes (+y), centres
// translating along a smooth path in the plane y = -distance, and a small wobble of the camera's
// orientation. Why: on look-at cameras the image barely moves at the depth the cameras aim at, so
// a static camera explains the views about as well as the true motion; with parallel axes every
// depth shows parallax (docs/notes/2026-11-27-dbarf-collapse-basin.md).
struct HandheldOptions {
  int num_views = 20;
  int width = 128, height = 96;
  double focal_factor = 1.1;  // focal length = factor * width
  double distance = 4.0;      // the plane of the centres is y = -distance
  // Half-extent of the centres' path in x (0.75 of it in z), scene units: a Lissajous figure
  // x = spread sin(2 pi t + a), z = 0.75 spread sin(4 pi t + b), t in [0, 1], which sweeps the
  // plane as a hand waving the camera does. With LayeredSceneOptions' nearest layer at 1.5, the
  // path's extent is a third of the nearest depth, as in LLFF's captures.
  double spread = 0.25;
  double depth_wobble = 0.1;      // out-of-plane motion, a fraction of spread (a hand is no rail)
  double max_rotation_deg = 2.0;  // amplitude of the yaw and pitch wobble (roll: half of it), degrees
  unsigned seed = 0;              // the phases of the path and of the wobble
  void Check() const;             // throws std::invalid_argument
};

std::vector<PosedCamera> HandheldTrajectory(const HandheldOptions& options);

// A walk through a room as ScanNet's captures: one loop around an ellipse at eye height in the
// room of ProceduralRoom (z up, the floor at z = 0, centred on the origin), the heading swinging
// from the direction of walking towards the room's centre and out towards the walls, so the set
// holds inward and outward views with wide baselines between them.
struct RoomWalkOptions {
  int num_views = 30;
  int width = 128, height = 96;
  double focal_factor = 0.7;              // focal length = factor * width (a wide lens, 71 deg across)
  double radius_x = 1.6, radius_y = 1.2;  // the ellipse's half-axes, scene units
  double eye_height = 1.5;
  double swing_deg = 75;  // amplitude of the heading's swing about the walking direction
  double pitch_deg = -8;  // looking slightly down (negative: down)
  double wobble_deg = 2;  // hand-held wobble of pitch and roll
  unsigned seed = 0;      // the phases of the swing and the wobble
  void Check() const;     // throws std::invalid_argument
};

std::vector<PosedCamera> RoomWalkTrajectory(const RoomWalkOptions& options);

}  // namespace nerfreg
