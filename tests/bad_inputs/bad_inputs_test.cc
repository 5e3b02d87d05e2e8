// The bad-input battery: each case is a broken input, the command run on it, and the message
// class it must produce. A case passes when the command exits 2 with a one-line error naming the
// file (and field), leaves no output behind, and does not crash (exit 3 or a signal fails it).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>

#include "cli_test_util.h"
#include "nerfreg/data/ngp_test_snapshot.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/splat_test_util.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

struct BadInputCase {
  const char* name;
  // Writes the broken input into dir; returns the nerfreg arguments (may use dir).
  std::function<std::string(const std::string& dir)> setup;
  const char* expected;  // substring of the error line, after "error: "
  const char* output;    // output path (relative to dir) that must not exist afterwards, or ""
};

const std::vector<BadInputCase>& Cases() {
  static const std::vector<BadInputCase> cases = {
      {"report_missing_run_dir", [](const std::string& d) { return "report " + d + "/nope --out " + d + "/r.html"; },
       "nope: expected a run directory", "r.html"},
      {"report_existing_output_without_force",
       [](const std::string& d) {
         CreateDirectories(d + "/run");
         WriteFileAtomic(d + "/r.html", "old");
         return "report " + d + "/run --out " + d + "/r.html";
       },
       "r.html: exists; pass --force to overwrite", ""},
      {"render_missing_mesh",
       [](const std::string& d) { return "render --mesh " + d + "/none.obj --out " + d + "/out"; },
       "none.obj: expected an existing mesh file", "out"},
      {"render_unreadable_mesh",
       [](const std::string& d) {
         WriteFileAtomic(d + "/bad.off", "OFF\n3 1 0\n0 0 0\n1 0\n");
         return "render --mesh " + d + "/bad.off --out " + d + "/out";
       },
       "bad.off: face 0: expected a line", "out"},
      {"render_bad_size", [](const std::string& d) { return "render --procedural 1 --size 0x5 --out " + d + "/out"; },
       "--size", "out"},
      {"render_room_of_a_mesh",
       [](const std::string& d) {
         return "render --mesh /usr/share/assimp/models/OBJ/spider.obj --trajectory room --out " + d + "/out";
       },
       "--trajectory: expected orbit, forward or llff with --mesh", "out"},
      {"render_room_of_tiles",
       [](const std::string& d) {
         return "render --procedural 1 --trajectory room --material repetitive --views 2 --size 8 --out " + d + "/out";
       },
       "--material: expected textured or low-texture for rooms", "out"},
      {"render_existing_output",
       [](const std::string& d) {
         CreateDirectories(d + "/out");
         return "render --procedural 1 --views 2 --size 8 --out " + d + "/out";
       },
       "out: exists; pass --force to overwrite", ""},
      {"convert_truncated_json",
       [](const std::string& d) {
         WriteFileAtomic(d + "/transforms.json", "{\"frames\": [");
         return "convert " + d + "/transforms.json --to colmap --out " + d + "/sparse";
       },
       "transforms.json: expected valid JSON", "sparse"},
      {"convert_bad_matrix",
       [](const std::string& d) {
         WriteFileAtomic(
             d + "/transforms.json",
             R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0],[0,1,0]]}]})");
         return "convert " + d + "/transforms.json --to colmap --out " + d + "/sparse";
       },
       "transforms.json: frames[0].transform_matrix: expected a 4x4 matrix", "sparse"},
      {"convert_missing_image_for_size",
       [](const std::string& d) {
         WriteFileAtomic(
             d + "/transforms.json",
             R"({"camera_angle_x": 0.7, "frames": [{"file_path": "./train/r_0", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
         return "convert " + d + "/transforms.json --to colmap --out " + d + "/sparse";
       },
       "r_0.png: expected an existing image file", "sparse"},
      {"convert_truncated_npy",
       [](const std::string& d) {
         WriteFileAtomic(d + "/poses_bounds.npy", std::string("\x93NUMPY\x01\x00", 8));
         return "convert " + d + "/poses_bounds.npy --to nerf --out " + d + "/t.json";
       },
       "poses_bounds.npy", "t.json"},
      {"convert_colmap_bad_camera_model",
       [](const std::string& d) {
         WriteFileAtomic(d + "/m/cameras.txt", "1 FISHEYE_X 64 48 1 2 3\n");
         WriteFileAtomic(d + "/m/images.txt", "");
         return "convert " + d + "/m --to nerf --out " + d + "/t.json";
       },
       "cameras.txt: line 1 MODEL: expected SIMPLE_PINHOLE", "t.json"},
      {"convert_unknown_format",
       [](const std::string& d) { return "convert " + d + " --to nerf --out " + d + "/t.json"; },
       "expected a transforms.json, an LLFF poses_bounds.npy or a COLMAP model folder", "t.json"},
      {"ngp_truncated_snapshot",
       [](const std::string& d) {
         auto bytes = TestNgpSnapshotBytes(MakeTestNgpSnapshot().json, true);
         bytes.resize(bytes.size() / 2);
         WriteFileAtomic(d + "/s.ingp", std::string(bytes.begin(), bytes.end()));
         return "nerf import " + d + "/s.ingp --out " + d + "/b.ckpt";
       },
       "s.ingp: expected a complete zlib/gzip-compressed .ingp snapshot", "b.ckpt"},
      {"ngp_params_count_mismatch",
       [](const std::string& d) {
         auto t = MakeTestNgpSnapshot();
         t.json["snapshot"]["n_params"] = t.params.size() - 8;
         WriteTestNgpSnapshot(t.json, d + "/s.msgpack", false);
         return "nerf import " + d + "/s.msgpack --out " + d + "/b.ckpt";
       },
       "s.msgpack: snapshot.n_params: expected 9696 for this encoding and these networks", "b.ckpt"},
      {"ngp_claims_1e12_params",
       [](const std::string& d) {
         auto t = MakeTestNgpSnapshot();
         t.json["snapshot"]["n_params"] = std::uint64_t(1000000000000ull);
         WriteTestNgpSnapshot(t.json, d + "/s.msgpack", false);
         return "nerf import " + d + "/s.msgpack --out " + d + "/b.ckpt";
       },
       "(the file claims 1000000000000)", "b.ckpt"},
      {"ngp_unsupported_encoding",
       [](const std::string& d) {
         auto t = MakeTestNgpSnapshot();
         t.json["encoding"]["otype"] = "TiledGrid";
         WriteTestNgpSnapshot(t.json, d + "/s.msgpack", false);
         return "nerf import " + d + "/s.msgpack --out " + d + "/b.ckpt";
       },
       "s.msgpack: encoding.otype: expected \"HashGrid\"", "b.ckpt"},
      {"ngp_deeply_nested_snapshot",
       [](const std::string& d) {
         // 3 MB of nested one-element arrays, gzip-compressed to 3 KB: overflowed the stack.
         WriteFileAtomic(d + "/d.ingp", ReadFileToString(std::string(NERFREG_SOURCE_DIR) +
                                                         "/fuzz/corpus/ngp_snapshot/deep_nesting.ingp"));
         return "nerf import " + d + "/d.ingp --out " + d + "/b.ckpt";
       },
       "d.ingp: expected an instant-ngp snapshot nested at most 64 levels deep", "b.ckpt"},
      {"colmap_negative_focal",
       [](const std::string& d) {
         WriteFileAtomic(d + "/m/cameras.txt", "1 PINHOLE 16 16 -20 20 8 8\n");
         WriteFileAtomic(d + "/m/images.txt", "1 1 0 0 0 0 0 0 1 a.png\n\n");
         WriteFileAtomic(d + "/m/points3D.txt", "");
         return "convert " + d + "/m --to nerf --out " + d + "/t.json";
       },
       "m: frames[0]: expected valid intrinsics", "t.json"},
      {"transforms_absurd_focal",
       [](const std::string& d) {
         WriteFileAtomic(
             d + "/transforms.json",
             R"({"fl_x": 1e308, "fl_y": 1e308, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
         return "convert " + d + "/transforms.json --to colmap --out " + d + "/sparse";
       },
       "frames[0].fl_x: expected a focal length of at most 1e6 pixels", "sparse"},
      {"transforms_absurd_translation",
       [](const std::string& d) {
         WriteFileAtomic(
             d + "/transforms.json",
             R"({"fl_x": 10, "w": 4, "h": 4, "frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,1e308],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})");
         return "convert " + d + "/transforms.json --to colmap --out " + d + "/sparse";
       },
       "frames[0].transform_matrix: expected a finite camera position within 1e7 scene units", "sparse"},
      {"mesh_vertices_coincide",
       [](const std::string& d) {
         WriteFileAtomic(d + "/same.off", "OFF\n3 1 0\n1 1 1\n1 1 1\n1 1 1\n3 0 1 2\n");
         return "render --mesh " + d + "/same.off --views 2 --size 8 --out " + d + "/out";
       },
       "same.off: vertices: expected vertices spanning a finite, non-zero extent", "out"},
      {"dbarf_poses_zero_features",
       [](const std::string& d) { return "dbarf poses " + d + " --focal 100 --max-features 0 --out " + d + "/p"; },
       "error: --max-features: expected > 0, got 0", "p"},
      {"dbarf_poses_negative_sparse_keypoints",
       [](const std::string& d) {
         return "dbarf poses " + d + " --focal 100 --sift-sparse-keypoints -1 --out " + d + "/p";
       },
       "error: --sift-sparse-keypoints: expected >= 0, got -1", "p"},
      {"dbarf_poses_unknown_sift_normalization",
       [](const std::string& d) {
         return "dbarf poses " + d + " --focal 100 --sift-normalization root --out " + d + "/p";
       },
       "error: --sift-normalization: expected l1-root or l2, got 'root'", "p"},
      {"dbarf_poses_unknown_pairs",
       [](const std::string& d) { return "dbarf poses " + d + " --pairs nearby --out " + d + "/p"; },
       "error: --pairs: expected exhaustive, sequential, retrieval or auto, got \"nearby\"", "p"},
      {"dbarf_poses_negative_focal",
       [](const std::string& d) { return "dbarf poses " + d + " --focal -5 --out " + d + "/p"; },
       "error: --focal: expected a focal length in pixels > 0", "p"},
      {"dbarf_finetune_negative_depth_ba_rounds",
       [](const std::string& d) {
         return "dbarf finetune " + d + "/posed.json --depth-ba-rounds -1 --out " + d + "/ft.pt";
       },
       "error: --depth-ba-rounds: expected >= 0, got -1", "ft.pt"},
      {"dbarf_finetune_depth_ba_view_range_below_one",
       [](const std::string& d) {
         return "dbarf finetune " + d + "/posed.json --depth-ba-view-range 0.5 --out " + d + "/ft.pt";
       },
       "error: --depth-ba-view-range: expected 0 or > 1, got 0.5", "ft.pt"},
      {"reg_make_data_render_only_without_nerf_objects",
       [](const std::string& d) { return "reg make-data --procedural 1 --render-only --out " + d + "/out"; },
       "--render-only: expected --nerf-objects N > 0", "out"},
      {"reg_register_grid_not_a_multiple_of_16",
       [](const std::string& d) {
         return "reg register " + d + "/a.ckpt " + d + "/b.ckpt --grid-resolution 8 --out " + d + "/t.json";
       },
       "error: --grid-resolution: expected a multiple of 16 for the network", "t.json"},
      {"render_empty_out", [](const std::string& d) { return "render --procedural 1 --views 2 --size 8 --out \"\""; },
       "error: --out: expected a path", ""},
      {"unknown_option",
       [](const std::string& d) { return "report " + d + " --out " + d + "/r.html --no-such-option"; },
       "no-such-option", "r.html"},
      // 3D Gaussian splat PLYs (data/splat_ply.h), through reg register and reg apply.
      {"splats_nan_opacity",
       [](const std::string& d) {
         Splats s = RandomSplats(4, 1, 1);
         s.opacity(2) = std::nanf("");
         WriteSplatPly(s, d + "/nan.ply");
         WriteSplatPly(RandomSplats(4, 1, 2), d + "/good.ply");
         return "reg register " + d + "/nan.ply " + d + "/good.ply --method ransac --out " + d + "/t.json";
       },
       "nan.ply: vertex[2].opacity: expected a finite number (not NaN or infinite)", "t.json"},
      {"splats_zero_quaternion",
       [](const std::string& d) {
         Splats s = RandomSplats(4, 3, 3);
         s.rotation.col(1).setZero();
         WriteSplatPly(s, d + "/zero.ply", /*ascii=*/true);
         WriteFileAtomic(d + "/t.json", R"({"target_from_source": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})");
         return "reg apply " + d + "/t.json " + d + "/zero.ply --out " + d + "/out.ply";
       },
       "zero.ply: vertex[1].rot: expected a non-zero quaternion", "out.ply"},
      {"splats_missing_property",
       [](const std::string& d) {
         std::string ply = SerializeSplatPly(RandomSplats(2, 0, 4));
         ply.replace(ply.find("property float scale_2\n"), 23, "");
         WriteFileAtomic(d + "/missing.ply", ply);
         WriteFileAtomic(d + "/t.json", R"({"target_from_source": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})");
         return "reg apply " + d + "/t.json " + d + "/missing.ply --out " + d + "/out.ply";
       },
       "missing.ply: property scale_2: expected a float property of the vertex element (it is missing)", "out.ply"},
      {"splats_wrong_property_type",
       [](const std::string& d) {
         std::string ply = SerializeSplatPly(RandomSplats(2, 0, 5), /*ascii=*/true);
         ply.replace(ply.find("property float opacity"), 22, "property int opacity");
         WriteFileAtomic(d + "/typed.ply", ply);
         return "reg register " + d + "/typed.ply " + d + "/typed.ply --method ransac --out " + d + "/t.json";
       },
       "typed.ply: property opacity: expected type float (got int)", "t.json"},
      {"splats_header_claims_more_vertices",
       [](const std::string& d) {
         std::string ply = SerializeSplatPly(RandomSplats(3, 2, 6));
         ply.replace(ply.find("element vertex 3"), 16, "element vertex 2000000000");
         WriteFileAtomic(d + "/huge.ply", ply);
         return "reg register " + d + "/huge.ply " + d + "/huge.ply --method ransac --out " + d + "/t.json";
       },
       "huge.ply: element vertex: expected at most 3 vertices", "t.json"},
      {"reg_register_mesh_ply",
       [](const std::string& d) {
         WriteFileAtomic(d + "/m.ply",
                         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n0 0 0\n");
         return "reg register " + d + "/m.ply " + d + "/m.ply --method ransac --out " + d + "/t.json";
       },
       "m.ply: expected a NeRF block checkpoint or a 3D Gaussian splat PLY", "t.json"},
      {"reg_register_too_few_splats",
       [](const std::string& d) {
         WriteSplatPly(RandomSplats(50, 0, 9), d + "/few.ply");
         return "reg register " + d + "/few.ply " + d + "/few.ply --method ransac --out " + d + "/t.json";
       },
       "few.ply: vertex: expected at least 100 splats to register, got 50", "t.json"},
      {"reg_apply_scale_out_of_range",
       [](const std::string& d) {
         WriteSplatPly(RandomSplats(2, 0, 10), d + "/s.ply");
         WriteFileAtomic(d + "/big.json",
                         R"({"target_from_source": [[2000,0,0,0],[0,2000,0,0],[0,0,2000,0],[0,0,0,1]]})");
         return "reg apply " + d + "/big.json " + d + "/s.ply --out " + d + "/out.ply";
       },
       "big.json: target_from_source: expected a scale in [0.001, 1000], got 2000", "out.ply"},
      {"reg_apply_not_a_similarity",
       [](const std::string& d) {
         WriteSplatPly(RandomSplats(2, 0, 7), d + "/s.ply");
         WriteFileAtomic(d + "/shear.json", R"({"target_from_source": [[1,0.5,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})");
         return "reg apply " + d + "/shear.json " + d + "/s.ply --out " + d + "/out.ply";
       },
       "shear.json: target_from_source: expected a similarity transform", "out.ply"},
      {"reg_apply_force_onto_its_input",
       [](const std::string& d) {
         WriteSplatPly(RandomSplats(2, 0, 8), d + "/s.ply");
         WriteFileAtomic(d + "/t.json", R"({"target_from_source": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]})");
         return "reg apply " + d + "/t.json " + d + "/s.ply --out " + d + "/s.ply --force";
       },
       "s.ply: expected an output that is not an input", ""},
      // Usage errors CLI11 finds: the same one line, naming the argument.
      {"cli_unknown_flag", [](const std::string& d) { return "nerf eval " + d + "/a.ckpt " + d + "/data --bogus"; },
       "error: --bogus: expected an option or argument of this command", ""},
      {"cli_missing_required", [](const std::string& d) { return "dbarf pretrain " + d + "/scene"; },
       "error: --out: expected a value: it is required", ""},
      {"cli_value_not_in_set",
       [](const std::string& d) { return "dbarf pretrain " + d + "/scene --out " + d + "/w.pt --config huge"; },
       "error: --config: expected a valid value: huge not in {cpu,paper}", "w.pt"},
      {"cli_not_a_number",
       [](const std::string& d) { return "reg train " + d + "/pairs.json --out " + d + "/w.pt --iters many"; },
       "error: --iters: expected a value of its type, got many", "w.pt"},
      {"cli_missing_value",
       [](const std::string& d) { return "dbarf pretrain " + d + "/scene --out " + d + "/w.pt --steps"; },
       "error: --steps: expected 1 value(s) (INT), got none", "w.pt"},
  };
  return cases;
}

