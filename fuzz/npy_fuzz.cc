// Fuzzes the .npy parser (header, dtype, shape and size checks).
#include "fuzz_util.h"
#include "nerfreg/data/npy.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    nerfreg::ParseNpy(std::string(reinterpret_cast<const char*>(data), size), "fuzz.npy");
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
