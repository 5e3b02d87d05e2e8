#pragma once
// Pinhole camera with OpenCV radial-tangential distortion (k1, k2, p1, p2, and k3, k4 as
// nerfstudio's OPENCV: radial 1 + k1 r^2 + k2 r^4 + k3 r^6 + k4 r^8), or the OpenCV fisheye
// (equidistant) model with k1..k4 (nerfstudio's and COLMAP's OPENCV_FISHEYE).
//
// Conventions, used everywhere in nerfreg:
//  - Camera frame: OpenCV/COLMAP axes, +x right, +y down, +z forward (the viewing direction).
//    Other conventions are converted in geometry/conventions.h only.
//  - Image coordinates are continuous with the top-left corner of the top-left pixel at (0, 0);
//    pixel (col, row) has its centre at (col + 0.5, row + 0.5) (COLMAP convention). A camera with
//    cx = width / 2 is centred.
//  - Poses are stored as cam_from_world (Rigid3d).
#include <Eigen/Core>
#include <string>

namespace nerfreg {

enum class CameraModel { kOpenCV, kOpenCVFisheye };

struct Camera {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0;
  double k3 = 0, k4 = 0;
  // kOpenCVFisheye: theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8) with
  // theta the angle to the axis; p1, p2 unused.
  CameraModel model = CameraModel::kOpenCV;

  static Camera Pinhole(int width, int height, double fx, double fy, double cx, double cy);
  // NeRF-synthetic: focal from the horizontal field of view, principal point at the centre.
  static Camera FromFovX(int width, int height, double camera_angle_x);

  bool HasDistortion() const {
    return model == CameraModel::kOpenCVFisheye || k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0 || k4 != 0;
  }
  double FovX() const;
  double FovY() const;

  // Projects a point in the camera frame (z > 0) to image coordinates (distortion applied).
  Eigen::Vector2d ImgFromCam(const Eigen::Vector3d& x_in_cam) const;
  // Inverse: image coordinates to a camera-frame direction with z = 1 (distortion removed
  // iteratively).
  Eigen::Vector3d CamFromImg(const Eigen::Vector2d& uv) const;

  // The same camera for an image resized to (new_width, new_height): fx, cx scale with the width
  // and fy, cy with the height (all four, unlike the original DBARF, spec dbarf.md 9.1).
  Camera Resized(int new_width, int new_height) const;

  // Throws std::invalid_argument when sizes or focal lengths are not positive/finite.
  void Check() const;
  std::string ToString() const;

  // Every field equal: the same image size, model and parameters.
  bool operator==(const Camera& other) const {
    return width == other.width && height == other.height && fx == other.fx && fy == other.fy && cx == other.cx &&
           cy == other.cy && k1 == other.k1 && k2 == other.k2 && p1 == other.p1 && p2 == other.p2 && k3 == other.k3 &&
           k4 == other.k4 && model == other.model;
  }
  bool operator!=(const Camera& other) const { return !(*this == other); }
};

}  // namespace nerfreg
