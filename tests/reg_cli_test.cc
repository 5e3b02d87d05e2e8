// End-to-end registration commands: reg make-data -> reg train (SIGKILL mid-run, --resume) ->
// reg eval --pairs with every method; the bad-input cases of the registration network.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/data/ground_truth.h"
#include "nerfreg/reg/dreg_model.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/reg_train/pairs.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// The furniture path end to end on an archive the test writes: reg sh3f-split keeps a textured
// box (all of the hash range is train here) and excludes a 2-triangle panel, then reg make-data
// --meshes sh3f:train synthesises the box's pair in its split.
TEST(RegCli, Sh3fSplitThenMakeDataFromFurniture) {
  ScopedTempDir dir;
  Image tex(8, 8, 3, 0.2f);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 4; ++x) tex.at(x, y, 0) = 0.9f;
  std::string box = "mtllib box.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl wood\n";
  for (int k = 0; k < 8; ++k)
    box += "v " + std::to_string(k & 1) + " " + std::to_string((k >> 1) & 1) + " " + std::to_string(k >> 2) + "\n";
  for (const char* f : {"1 2 4 3", "5 7 8 6", "1 5 6 2", "3 4 8 7", "1 3 7 5", "2 6 8 4"}) {
    std::istringstream in(f);
    box += "f";
    for (int c = 1, v; in >> v; ++c) box += " " + std::to_string(v) + "/" + std::to_string(c);
    box += "\n";
  }
  const std::string catalog =
      "id#1=Test#box\nmodel#1=/t/box/box.obj\nwidth#1=50\nheight#1=40\ndepth#1=30\n"
      "id#2=Test#panel\nmodel#2=/t/panel.obj\nwidth#2=50\nheight#2=40\ndepth#2=30\n";
  const std::string panel = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
  CreateDirectories(dir.File("furniture"));
  WriteFileAtomic(dir.File("furniture/test.sh3f"),
                  MakeTestZip({{"PluginFurnitureCatalog.properties", catalog},
                               {"t/box/box.obj", box},
                               {"t/box/box.mtl", "newmtl wood\nKd 1 1 1\nmap_Kd wood.png\n"},
                               {"t/box/wood.png", EncodeImage(tex, ".png", "wood.png"), false},
                               {"t/panel.obj", panel}}));
  const std::string furniture = " --sh3f-dir " + dir.File("furniture");
  const CommandResult split = RunNerfreg("reg sh3f-split --train-percent 100 --val-percent 0 --quiet --out " +
                                         dir.File("split.json") + furniture);
  ASSERT_EQ(split.exit_code, 0) << split.output;
  const Json s = ReadJsonFile(dir.File("split.json"));
  EXPECT_EQ(s["train"], Json::array({"Test#box"}));
  EXPECT_EQ(s["counts"]["excluded_too_few_triangles"], 1) << s.dump();
  EXPECT_EQ(s["excluded"]["Test#panel"], "too few triangles (2)");
  EXPECT_EQ(s["models"]["Test#box"]["textures"], 1);

  const CommandResult made =
      RunNerfreg("reg make-data --meshes sh3f:train --mesh-pairs 1 --grid-resolution 32 --quiet --sh3f-split " +
                 dir.File("split.json") + furniture + " --out " + dir.File("data"));
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const Json pairs = ReadJsonFile(dir.File("data/pairs.json"));
  ASSERT_EQ(pairs["pairs"].size(), 1u) << pairs.dump();
  EXPECT_EQ(pairs["pairs"][0]["object"], "sh3f_Test_box");
  EXPECT_EQ(pairs["pairs"][0]["split"], "train");
  EXPECT_EQ(pairs["objects"]["sh3f_Test_box"]["sh3f_id"], "Test#box");

  const CommandResult bad = RunNerfreg("reg make-data --meshes sh3f:everything --out " + dir.File("bad"));
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.output.find("sh3f:train, sh3f:val or sh3f:test"), std::string::npos) << bad.output;
}

