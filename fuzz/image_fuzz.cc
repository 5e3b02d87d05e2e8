// Fuzzes image decoding (PNG, JPEG with its EXIF block, PGM/PPM), including the checks that run before any allocation.
#include "fuzz_util.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/image.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = nerfreg::WriteFuzzInput(data, size, ".png");
  try {
    nerfreg::ReadImage(path);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