class BadInput : public ::testing::TestWithParam<size_t> {};

TEST_P(BadInput, FailsCleanlyWithANamedError) {
  const BadInputCase& c = Cases()[GetParam()];
  ScopedTempDir dir;
  const std::string args = c.setup(dir.path());
  const CommandResult r = RunNerfreg(args);
  EXPECT_EQ(r.exit_code, 2) << c.name << ": " << r.output;
  EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.name << ": " << r.output;
  if (*c.output) EXPECT_FALSE(std::filesystem::exists(dir.File(c.output))) << c.name;
  // No temp files left anywhere under the test dir.
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
}

// A usage error is one line, as every other bad input's error is (not CLI11's two).
TEST(BadInputCommandLine, UsageErrorsAreOneLine) {
  for (const std::string args : {"nerf eval a.ckpt data --bogus", "dbarf pretrain scene", "reg train p --iters x"}) {
    const CommandResult r = RunNerfreg(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    std::string out = r.output;
    while (!out.empty() && out.back() == '\n') out.pop_back();
    EXPECT_EQ(out.rfind("error: ", 0), 0u) << args << ": " << r.output;
    EXPECT_EQ(out.find('\n'), std::string::npos) << args << ": " << r.output;
  }
  // --help still prints the help, exit 0.
  const CommandResult help = RunNerfreg("nerf eval --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.output.find("--device"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Battery, BadInput, ::testing::Range<size_t>(0, Cases().size()),
                         [](const ::testing::TestParamInfo<size_t>& info) {
                           return std::string(Cases()[info.param].name);
                         });

}  // namespace
}  // namespace nerfreg
