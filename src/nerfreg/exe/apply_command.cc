// nerfreg reg apply T.json INPUT --out OUTPUT [--inverse]
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/pipeline/apply_transform.h"
#include "nerfreg/util/logging.h"

using namespace nerfreg;

int RunRegApply(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Apply a registration's Sim(3) (T.json's target_from_source; --inverse: its inverse) to a file: a 3D "
                  "Gaussian splat PLY (centres, rotations, scales, SH degrees 1-3), a point-cloud or mesh PLY, a "
                  "transforms.json (NeRF-synthetic, instant-ngp, nerfstudio with its dataparser_transforms.json), a "
                  "COLMAP model folder, an LLFF poses_bounds.npy, or a NeRF block checkpoint (its frame is changed, "
                  "the field is not resampled). The input's kind is detected; the output has the same kind.",
                  "nerfreg reg apply runs/t.json data/b/splats.ply --out runs/b_in_a.ply");
  ApplyTransformOptions options;
  app.add_option("transform", options.transform, "T.json written by reg register")->required();
  app.add_option("input", options.input, "File (or COLMAP / dataset folder) to move")->required();
  app.add_option("--out", options.output, "Output: a file of the input's kind (a folder for a COLMAP model)")
      ->required();
  app.add_flag("--inverse", options.inverse,
               "Apply source_from_target (moves target-frame files into the source frame)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  options.force = common.force;
  const ApplyTransformResult r = ApplyTransformFile(options);
  LOG_INFO("moved {} {} item(s) (scale {:.6g}) into {}", r.items, ApplyInputKindName(r.kind), r.applied.scale,
           options.output);
  return 0;
}
