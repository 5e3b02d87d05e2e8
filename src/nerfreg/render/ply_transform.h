#pragma once
// A Sim(3) applied to a point-cloud or triangle-mesh PLY (`reg apply`), read and written through
// Open3D (checked first as the mesh loader checks PLY files: render/ply_check.h): vertices moved,
// normals rotated, colours and faces kept; the output is a binary PLY (Open3D's ASCII writer keeps
// 6 digits), written atomically. Properties Open3D does not read (e.g. a splat's) are not kept:
// splat PLYs go through data/sim3_apply.h instead.
#include <string>

#include "nerfreg/geometry/rigid3.h"

namespace nerfreg {

struct PlyTransformSummary {
  bool mesh = false;  // faces were found (a triangle mesh), else a point cloud
  std::int64_t vertices = 0;
  std::int64_t triangles = 0;
};

// Throws InputError naming `input` when it is not a PLY Open3D reads, or holds no vertices.
PlyTransformSummary TransformPlyFile(const std::string& input, const std::string& output, const Sim3d& new_from_old);

}  // namespace nerfreg