TEST(RegCli, MakeDataTrainKilledResumeAndEval) {
  ScopedTempDir dir;
  const CommandResult made =
      RunNerfreg("reg make-data --procedural 2 --mesh-pairs 1 --grid-resolution 32 --quiet --out " + dir.File("data"));
  ASSERT_EQ(made.exit_code, 0) << made.output;
  const Json pairs = ReadJsonFile(dir.File("data/pairs.json"));
  ASSERT_EQ(pairs["pairs"].size(), 2u);
  // make-data resumes: a second run skips the finished objects.
  const CommandResult again =
      RunNerfreg("reg make-data --procedural 2 --mesh-pairs 1 --grid-resolution 32 --out " + dir.File("data"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("\"objects_skipped\":2"), std::string::npos) << again.output;

  // Killed without warning mid-run: the weights and the training state still load.
  const std::string train = "reg train " + dir.File("data/pairs.json") + " --out " + dir.File("w.pt") +
                            " --iters 100000 --checkpoint-every 2 --val-every 0 --mirror 0.5 --recolour 0.5 --quiet";
  const CommandResult killed = RunShell("timeout -s KILL 15 " + std::string(NERFREG_BINARY) + " " + train);
  EXPECT_EQ(killed.exit_code, 137) << killed.output;
  DregModelOptions options;
  EXPECT_NO_THROW(LoadDregWeights(dir.File("w.pt"), &options));
  // The kill may land mid-write and leave that write's temporary file (nothing can catch
  // SIGKILL): the complete file is untouched, and the resumed run's first write removes it.
  const auto temp_files = [&] {
    std::vector<std::string> found;
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
      const std::string name = e.path().filename().string();
      if (name.find(".tmp.") != std::string::npos) found.push_back(name);
    }
    return found;
  };
  // Stand in for a kill mid-write so that the clean-up below is always exercised: a temporary
  // file of w.pt written by a process that has exited (a shell that printed its PID).
  const std::string dead_pid = RunShell("sh -c 'echo $$'").output;
  WriteFileAtomic(dir.File(".w.pt.tmp." + dead_pid.substr(0, dead_pid.find('\n')) + ".7"), "partial");
  ASSERT_FALSE(temp_files().empty());
  // The log says how far it got; --resume continues from the last checkpoint to a near end.
  int last_step = 0;
  {
    const CommandResult tail = RunShell("tail -n 1 " + dir.File("w.pt.log.jsonl"));
    last_step = Json::parse(tail.output)["step"].get<int>();
  }
  ASSERT_GT(last_step, 0);
  const int target = last_step + 3;
  const CommandResult resumed =
      RunNerfreg("reg train " + dir.File("data/pairs.json") + " --out " + dir.File("w.pt") + " --iters " +
                 std::to_string(target) + " --val-every 0 --mirror 0.5 --recolour 0.5 --resume --quiet");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_TRUE(temp_files().empty()) << temp_files().front();
  const Json summary = ReadJsonFile(dir.File("w.pt.json"));
  EXPECT_EQ(summary["iterations"].get<int>(), target);
  EXPECT_EQ(summary["options"]["mirror_probability"].get<double>(), 0.5);
  EXPECT_EQ(summary["options"]["colour_probability"].get<double>(), 0.5);
  const CommandResult bad_mirror = RunNerfreg("reg train " + dir.File("data/pairs.json") + " --out " +
                                              dir.File("w_bad.pt") + " --iters 2 --mirror 1.5 --quiet");
  EXPECT_NE(bad_mirror.exit_code, 0);
  EXPECT_NE(bad_mirror.output.find("--mirror"), std::string::npos) << bad_mirror.output;
  // It did not start again from zero: no step 1 after the resume.
  const CommandResult steps = RunShell("grep -c '\"step\":1,' " + dir.File("w.pt.log.jsonl"));
  EXPECT_EQ(steps.output.substr(0, 1), "1") << steps.output;

  // --init starts a new run (step 0, fresh optimizer) from those weights: with a vanishing
  // learning rate the result is still them, where a fresh start (the same seed) is not.
  const std::string short_run =
      "reg train " + dir.File("data/pairs.json") + " --iters 2 --lr 1e-12 --val-every 0 --quiet";
  ASSERT_EQ(RunNerfreg(short_run + " --init " + dir.File("w.pt") + " --out " + dir.File("w_init.pt")).exit_code, 0);
  ASSERT_EQ(RunNerfreg(short_run + " --out " + dir.File("w_fresh.pt")).exit_code, 0);
  {
    DregNet trained = LoadDregWeights(dir.File("w.pt"), nullptr);
    DregNet init = LoadDregWeights(dir.File("w_init.pt"), nullptr);
    DregNet fresh = LoadDregWeights(dir.File("w_fresh.pt"), nullptr);
    double init_diff = 0, fresh_diff = 0;
    const auto a = trained->parameters(), b = init->parameters(), c = fresh->parameters();
    for (size_t i = 0; i < a.size(); ++i) {
      init_diff = std::max(init_diff, (a[i] - b[i]).abs().max().item<double>());
      fresh_diff = std::max(fresh_diff, (a[i] - c[i]).abs().max().item<double>());
    }
    EXPECT_LT(init_diff, 1e-6);
    EXPECT_GT(fresh_diff, 1e-3);
  }
  // reg average: the element-wise mean of two runs; an existing output is kept without --force.
  const std::string average =
      "reg average " + dir.File("w.pt") + " " + dir.File("w_fresh.pt") + " --out " + dir.File("w_mean.pt");
  ASSERT_EQ(RunNerfreg(average).exit_code, 0);
  EXPECT_NE(RunNerfreg(average).exit_code, 0);
  {
    DregNet trained = LoadDregWeights(dir.File("w.pt"), nullptr);
    DregNet fresh = LoadDregWeights(dir.File("w_fresh.pt"), nullptr);
    DregNet mean = LoadDregWeights(dir.File("w_mean.pt"), nullptr);
    const auto a = trained->parameters(), c = fresh->parameters(), m = mean->parameters();
    double worst = 0;
    for (size_t i = 0; i < a.size(); ++i)
      worst = std::max(worst, (m[i] - (a[i] + c[i]) / 2).abs().max().item<double>());
    EXPECT_LT(worst, 1e-6);
  }

  // Every method on the pairs, one table with a summary line per method.
  const CommandResult eval =
      RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods dreg,ransac " +
                 "--refine none,icp --weights " + dir.File("w.pt") + " --out " + dir.File("eval.json"));
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  const Json table = ReadJsonFile(dir.File("eval.json"));
  EXPECT_EQ(table["rows"].size(), 2u * 4u);
  EXPECT_TRUE(table["summary"].contains("ransac+icp"));
  EXPECT_TRUE(table["summary"].contains("dreg"));
  // FPFH + RANSAC + ICP agrees with these synthesised pairs' ground truth (a wrong or inverted one
  // is tens of degrees off; one point per 0.11-unit cell limits ICP to a few degrees: 3.1 measured).
  EXPECT_LT(table["summary"]["ransac+icp"]["median_rotation_deg"].get<double>(), 10.0);
  // Successes are also counted apart by overlap: the pairs below the threshold are those pairs.json
  // says are, and the two bins hold every pair.
  const Json pairs_json = ReadJsonFile(dir.File("data/pairs.json"));
  const double threshold = 0.95;
  int below = 0;
  for (const auto& p : pairs_json["pairs"]) below += p["overlap"].get<double>() < threshold;
  const CommandResult binned =
      RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods ransac " +
                 "--overlap-threshold 0.95 --out " + dir.File("eval_binned.json"));
  ASSERT_EQ(binned.exit_code, 0) << binned.output;
  const Json by_overlap = ReadJsonFile(dir.File("eval_binned.json"))["summary"]["ransac+icp"]["by_overlap"];
  EXPECT_EQ(by_overlap["below"]["pairs"].get<int>(), below) << by_overlap.dump();
  EXPECT_EQ(by_overlap["below"]["pairs"].get<int>() + by_overlap["at_or_above"]["pairs"].get<int>(), 2)
      << by_overlap.dump();
  EXPECT_LE(by_overlap["below"]["successes_5deg_0.05"].get<int>(), below);
  EXPECT_NE(RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --overlap-threshold 1.5").exit_code, 0);
  // ICP on the mask without the half-turn check (the earlier refinement) is its own row name.
  const CommandResult mask =
      RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods ransac " +
                 "--refine icp --icp-points mask --no-flips --out " + dir.File("eval_mask.json"));
  ASSERT_EQ(mask.exit_code, 0) << mask.output;
  const Json mask_table = ReadJsonFile(dir.File("eval_mask.json"));
  EXPECT_TRUE(mask_table["summary"].contains("ransac+icp[mask][noflips]")) << mask_table["summary"].dump();
  EXPECT_LT(mask_table["summary"]["ransac+icp[mask][noflips]"]["median_rotation_deg"].get<double>(), 10.0);
  // --methods truth: the refinements started at the ground truth (their floor); unrefined it is
  // the truth itself, and grid ICP from it moves a few degrees at most (one point per cell).
  const CommandResult truth =
      RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --split all --methods truth " +
                 "--refine none,icp --out " + dir.File("eval_truth.json"));
  ASSERT_EQ(truth.exit_code, 0) << truth.output;
  const Json truth_table = ReadJsonFile(dir.File("eval_truth.json"));
  ASSERT_TRUE(truth_table["summary"].contains("truth+icp")) << truth_table["summary"].dump();
  EXPECT_LT(truth_table["summary"]["truth"]["mean_rotation_deg"].get<double>(), 1e-6);
  EXPECT_LT(truth_table["summary"]["truth+icp"]["median_rotation_deg"].get<double>(), 5.0);
  EXPECT_NE(RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --methods oracle").exit_code, 0);
  const CommandResult bad =
      RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") + " --methods ransac --icp-points all");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("--icp-points"), std::string::npos) << bad.output;
}

