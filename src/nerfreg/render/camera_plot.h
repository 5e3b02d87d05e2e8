#pragma once
// Camera positions seen from above, for looking at estimated poses (dbarf poses) and at estimated
// poses against ground truth (dbarf eval-poses) without a 3D viewer: each camera is a disc at its
// centre with a short line along its viewing direction, projected onto the plane orthogonal to the
// cameras' mean up vector (when the cameras disagree on up, the best-fit plane of the centres).
// The image is oriented so that the cameras' mean viewing direction points up the picture.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

struct CameraPlotOptions {
  // Width and height of the square picture, pixels.
  int size = 512;
  // Empty border around the cameras, pixels (the scale bar sits in the bottom one).
  int margin = 32;
  // Radius of the disc drawn at each camera centre, pixels.
  int marker_radius = 4;
  // Length of a camera's viewing-direction line when it lies in the plane, as a fraction of the
  // widest extent of the centres (shorter the more the camera looks up or down).
  double direction_length = 0.08;
  // Throws std::invalid_argument naming the field when a value is out of range.
  void Check() const;
};

// One set of cameras drawn in one colour.
struct PlottedCameras {
  std::vector<Rigid3d> cam_from_world;  // OpenCV camera axes, all sets in the same world frame
  Eigen::Vector3f color;                // RGB in [0, 1]
};

struct CameraPlot {
  Image image;  // [size, size] RGB on white
  // Length, in world units, of the black scale bar in the bottom-left corner: 1, 2 or 5 x 10^k,
  // about a fifth of the picture (the image utilities draw no text, so the caller reports it).
  double scale_bar_length = 0;
};

// Draws every set; with link_first_two, a grey line joins camera k of sets[0] to camera k of
// sets[1] (e.g. estimate and ground truth; both sets must then have the same size). The view
// plane is taken from the cameras of sets[0]. Throws std::invalid_argument when there is no camera
// or the link sets differ in size.
CameraPlot PlotCamerasFromAbove(const std::vector<PlottedCameras>& sets, bool link_first_two,
                                const CameraPlotOptions& options = CameraPlotOptions());

// Colours of the plots the commands write: estimate, ground truth, links.
inline const Eigen::Vector3f kEstimateColor(0.85f, 0.15f, 0.1f);
inline const Eigen::Vector3f kGroundTruthColor(0.1f, 0.3f, 0.9f);
inline const Eigen::Vector3f kLinkColor(0.65f, 0.65f, 0.65f);

}  // namespace nerfreg
