// reg make-data: the registration network's training and evaluation pairs (renders with the
// render layer, trains blocks, synthesises pairs).
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/reg_data/training_data.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

using namespace nerfreg;

int RunRegMakeData(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(
      app,
      "Make registration training / evaluation pairs, one object at a time (resumable: objects already in "
      "OUT/pairs.json are skipped). Each object gives --mesh-pairs pairs synthesised from the mesh with "
      "NeRF-like artefacts (cheap) and, for the first --nerf-objects objects, pairs of real NeRF blocks "
      "(rendered, trained, grids extracted; ~3 min a block on 2 cores). Meshes reserved for independent "
      "evaluation (docs/data.md) must not be used.",
      "nerfreg reg make-data --meshes /usr/share/assimp/models/OBJ/spider.obj --procedural 20 --out data/reg");
  std::string out;
  MakeDataOptions o;
  o.nerf = NerfTrainOptions::Preset("fast");
  o.nerf.iterations = 500;
  std::string preset = "fast";
  int nerf_iters = 500;
  app.add_option("--out", out, "Output folder (pairs.json + grids)")->required();
  app.add_option("--meshes", o.meshes,
                 "Mesh files, or sh3f:train / sh3f:val / sh3f:test (Sweet Home 3D furniture of that split of "
                 "--sh3f-split; their pairs get that split)")
      ->expected(0, 10000);
  app.add_option("--sh3f-split", o.sh3f_split_file, "Furniture split file (default models/sh3f_split.json)");
  app.add_option("--sh3f-dir", o.sh3f_dir,
                 std::string("Folder of the .sh3f archives (default ") + kSh3fFurnitureDir + ")");
  app.add_option("--sh3f-limit", o.sh3f_limit,
                 "At most N models of each sh3f: split, in the file's order (default 0: all)");
  app.add_option("--procedural", o.procedural, "Number of procedural objects");
  app.add_option("--procedural-seed", o.procedural_seed, "Seed of the first procedural object (default 1000)");
  app.add_option("--mesh-pairs", o.mesh_pairs, "Synthesised pairs per object (default 4)");
  app.add_option("--nerf-objects", o.nerf_objects, "The first N objects also get real trained NeRF blocks (default 0)");
  app.add_flag("--render-only", o.render_only,
               "Render the --nerf-objects' blocks and stop: no training, no pairs of them (for training elsewhere, "
               "e.g. on a GPU: bench/gpu_dreg.cc)");
  app.add_option("--blocks", o.blocks, "Blocks per object: 2 (the paper) or 4 (adjacent pairs: low overlap)");
  app.add_option("--split", o.split, "Split written for every pair of files and procedural objects: train or val")
      ->check(CLI::IsMember({"train", "val"}));
  app.add_option("--image-size", o.image_size, "NeRF render size, pixels (default 100)");
  app.add_option("--nerf-preset", preset, "Block training preset (default fast)");
  app.add_option("--nerf-iters", nerf_iters, "Block training iterations (default 500)");
  app.add_option("--seed", o.seed, "Random seed");
  app.add_option("--scale-augment", o.synthetic.max_relative_scale,
                 "Synthesised pairs: a relative scale between the blocks drawn log-uniformly in [1/X, X], then each "
                 "block normalised by its own seen extent as reg register --scale free does (e.g. 2; default 0: off, "
                 "both blocks in the mesh's unit)");
  AddGridOptions(app, &o.grid);
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  o.nerf = NerfTrainOptions::Preset(preset);
  o.nerf.iterations = nerf_iters;
  o.nerf.eval_every = 0;
  o.synthetic.resolution = o.grid.resolution;
  o.synthetic.side = o.grid.side;
  const MakeDataSummary s = MakeRegistrationData(o, out);
  std::printf("%s\n", Json({{"pairs_json", JoinPaths(out, "pairs.json")},
                            {"objects_done", s.objects_done},
                            {"objects_skipped", s.objects_skipped},
                            {"pairs", s.pairs},
                            {"seconds", s.seconds}})
                          .dump()
                          .c_str());
  return 0;
}

int RunRegSh3fSplit(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Split the Sweet Home 3D furniture models into train / val / test by a salted hash of each mesh "
                  "(copies of one OBJ together), loading every model: those that fail to load or are degenerate "
                  "(too few or too many triangles, flat) are excluded with the reason. Writes the split file "
                  "reg make-data --meshes sh3f:train reads.",
                  "nerfreg reg sh3f-split --out models/sh3f_split.json");
  std::string out;
  Sh3fSplitOptions o;
  app.add_option("--out", out, "Split file to write (JSON)")->required();
  app.add_option("--sh3f-dir", o.furniture_dir,
                 std::string("Folder of the .sh3f archives (default ") + kSh3fFurnitureDir + ")");
  app.add_option("--train-percent", o.train_percent, "Train share of the hash range (default 80)");
  app.add_option("--val-percent", o.val_percent, "Validation share (default 10; the rest is test)");
  app.add_option("--salt", o.salt, "Hash salt (default nerfreg-sh3f-split-v1)");
  app.add_option("--min-thickness", o.min_thickness, "Smallest / largest box side below this is flat (default 0.02)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force);
  const Json split = MakeSh3fSplit(o);
  WriteJsonFile(out, split);
  std::printf("%s\n", Json({{"split_file", out}, {"counts", split["counts"]}}).dump().c_str());
  return 0;
}