TEST(RegCli, BadWeightsAreClearErrors) {
  ScopedTempDir dir;
  ASSERT_EQ(
      RunNerfreg("reg make-data --procedural 1 --mesh-pairs 1 --grid-resolution 32 --quiet --out " + dir.File("data"))
          .exit_code,
      0);
  RunShell("echo 'not weights' > " + dir.File("bad.pt"));
  const CommandResult r = RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") +
                                     " --split all --methods dreg --weights " + dir.File("bad.pt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.pt"), std::string::npos) << r.output;
  const CommandResult missing = RunNerfreg("reg eval --pairs " + dir.File("data/pairs.json") +
                                           " --split all --methods dreg --weights " + dir.File("none.pt"));
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("none.pt"), std::string::npos) << missing.output;
  // Fine-tuning from a file that is not weights: the same clear error, and no output written.
  const CommandResult init = RunNerfreg("reg train " + dir.File("data/pairs.json") + " --iters 1 --init " +
                                        dir.File("bad.pt") + " --out " + dir.File("w.pt"));
  EXPECT_EQ(init.exit_code, 2) << init.output;
  EXPECT_NE(init.output.find("bad.pt"), std::string::npos) << init.output;
  EXPECT_FALSE(FileExists(dir.File("w.pt")));
  // Averaging a file that is not weights: the same, naming it.
  const CommandResult average = RunNerfreg("reg average " + dir.File("bad.pt") + " --out " + dir.File("w.pt"));
  EXPECT_EQ(average.exit_code, 2) << average.output;
  EXPECT_NE(average.output.find("bad.pt"), std::string::npos) << average.output;
  EXPECT_FALSE(FileExists(dir.File("w.pt")));
  // Training pairs whose grids have no surface voxels: every step would be skipped, so reg train
  // says so and writes nothing (it used to print a weights path it had not written).
  const auto pairs = ReadPairs(dir.File("data/pairs.json"));
  ASSERT_FALSE(pairs.empty());
  RegGrid empty = LoadRegGrid(pairs[0].source);
  empty.mask = torch::zeros_like(empty.mask);
  SaveRegGrid(empty, dir.File("empty.grid"));
  WriteJsonFile(dir.File("empty_pairs.json"),
                Json{{"pairs", Json::array({Json{{"name", "empty"},
                                                 {"object", "empty"},
                                                 {"kind", "mesh"},
                                                 {"split", "train"},
                                                 {"source", "empty.grid"},
                                                 {"target", "empty.grid"},
                                                 {"target_from_source", MatrixToJson(Eigen::Matrix4d::Identity())},
                                                 {"overlap", 1.0}}})}});
  const CommandResult skipped =
      RunNerfreg("reg train " + dir.File("empty_pairs.json") + " --iters 2 --config cpu --out " + dir.File("w.pt"));
  EXPECT_EQ(skipped.exit_code, 2) << skipped.output;
  EXPECT_NE(skipped.output.find("surface voxels"), std::string::npos) << skipped.output;
  EXPECT_FALSE(FileExists(dir.File("w.pt")));
  EXPECT_FALSE(FileExists(dir.File("w.pt.log.jsonl")));
}

