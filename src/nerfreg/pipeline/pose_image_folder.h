#pragma once
// `dbarf poses`'s job: every image of a folder posed from the images and their intrinsics alone
// (dbarf_sfm/network_poses.h: the SfM, the pose network or both), written as posed images
// (dbarf_data/posed_images.h: OUT/transforms.json) with a COLMAP model (OUT/sparse/0) and the cameras
// seen from above (OUT/cameras.png), all moved into place at once.
#include <string>

#include "nerfreg/dbarf_sfm/network_poses.h"

namespace nerfreg {

struct ImageFolderPosesOptions {
  std::string images_dir;  // PNG / JPEG images, sorted by name
  // Intrinsics: a transforms.json (its poses ignored), or a focal length in pixels (principal point
  // at the image centre); both are held fixed unless refine_intrinsics. With neither, the images
  // are self-calibrated: a focal prior from EXIF (or the image size), the focal length estimated
  // from the fundamental matrices and refined with k1, k2 in the bundle adjustment, per camera
  // group (one per make / model / size).
  std::string intrinsics;
  double focal = 0;
  bool refine_intrinsics = false;
  // Refining the focal: a focal length whose standard deviation (from the bundle adjustment's
  // covariance) is above this fraction of it is reported as poorly determined, with a warning and
  // `"determined": false` under "self_calibration" in transforms.json. Some captures leave the
  // focal free (centres on a line, optical axes through one point: a critical motion).
  double max_focal_relative_stddev = 0.01;
  std::string out;                   // output folder
  bool force = false;                // replace an existing output
  std::string neighbours = "graph";  // network: graph (SIFT view graph) or appearance (thumbnails only)
  // The method and its options (network.match_images follows neighbours); RootSIFT descriptors,
  // measured for posing (viewgraph/view_graph.h), where the library's default stays L2.
  ImagePosesOptions poses = [] {
    ImagePosesOptions p;
    p.sfm.view_graph.normalization = SiftNormalization::kL1Root;
    return p;
  }();
  void Check() const;  // throws InputError naming the flag
};

struct ImageFolderPosesResult {
  int images = 0, posed = 0, posed_by_network = 0;
  bool well_constrained = true;
  double seconds = 0;
};

// Throws InputError on bad input; writes nothing then.
ImageFolderPosesResult PoseImageFolder(ImageFolderPosesOptions options);

}  // namespace nerfreg
