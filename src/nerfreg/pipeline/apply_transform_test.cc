// reg apply on files of every kind it takes: T then T^-1 gives each file back within 1e-6, and
// the outputs follow the project's rules (an existing output needs force; an input is never replaced).
#include "nerfreg/pipeline/apply_transform.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "nerfreg/data/colmap.h"
#include "nerfreg/data/npy.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/splat_test_util.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/render/mesh.h"
#include "nerfreg/render/procedural.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

const Sim3d kTargetFromSource(0.6,
                              Eigen::Quaterniond(Eigen::AngleAxisd(2.5, Eigen::Vector3d(-0.2, 1, 0.4).normalized())),
                              Eigen::Vector3d(-0.7, 0.3, 1.2));

class ApplyTransform : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteJsonFile(dir_.File("t.json"), {{"target_from_source", MatrixToJson(kTargetFromSource.ToMatrix())}});
  }

  // INPUT -> moved (T), -> back (T^-1); returns the result of the first.
  ApplyTransformResult RoundTrip(const std::string& input, const std::string& moved, const std::string& back) {
    ApplyTransformOptions o{dir_.File("t.json"), input, moved};
    const ApplyTransformResult r = ApplyTransformFile(o);
    ApplyTransformOptions inverse{dir_.File("t.json"), moved, back, /*inverse=*/true};
    const ApplyTransformResult rb = ApplyTransformFile(inverse);
    EXPECT_EQ(rb.kind, r.kind);
    EXPECT_LT((rb.applied.ToMatrix() * r.applied.ToMatrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
    return r;
  }
  ScopedTempDir dir_;
};

TEST_F(ApplyTransform, SplatPlyRoundTripsWithin1e6) {
  const Splats s = RandomSplats(200, 3, 41);
  WriteSplatPly(s, dir_.File("s.ply"));
  const ApplyTransformResult r = RoundTrip(dir_.File("s.ply"), dir_.File("moved.ply"), dir_.File("back.ply"));
  EXPECT_EQ(r.kind, ApplyInputKind::kSplats);
  EXPECT_EQ(r.items, 200);
  const Splats moved = ReadSplatPly(dir_.File("moved.ply")), back = ReadSplatPly(dir_.File("back.ply"));
  EXPECT_GT((moved.position - s.position).cwiseAbs().maxCoeff(), 0.1);
  EXPECT_LT((back.position - s.position).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((back.log_scale - s.log_scale).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((back.rotation - s.rotation).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((back.f_rest - s.f_rest).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((back.normal - s.normal).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_EQ(back.f_dc, s.f_dc);
  EXPECT_EQ(back.opacity, s.opacity);
  EXPECT_EQ(back.extras[0].values, s.extras[0].values);
}

TEST_F(ApplyTransform, MeshAndPointCloudPlyRoundTripWithin1e6) {
  TriangleMesh box = MakeBox(Eigen::Vector3f(0.5f, 0.3f, 0.2f), Eigen::Vector3f(0.2f, 0.6f, 0.9f), 2);
  // A PLY mesh written as the mesh exporter writes it (binary floats, normals, colours).
  std::string ply = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(box.vertices.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                    "property float nz\nelement face " +
                    std::to_string(box.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : box.vertices)
    ply += std::to_string(v.x()) + " " + std::to_string(v.y()) + " " + std::to_string(v.z()) + " 0 0 1\n";
  for (const auto& t : box.triangles)
    ply += "3 " + std::to_string(t.x()) + " " + std::to_string(t.y()) + " " + std::to_string(t.z()) + "\n";
  WriteFileAtomic(dir_.File("mesh.ply"), ply);
  const ApplyTransformResult r =
      RoundTrip(dir_.File("mesh.ply"), dir_.File("mesh_moved.ply"), dir_.File("mesh_back.ply"));
  EXPECT_EQ(r.kind, ApplyInputKind::kPly);
  const TriangleMesh moved = LoadMesh(dir_.File("mesh_moved.ply")), back = LoadMesh(dir_.File("mesh_back.ply"));
  const TriangleMesh original = LoadMesh(dir_.File("mesh.ply"));
  ASSERT_EQ(back.vertices.size(), original.vertices.size());
  ASSERT_EQ(back.triangles.size(), original.triangles.size());
  for (size_t i = 0; i < original.vertices.size(); ++i) {
    const Eigen::Vector3d expected = kTargetFromSource * Eigen::Vector3d(original.vertices[i].cast<double>());
    EXPECT_LT((moved.vertices[i].cast<double>() - expected).norm(), 1e-6);
    EXPECT_LT((back.vertices[i] - original.vertices[i]).norm(), 1e-6);
  }
  EXPECT_EQ(back.triangles, original.triangles);

  WriteFileAtomic(dir_.File("cloud.ply"),
                  "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                  "property double z\nend_header\n0.1 0.2 0.3\n-1 2 0.5\n3 -0.25 1\n");
  RoundTrip(dir_.File("cloud.ply"), dir_.File("cloud_moved.ply"), dir_.File("cloud_back.ply"));
  // Open3D writes binary doubles: the three points come back to within 1e-6.
  const std::string bytes = ReadFileToString(dir_.File("cloud_back.ply"));
  const size_t body = bytes.find("end_header\n") + 11;
  ASSERT_NE(bytes.find("property double x"), std::string::npos) << bytes.substr(0, body);
  ASSERT_EQ(bytes.size() - body, 3 * 3 * sizeof(double));
  const double expected[] = {0.1, 0.2, 0.3, -1, 2, 0.5, 3, -0.25, 1};
  for (int k = 0; k < 9; ++k) {
    double v;
    std::memcpy(&v, bytes.data() + body + 8 * k, 8);
    EXPECT_NEAR(v, expected[k], 1e-6);
  }
}

TEST_F(ApplyTransform, TransformsJsonWithNerfstudioDataparserRoundTrips) {
  CreateDirectories(dir_.File("ns"));
  WriteFileAtomic(dir_.File("ns/transforms.json"),
                  R"({"camera_model": "OPENCV", "fl_x": 50, "fl_y": 50, "cx": 20, "cy": 15,
    "w": 40, "h": 30, "applied_transform": [[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0]],
    "frames": [{"file_path": "images/a.png", "transform_matrix": [[1, 0, 0, 1], [0, 0, -1, -3], [0, 1, 0, 0.5], [0, 0, 0, 1]]}]})");
  const Sim3d trained_from_data(0.25, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX())),
                                Eigen::Vector3d(0.1, 0, 0));
  WriteDataparserTransforms(trained_from_data, dir_.File("ns/dataparser_transforms.json"));
  CreateDirectories(dir_.File("moved"));
  CreateDirectories(dir_.File("back"));
  const ApplyTransformResult r =
      RoundTrip(dir_.File("ns"), dir_.File("moved/transforms.json"), dir_.File("back/transforms.json"));
  EXPECT_EQ(r.kind, ApplyInputKind::kTransformsJson);
  EXPECT_EQ(r.written.size(), 2u);  // and dataparser_transforms.json beside it
  const Dataset in = ReadTransformsJson(dir_.File("ns/transforms.json"));
  const Dataset moved = ReadTransformsJson(dir_.File("moved/transforms.json"));
  const Dataset back = ReadTransformsJson(dir_.File("back/transforms.json"));
  EXPECT_LT((back.frames[0].cam_from_world.ToMatrix() - in.frames[0].cam_from_world.ToMatrix()).norm(), 1e-6);
  EXPECT_LT((*back.applied_transform - *in.applied_transform).norm(), 1e-6);
  EXPECT_LT((back.trained_from_data->ToMatrix() - in.trained_from_data->ToMatrix()).norm(), 1e-6);
  // The trained model's frame did not move: a camera there is where it was.
  const Sim3d trained_from_moved = *moved.trained_from_data;
  EXPECT_LT((trained_from_moved.TransformCamera(moved.frames[0].cam_from_world).ToMatrix() -
             trained_from_data.TransformCamera(in.frames[0].cam_from_world).ToMatrix())
                .norm(),
            1e-9);
}

TEST_F(ApplyTransform, ColmapTextAndBinaryAndLlffRoundTrip) {
  ColmapModel model;
  ColmapCamera cam;
  cam.camera_id = 1;
  cam.model = "PINHOLE";
  cam.width = 40;
  cam.height = 30;
  cam.params = {50, 50, 20, 15};
  model.cameras[1] = cam;
  for (std::uint32_t i = 1; i <= 3; ++i) {
    ColmapImage im;
    im.image_id = i;
    im.camera_id = 1;
    im.name = "im" + std::to_string(i) + ".png";
    im.cam_from_world = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * i, Eigen::Vector3d::UnitY())),
                                Eigen::Vector3d(0.1 * i, 0.2, 3));
    model.images[i] = im;
  }
  ColmapPoint3D p;
  p.point3d_id = 5;
  p.xyz = Eigen::Vector3d(0.3, -0.2, 0.8);
  model.points3d[5] = p;
  for (const bool binary : {false, true}) {
    const std::string in = dir_.File(binary ? "bin" : "txt");
    CreateDirectories(in);
    binary ? WriteColmapBinary(model, in) : WriteColmapText(model, in);
    const std::string moved = in + "_moved", back = in + "_back";
    EXPECT_EQ(RoundTrip(in, moved, back).kind, ApplyInputKind::kColmap);
    EXPECT_EQ(FileExists(JoinPaths(moved, "cameras.bin")), binary);
    const ColmapModel m = ReadColmapModel(back);
    for (const auto& [id, im] : model.images) {
      EXPECT_LT((m.images.at(id).cam_from_world.ToMatrix() - im.cam_from_world.ToMatrix()).norm(), 1e-6);
    }
    EXPECT_LT((m.points3d.at(5).xyz - p.xyz).norm(), 1e-6);
    EXPECT_GT((ReadColmapModel(moved).points3d.at(5).xyz - p.xyz).norm(), 0.1);
  }
  NpyArray llff;
  llff.shape = {2, 17};
  for (int i = 0; i < 34; ++i) llff.data.push_back(std::cos(0.3 * i));
  CreateDirectories(dir_.File("llff"));
  WriteNpy(dir_.File("llff/poses_bounds.npy"), llff);
  EXPECT_EQ(RoundTrip(dir_.File("llff"), dir_.File("moved.npy"), dir_.File("back.npy")).kind, ApplyInputKind::kLlff);
  const NpyArray back = ReadNpy(dir_.File("back.npy"));
  for (size_t k = 0; k < llff.data.size(); ++k) EXPECT_NEAR(back.data[k], llff.data[k], 1e-6);
}

TEST_F(ApplyTransform, NerfBlockRoundTripsToItsOwnFrame) {
  FieldOptions fo;
  fo.encoding.log2_table_size = 12;
  fo.encoding.levels = 4;
  OccupancyGridOptions go;
  go.resolution = 16;
  NerfBlock b = NerfBlock::Create(fo, go, MarchOptions(), 1);
  SaveNerfBlock(b, dir_.File("b.ckpt"));
  EXPECT_EQ(RoundTrip(dir_.File("b.ckpt"), dir_.File("moved.ckpt"), dir_.File("back.ckpt")).kind,
            ApplyInputKind::kNerfBlock);
  const NerfBlock moved = LoadNerfBlock(dir_.File("moved.ckpt")), back = LoadNerfBlock(dir_.File("back.ckpt"));
  EXPECT_LT((moved.world_from_field.ToMatrix() - kTargetFromSource.ToMatrix()).norm(), 1e-12);
  EXPECT_FALSE(back.Moved());
  EXPECT_TRUE(torch::equal(back.field->table, b.field->table));  // the field itself is untouched
}

TEST_F(ApplyTransform, OutputsFollowTheRules) {
  WriteSplatPly(RandomSplats(5, 0, 1), dir_.File("s.ply"));
  auto error = [&](const std::string& out, bool force) {
    return InputErrorOf([&] { ApplyTransformFile({dir_.File("t.json"), dir_.File("s.ply"), out, false, force}); });
  };
  // --force never replaces an input (the splats, or T.json itself).
  EXPECT_NE(error(dir_.File("s.ply"), true).find("expected an output that is not an input"), std::string::npos);
  WriteFileAtomic(dir_.File("transforms.json"), R"({"fl_x": 10, "w": 4, "h": 4, "frames": []})");
  const std::string onto_transform = InputErrorOf([&] {
    ApplyTransformFile({dir_.File("t.json"), dir_.File("transforms.json"), dir_.File("t.json"), false, true});
  });
  EXPECT_NE(onto_transform.find("t.json: expected an output that is not an input"), std::string::npos)
      << onto_transform;
  EXPECT_TRUE(ReadJsonFile(dir_.File("t.json")).contains("target_from_source"));
  WriteFileAtomic(dir_.File("old.ply"), "old");
  EXPECT_NE(error(dir_.File("old.ply"), false).find("exists; pass --force"), std::string::npos);
  EXPECT_EQ(error(dir_.File("old.ply"), true), "");
  EXPECT_TRUE(IsSplatPly(dir_.File("old.ply")));
  EXPECT_NE(error(dir_.File("s.json"), false).find("--out: expected a .ply path for splats"), std::string::npos);
  // A transform that is not a similarity.
  WriteJsonFile(dir_.File("shear.json"),
                {{"target_from_source", {{1, 0.5, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}}});
  const std::string e = InputErrorOf([&] {
    ApplyTransformFile({dir_.File("shear.json"), dir_.File("s.ply"), dir_.File("x.ply")});
  });
  EXPECT_NE(e.find("shear.json: target_from_source: expected a similarity transform"), std::string::npos) << e;
  EXPECT_FALSE(FileExists(dir_.File("x.ply")));
}

}  // namespace
}  // namespace nerfreg
