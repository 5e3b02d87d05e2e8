// Fuzzes the COLMAP binary reader: the first byte picks which file gets the input (the others
// hold a valid one-camera, one-image model), so each record parser is reached.
#include <filesystem>
#include <fstream>

#include "fuzz_util.h"
#include "nerfreg/data/colmap.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = "/dev/shm/nerfreg_fuzz_colmap_bin_" + std::to_string(::getpid());
  static bool init = false;
  if (!init) {
    nerfreg::ColmapModel m;
    nerfreg::Camera cam = nerfreg::Camera::Pinhole(8, 6, 5, 5, 4, 3);
    m.cameras[1] = nerfreg::ColmapCamera::FromCamera(1, cam);
    nerfreg::ColmapImage im;
    im.image_id = 1;
    im.camera_id = 1;
    im.name = "a.png";
    m.images[1] = im;
    nerfreg::WriteColmapBinary(m, dir + "/valid");
    init = true;
  }
  if (size == 0) return 0;
  const char* names[3] = {"cameras.bin", "images.bin", "points3D.bin"};
  for (const char* n : names) {
    std::filesystem::copy_file(dir + "/valid/" + n, dir + "/" + n, std::filesystem::copy_options::overwrite_existing);
  }
  std::ofstream(dir + "/" + names[data[0] % 3], std::ios::binary)
      .write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  try {
    nerfreg::ReadColmapBinary(dir);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
