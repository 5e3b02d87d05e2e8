// Fuzzes JSON reading and the typed field accessors every format parser uses.
#include "fuzz_util.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/json_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = nerfreg::WriteFuzzInput(data, size, ".json");
  try {
    const nerfreg::Json j = nerfreg::ReadJsonFile(path);
    const nerfreg::JsonField root(j, path);
    root.DoubleOr("camera_angle_x", 0.5);
    root.IntOr("w", 0);
    if (root.Has("frames")) {
      const auto frames = root["frames"];
      for (size_t i = 0; i < frames.ArraySize() && i < 8; ++i) {
        frames[i]["transform_matrix"].Matrix(4, 4);
        frames[i].StringOr("file_path", "");
      }
    }
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