// reg register (default --refine field) and reg register-many on one trained block given twice
// (three times): the true pose is the identity, which RANSAC + ICP finds and the field alignment
// must keep; the outputs record the refinement. (AlignFields' recovery of a known move of a
// trained block's field is in reg/grid_extraction_test.cc; measured accuracy in
// results/registration.md.)
TEST(RegCli, RegisterAndRegisterManyRefineOnTheFields) {
  ScopedTempDir dir;
  ASSERT_EQ(RunNerfreg("render --procedural 4 --views 30 --size 24 --supersample 1 --test-every 6 --quiet --out " +
                       dir.File("data"))
                .exit_code,
            0);
  const std::string block = dir.File("b.ckpt");
  ASSERT_EQ(RunNerfreg("nerf train " + dir.File("data") + " --out " + block + " --iters 150 --samples 4096 --quiet")
                .exit_code,
            0);

  const CommandResult one =
      RunNerfreg("reg register " + block + " " + block + " --method ransac --quiet --out " + dir.File("t.json"));
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const Json t = ReadJsonFile(dir.File("t.json"));
  // With the scale free (the default) the kept pose is also polished with its scale held, and
  // "+polish" says so when the polish lowered the fields' cost.
  EXPECT_EQ(t["method"].get<std::string>().rfind("ransac+icp+field", 0), 0u) << t["method"];
  // The polish aligns the fields coarse (samples spread wider) to fine.
  ASSERT_TRUE(t["polish"]["field_coarse"].is_object()) << t.dump();
  EXPECT_GT(t["polish"]["field_coarse"]["samples"].get<int>(), 100) << t.dump();
  ASSERT_TRUE(t["field"].is_object()) << t.dump();
  EXPECT_LE(t["field"]["final_cost"].get<double>(), t["field"]["initial_cost"].get<double>());
  EXPECT_GT(t["field"]["samples"].get<int>(), 100);
  const Sim3d est = Sim3d::FromMatrix(JsonField(t, "t.json")["target_from_source"].Matrix(4, 4));
  EXPECT_LT(RotationErrorDeg(est.rotation, Eigen::Quaterniond::Identity()), 0.2);
  EXPECT_LT(est.translation.norm(), 0.005);

  // register-many registers each pair as reg register does, with its flags.
  const CommandResult many =
      RunNerfreg("reg register-many " + block + " " + block + " " + block + " --method ransac --quiet --out " +
                 dir.File("many.json") + " --merged-cameras " + dir.File("cams.json"));
  ASSERT_EQ(many.exit_code, 0) << many.output;
  // One block three times: each image once in the merged cameras, seen by all three, the three
  // cameras together (the registration's identity).
  const Json cams = ReadJsonFile(dir.File("cams.json"));
  ASSERT_EQ(cams["frames"].size(), ReadJsonFile(dir.File("data/transforms.json"))["frames"].size()) << cams.dump();
  for (const Json& f : cams["frames"]) {
    EXPECT_EQ(f["blocks"], Json::array({0, 1, 2})) << f.dump();
    EXPECT_LT(f["spread"]["rotation_deg"].get<double>(), 0.2) << f.dump();
    EXPECT_LT(f["spread"]["centre"].get<double>(), 0.05) << f.dump();
  }
  const Json m = ReadJsonFile(dir.File("many.json"));
  ASSERT_EQ(m["world_from_block"].size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(m["connected"][k].get<bool>());
    const Sim3d w = Sim3d::FromMatrix(JsonField(m, "many.json")["world_from_block"][k].Matrix(4, 4));
    EXPECT_LT(RotationErrorDeg(w.rotation, Eigen::Quaterniond::Identity()), 0.2) << k;
  }
  EXPECT_EQ(m["status"], "registered");
  for (const auto& e : m["edges"]) {
    EXPECT_TRUE(e["field"].is_object()) << e.dump();
    EXPECT_EQ(e["method"].get<std::string>().rfind("ransac+icp+field", 0), 0u) << e.dump();
    EXPECT_EQ(e["status"], "registered") << e.dump();
  }

  // dreg + ICP: on the grids, then on the blocks' occupied points (recorded, with the pose it
  // started from). The network's answer here is whatever it is; the ICPs must end at the identity.
  const CommandResult d = RunNerfreg("reg register " + block + " " + block +
                                     " --method dreg --refine icp --quiet --out " + dir.File("d.json"));
  ASSERT_EQ(d.exit_code, 0) << d.output;
  const Json dj = ReadJsonFile(dir.File("d.json"));
  EXPECT_EQ(dj["method"].get<std::string>(), "dreg+icp+block") << dj.dump();
  ASSERT_TRUE(dj.contains("block_icp") && dj["block_icp"].contains("before")) << dj.dump();
  EXPECT_GT(dj["block_icp"]["fitness"].get<double>(), 0.9) << dj.dump();
  const Sim3d de = Sim3d::FromMatrix(JsonField(dj, "d.json")["target_from_source"].Matrix(4, 4));
  EXPECT_LT(RotationErrorDeg(de.rotation, Eigen::Quaterniond::Identity()), 0.5);
  EXPECT_TRUE(dj["agreeing_candidates"].is_null()) << "one candidate, nothing to agree with";

  // The default, auto + field: three candidates, all at the identity here, so the kept one has
  // two others agreeing and no warning about it.
  const CommandResult a = RunNerfreg("reg register " + block + " " + block + " --out " + dir.File("a.json"));
  ASSERT_EQ(a.exit_code, 0) << a.output;
  const Json aj = ReadJsonFile(dir.File("a.json"));
  EXPECT_EQ(aj["agreeing_candidates"].get<int>(), 2) << aj.dump();
  EXPECT_EQ(a.output.find("no other candidate"), std::string::npos) << a.output;

  // reg eval --refine field on a real pair (block_K.ckpt beside block_K.grid): the block against
  // itself, identity.
  ASSERT_EQ(RunNerfreg("reg extract " + block + " --quiet --out " + dir.File("b.grid")).exit_code, 0);
  const Json pairs = {{"pairs", Json::array({{{"name", "self"},
                                              {"kind", "nerf"},
                                              {"split", "val"},
                                              {"source", "b.grid"},
                                              {"target", "b.grid"},
                                              {"target_from_source", MatrixToJson(Eigen::Matrix4d::Identity())}}})}};
  WriteJsonFile(dir.File("pairs.json"), pairs);
  const CommandResult eval = RunNerfreg("reg eval --pairs " + dir.File("pairs.json") +
                                        " --methods ransac --refine block-icp,field --out " + dir.File("eval.json"));
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  const Json table = ReadJsonFile(dir.File("eval.json"));
  for (const char* name : {"ransac+icp+block", "ransac+icp+block+field"}) {
    ASSERT_TRUE(table["summary"].contains(name)) << name << " " << table.dump();
    EXPECT_LT(table["summary"][name]["median_rotation_deg"].get<double>(), 0.2) << name;
  }

  // --methods auto is reg register itself on the pair's blocks: the same kept candidate and pose
  // as a.json's (the same defaults and seed).
  const CommandResult ev_auto = RunNerfreg("reg eval --pairs " + dir.File("pairs.json") +
                                           " --methods auto --refine field --out " + dir.File("eval_auto.json"));
  ASSERT_EQ(ev_auto.exit_code, 0) << ev_auto.output;
  const Json auto_row = ReadJsonFile(dir.File("eval_auto.json"))["rows"][0];
  EXPECT_EQ(auto_row["method"], "auto+field") << auto_row.dump();
  EXPECT_EQ(auto_row["kept"], aj["method"]) << auto_row.dump();
  EXPECT_EQ(auto_row["status"], aj["status"]) << auto_row.dump();
  const Sim3d ae = Sim3d::FromMatrix(JsonField(aj, "a.json")["target_from_source"].Matrix(4, 4));
  EXPECT_NEAR(auto_row["rotation_error_deg"].get<double>(),
              RotationErrorDeg(ae.rotation, Eigen::Quaterniond::Identity()), 1e-9);

  // Bad refinement options are one-line errors before any work.
  const CommandResult bad =
      RunNerfreg("reg register " + block + " " + block + " --field-iterations -1 --out " + dir.File("x.json"));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--field-iterations"), std::string::npos) << bad.output;
  EXPECT_FALSE(FileExists(dir.File("x.json")));
}

