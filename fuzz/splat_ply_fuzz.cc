// Fuzzes the 3D Gaussian splat PLY reader (header, counts against the file size, values), and
// the transform `reg apply` runs on what it accepts (SH rotation of every degree).
#include "fuzz_util.h"
#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const nerfreg::Splats s =
        nerfreg::ParseSplatPly(std::string(reinterpret_cast<const char*>(data), size), "fuzz.ply");
    const nerfreg::Sim3d t(2.0, Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5), Eigen::Vector3d(1, 2, 3));
    nerfreg::ParseSplatPly(nerfreg::SerializeSplatPly(nerfreg::TransformSplats(s, t)), "moved.ply");
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
