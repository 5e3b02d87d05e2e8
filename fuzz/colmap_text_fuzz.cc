// Fuzzes the COLMAP text reader: the input is split at the first two '\x00' bytes into
// cameras.txt, images.txt and points3D.txt.
#include <filesystem>
#include <fstream>

#include "fuzz_util.h"
#include "nerfreg/data/colmap.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = "/dev/shm/nerfreg_fuzz_colmap_txt_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string in(reinterpret_cast<const char*>(data), size);
  const size_t a = in.find('\0'), b = a == std::string::npos ? a : in.find('\0', a + 1);
  const std::string parts[3] = {
      in.substr(0, a),
      a == std::string::npos ? "" : in.substr(a + 1, b == std::string::npos ? std::string::npos : b - a - 1),
      b == std::string::npos ? "" : in.substr(b + 1)};
  const char* names[3] = {"/cameras.txt", "/images.txt", "/points3D.txt"};
  for (int k = 0; k < 3; ++k) std::ofstream(dir + names[k], std::ios::binary) << parts[k];
  try {
    nerfreg::ReadColmapText(dir);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
