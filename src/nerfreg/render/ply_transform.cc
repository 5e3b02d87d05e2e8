#include "nerfreg/render/ply_transform.h"

#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/PointCloudIO.h>
#include <open3d/io/TriangleMeshIO.h>
#include <open3d/utility/Logging.h>

#include <cstdint>

#include "nerfreg/render/ply_check.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

namespace {

void MovePoints(std::vector<Eigen::Vector3d>* points, std::vector<Eigen::Vector3d>* normals,
                const Sim3d& new_from_old) {
  const Eigen::Matrix3d r = new_from_old.rotation.toRotationMatrix();
  for (Eigen::Vector3d& p : *points) p = new_from_old * p;
  for (Eigen::Vector3d& n : *normals) n = r * n;
}

}  // namespace

PlyTransformSummary TransformPlyFile(const std::string& input, const std::string& output, const Sim3d& new_from_old) {
  if (!FileExists(input)) ThrowInputError(input, "", "an existing PLY file");
  CheckPlyForOpen3d(input);
  // Open3D's warnings would duplicate our errors (as in LoadMesh).
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  // Always binary: Open3D's ASCII writer keeps 6 significant digits, which would lose the 1e-6
  // a round trip must keep.
  const bool ascii = false;
  PlyTransformSummary summary;
  open3d::geometry::TriangleMesh mesh;
  open3d::io::ReadTriangleMeshOptions mesh_options;
  const bool is_mesh = open3d::io::ReadTriangleMeshFromPLY(input, mesh, mesh_options) && !mesh.triangles_.empty();
  if (is_mesh) {
    MovePoints(&mesh.vertices_, &mesh.vertex_normals_, new_from_old);
    summary = {true, static_cast<std::int64_t>(mesh.vertices_.size()),
               static_cast<std::int64_t>(mesh.triangles_.size())};
    WriteAtomically(output, [&](const std::string& tmp) {
      if (!open3d::io::WriteTriangleMeshToPLY(tmp, mesh, ascii, false, mesh.HasVertexNormals(), mesh.HasVertexColors(),
                                              false, false)) {
        ThrowInputError(output, "", "a writable location (Open3D could not write the mesh)");
      }
    });
    return summary;
  }
  open3d::geometry::PointCloud cloud;
  open3d::io::ReadPointCloudOption cloud_options;
  if (!open3d::io::ReadPointCloudFromPLY(input, cloud, cloud_options) || cloud.points_.empty()) {
    ThrowInputError(input, "", "a point-cloud or mesh PLY with vertices x, y, z (Open3D read none)");
  }
  MovePoints(&cloud.points_, &cloud.normals_, new_from_old);
  summary.vertices = static_cast<std::int64_t>(cloud.points_.size());
  WriteAtomically(output, [&](const std::string& tmp) {
    if (!open3d::io::WritePointCloudToPLY(tmp, cloud, open3d::io::WritePointCloudOption(ascii))) {
      ThrowInputError(output, "", "a writable location (Open3D could not write the point cloud)");
    }
  });
  return summary;
}

}  // namespace nerfreg
