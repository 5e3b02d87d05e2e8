// nerfreg report RUN_DIR --out report.html
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/pipeline/run_report.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"

using namespace nerfreg;

int RunReport(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app,
                  "Write one self-contained HTML page for a run: summary, registration overlays and 3D view, renders "
                  "beside their ground truth, training curves, camera frusta (docs/report.md).",
                  "nerfreg report runs/duck --out runs/duck/report.html");
  std::string run_dir, out;
  ReportOptions options;
  app.add_option("run_dir", run_dir, "Run directory")->required();
  app.add_option("--out", out, "Output HTML file")->required();
  app.add_option("--title", options.title, "Page title (default: the directory name)");
  app.add_option("--three-js", options.three_js,
                 "three.min.js inlined for the 3D views (default: Debian's libjs-three)");
  app.add_option("--max-points", options.max_points_per_block, "3D view: points kept per block (default 20000)");
  app.add_option("--max-views", options.max_views, "Renders shown beside their ground truth per folder (default 8)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force);
  WriteRunReport(run_dir, out, options);
  LOG_INFO("wrote {}", out);
  return 0;
}
