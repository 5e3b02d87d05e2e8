#include "nerfreg/util/training_log.h"

#include <sstream>

#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

int RewindTrainingLog(const std::string& path, std::int64_t step) {
  if (!FileExists(path)) return 0;
  std::istringstream in(ReadFileToString(path));
  std::string kept, line;
  int dropped = 0;
  while (std::getline(in, line)) {
    const Json j = Json::parse(line, nullptr, /*allow_exceptions=*/false);
    const bool keep =
        j.is_object() && (!j.contains("step") || (j["step"].is_number() && j["step"].get<double>() <= step));
    if (keep) {
      kept += line + "\n";
    } else if (!line.empty()) {
      ++dropped;
    }
  }
  if (dropped > 0) WriteFileAtomic(path, kept);
  return dropped;
}

}  // namespace nerfreg