// The GPU run's path, here on the CPU at toy sizes: reg make-data --render-only renders blocks and
// trains nothing; bench/gpu_dreg.cc trains them (TrainBlockPairs), pairs them under the true
// transforms, trains the paper network in two resumed slices and scores the test pairs.
TEST(RegCli, RenderOnlyBlocksTrainAndPairElsewhere) {
  ScopedTempDir dir;
  // Seeds whose 2-block pairs overlap well (0.52, 0.78) at these toy sizes; 7000 and 7002 were near
  // 0.05. No val/: it is optional, and each split costs two blocks' training.
  const char* splits[] = {"train", "test"};
  const int seeds[] = {7004, 7005};
  for (int k = 0; k < 2; ++k) {
    const std::string out = dir.File(std::string("data/") + splits[k]);
    const CommandResult made = RunNerfreg("reg make-data --procedural 1 --procedural-seed " + std::to_string(seeds[k]) +
                                          " --mesh-pairs 0 --nerf-objects 1 --render-only --image-size 24 --quiet "
                                          "--out " +
                                          out);
    ASSERT_EQ(made.exit_code, 0) << made.output;
    const Json index = ReadJsonFile(out + "/pairs.json");
    EXPECT_TRUE(index["pairs"].empty());
    EXPECT_TRUE(index["objects"].empty());  // a later run without --render-only trains it
    ASSERT_EQ(index["rendered"].size(), 1u);
    const std::string object = index["rendered"].begin().key();
    EXPECT_TRUE(FileExists(out + "/" + object + "/nerf/data/block_1/transforms.json"));
    EXPECT_FALSE(FileExists(out + "/" + object + "/nerf/block_0.grid"));
  }
  const CommandResult run =
      RunShell(std::string(NERFREG_GPU_DREG_BINARY) + " --data " + dir.File("data") +
               " --device cpu --nerf-iters 100 --nerf-samples 4096 --grid-resolution 32 --dreg-iters 2 "
               "--dreg-slice 1 --dreg-seconds 1000 --work " +
               dir.File("work") + " --out " + dir.File("gpu_dreg.json") + " 2>&1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const Json j = ReadJsonFile(dir.File("gpu_dreg.json"));
  EXPECT_EQ(j["dreg_train"]["iterations"].get<int>(), 2) << j.dump();
  EXPECT_TRUE(FileExists(dir.File("work/dreg_paper.pt")));
  // Every split's blocks were trained and paired under the renders' true transforms.
  for (const char* split : splits) {
    const std::string folder = dir.File(std::string("data/") + split);
    const auto pairs = ReadPairs(folder + "/pairs_gpu.json");
    ASSERT_EQ(pairs.size(), 1u) << split;
    EXPECT_GE(pairs[0].overlap, 0.05);
    EXPECT_TRUE(FileExists(pairs[0].source) && FileExists(pairs[0].target));
    const GroundTruthFile truth(folder + "/" + pairs[0].object + "/nerf/data/ground_truth.json");
    EXPECT_LT((pairs[0].target_from_source - truth.TargetFromSource(0, 1).ToMatrix()).norm(), 1e-9);
  }
  EXPECT_EQ(j["test"]["trained"]["pairs"].get<int>(), 1);
  EXPECT_EQ(j["test"]["untrained"]["pairs"].get<int>(), 1);
  EXPECT_EQ(j["train"]["trained"]["pairs"].get<int>(), 1);  // the pairs it trained on, scored too
}

}  // namespace
}  // namespace nerfreg
