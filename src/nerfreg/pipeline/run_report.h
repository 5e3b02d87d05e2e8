#pragma once
// `nerfreg report`: one self-contained HTML page for a run directory that fetches nothing when
// viewed (images as data: URIs, charts as inline SVG, three.js inlined). It shows, from the files
// the commands write:
//  - a summary card: registration errors (reg eval's JSON), times, PSNR;
//  - each registration (a JSON with "target_from_source", reg register's T.json) with its
//    before/after overlays and, when point clouds of its blocks are in the run (nerf export
//    --points, named as the checkpoints: block_0.ckpt -> block_0.ply), an interactive 3D view of
//    both blocks after applying T, with the blocks' camera frusta (a dataset folder named as the
//    checkpoint, e.g. data/block_0/transforms.json);
//  - renders (a folder of PNGs named as a dataset's frames) next to their ground truth, with
//    per-view PSNR and an error heat-map;
//  - training curves from `*.jsonl` logs (log scale for losses);
//  - camera frusta of the other posed image sets (dbarf poses' OUT/transforms.json);
//  - the remaining JSON files as tables and the remaining PNGs.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/data/dataset.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

// Debian's libjs-three (scripts/setup.sh installs it).
inline constexpr const char* kDefaultThreeJs = "/usr/share/javascript/three/three.min.js";

struct ReportOptions {
  std::string title;                       // page title; default: the run directory's name
  std::string three_js = kDefaultThreeJs;  // read when the page has a 3D view
  int max_points_per_block = 20000;        // 3D view: points kept per block (evenly strided)
  int max_views = 8;                       // renders shown beside their ground truth per folder
  int max_images = 200;                    // other images beyond this are listed, not embedded
  long long max_image_bytes = 8 << 20;     // larger PNGs are listed, not embedded
  int max_camera_views = 6;                // 3D views of posed image sets (one WebGL context each)
  void Check() const;                      // throws InputError naming the option
};

// Builds the page for run_dir and writes it atomically to out_path. Throws InputError when
// run_dir is not a directory, or naming options.three_js when the page needs three.js and the
// file is missing.
void WriteRunReport(const std::string& run_dir, const std::string& out_path, const ReportOptions& options);

// The vertices of an ASCII PLY whose first three vertex properties are x y z (nerf export
// --points), every k-th kept so at most max_points remain. [3, N]. Throws InputError naming the
// file and the header field on anything else.
Eigen::Matrix3Xd ReadPlyPoints(const std::string& path, int max_points);

// Line segments (pairs of endpoints, [3, 2 * 8 * frames]) drawing each frame's camera as a
// pyramid of the given depth, mapped by world_from_dataset.
Eigen::Matrix3Xd CameraFrustumSegments(const Dataset& dataset, const Sim3d& world_from_dataset, double depth);

// Error heat-map of a render against its ground truth (same size, RGB): the mean absolute error
// over channels mapped from 0 (black) through red and yellow to white at `full_scale`.
Image ErrorHeatMap(const Image& render, const Image& ground_truth, float full_scale = 0.25f);

}  // namespace nerfreg
