// nerfreg report RUN_DIR --out report.html
#include "nerfreg/exe/command.h"
#include "nerfreg/exe/commands.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/report.h"

using namespace nerfreg;

int RunReport(int argc, char** argv) {
  CLI::App app;
  CommonOptions common;
  AddCommonOptions(app, &common);
  DescribeCommand(app, "Write one self-contained HTML page (images, metrics, training curves) for a run.",
                  "nerfreg report runs/duck --out runs/duck/report.html");
  std::string run_dir, out;
  ReportOptions options;
  app.add_option("run_dir", run_dir, "Run directory")->required();
  app.add_option("--out", out, "Output HTML file")->required();
  app.add_option("--title", options.title, "Page title (default: the directory name)");
  if (int rc = ParseCommand(app, argc, argv, common); rc >= 0) return rc;
  CheckCanWriteOutput(out, common.force);
  WriteRunReport(run_dir, out, options);
  LOG_INFO("wrote {}", out);
  return 0;
}
