#pragma once
// Every camera-axis and pose convention nerfreg reads or writes, converted in this one place.
// Internally: cam_from_world (Rigid3d) with OpenCV camera axes (see camera.h).
//
//  - OpenGL / Blender / NeRF-synthetic transforms.json: camera-to-world 4x4 ("transform_matrix"),
//    camera axes +x right, +y up, +z backwards (the camera looks along -z).
//  - LLFF poses_bounds.npy: camera-to-world 3x4 with columns in the order (down, right, backwards).
//  - instant-ngp: its internal frame takes an OpenGL c2w, negates its y and z columns, scales and
//    offsets the translation (scale 0.33, offset 0.5 by default) and cycles axes xyz <- yzx.
//  - COLMAP: cam_from_world with OpenCV axes (identity conversion).
#include <Eigen/Core>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

// OpenGL camera-to-world (transforms.json) <-> cam_from_world (OpenCV axes).
// Throws std::invalid_argument if the 3x3 block is not a rotation.
Rigid3d CamFromWorldFromOpenGL(const Eigen::Matrix4d& world_from_cam_gl);
Eigen::Matrix4d OpenGLFromCamFromWorld(const Rigid3d& cam_from_world);

// LLFF 3x4 camera-to-world with (down, right, back) columns <-> cam_from_world.
Rigid3d CamFromWorldFromLlff(const Matrix3x4d& world_from_cam_llff);
Matrix3x4d LlffFromCamFromWorld(const Rigid3d& cam_from_world);

// instant-ngp's internal camera matrix (3x4) from an OpenGL transforms.json c2w and back
// (nerf_matrix_to_ngp / ngp_matrix_to_nerf in instant-ngp).
Matrix3x4d NgpFromOpenGL(const Eigen::Matrix4d& world_from_cam_gl, double scale = 0.33,
                         const Eigen::Vector3d& offset = Eigen::Vector3d(0.5, 0.5, 0.5));
Eigen::Matrix4d OpenGLFromNgp(const Matrix3x4d& ngp, double scale = 0.33,
                              const Eigen::Vector3d& offset = Eigen::Vector3d(0.5, 0.5, 0.5));

// A world point mapped into instant-ngp's unit cube frame and back (positions, not cameras).
Eigen::Vector3d NgpPointFromWorld(const Eigen::Vector3d& x, double scale = 0.33,
                                  const Eigen::Vector3d& offset = Eigen::Vector3d(0.5, 0.5, 0.5));
Eigen::Vector3d WorldPointFromNgp(const Eigen::Vector3d& x, double scale = 0.33,
                                  const Eigen::Vector3d& offset = Eigen::Vector3d(0.5, 0.5, 0.5));

// Camera centre in world coordinates.
Eigen::Vector3d CameraCenter(const Rigid3d& cam_from_world);

// cam_from_world for a camera at `eye` looking at `target` with `up` roughly up in the image
// (OpenCV axes: +y down, so the image's up is -y). Throws if eye == target or up is parallel.
Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up);

}  // namespace nerfreg
