// Fuzzes the mesh-loading entry point (render/mesh.h LoadMesh: our checks, then Open3D's readers)
// for the formats LoadMesh guards: OFF, PLY and STL. Byte 0 picks the file's extension, which picks
// the reader; the rest is the file. What this fuzzer found, and LoadMesh now checks before Open3D
// sees the file: element counts that ask for multi-GB arrays (OFF, PLY, binary STL), and faces of
// fewer than 3 vertices or with indices out of range, which Open3D's ear clipping reads out of
// bounds with (OFF, PLY).
//
// Not fuzzed: OBJ, glTF and GLB. Open3D 0.16 reads them through Assimp and then takes every face
// as a triangle: an OBJ face that Assimp reads as a line or a point ("f 1/1/3/1 4/4/1" found here,
// also "l" and "p" statements) is read out of bounds inside ReadTriangleMeshUsingASSIMP (SEGV).
// Guarding that means re-parsing OBJ and glTF the way Assimp does (materials and buffers
// included); until then those formats are only as safe as Open3D + Assimp are, and meshes from
// untrusted sources should be converted to PLY or OFF first.
#include <string>

#include "fuzz_util.h"
#include "nerfreg/render/mesh.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const char* const kExtensions[] = {".off", ".ply", ".stl"};
  if (size < 1) return 0;
  const char* ext = kExtensions[data[0] % (sizeof(kExtensions) / sizeof(kExtensions[0]))];
  const std::string path = nerfreg::WriteFuzzInput(data + 1, size - 1, ext);
  try {
    nerfreg::LoadMesh(path);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
