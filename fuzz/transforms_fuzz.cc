// Fuzzes transforms.json reading (NeRF-synthetic / instant-ngp / nerfstudio fields).
#include "fuzz_util.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = nerfreg::WriteFuzzInput(data, size, ".json");
  try {
    nerfreg::ReadTransformsJson(path);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
