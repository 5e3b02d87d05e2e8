// Fuzzes the mesh-loading entry point (render/mesh.h LoadMesh: our checks, then Open3D's readers)
// for the formats LoadMesh guards: OFF, PLY, STL and OBJ. Byte 0 picks the file's extension, which picks
// the reader; the rest is the file. What this fuzzer found, and LoadMesh now checks before Open3D
// sees the file: element counts that ask for multi-GB arrays (OFF, PLY, binary STL), and faces of
// fewer than 3 vertices or with indices out of range, which Open3D's ear clipping reads out of
// bounds with (OFF, PLY).
//
// OBJ: Open3D 0.16 reads it through Assimp and then takes every face as a triangle: a face Assimp
// reads as a line or a point ("f 1/1/3/1 4/4/1" found here, also "l" and "p" statements) was read
// out of bounds inside ReadTriangleMeshUsingASSIMP (SEGV); LoadMesh now checks OBJ faces first.
// Not fuzzed: glTF and GLB (Assimp's glTF importer, buffers and accessors); they are only as safe
// as Open3D + Assimp are, and meshes from untrusted sources should be converted to PLY or OFF.
#include <string>

#include "fuzz_util.h"
#include "nerfreg/render/mesh.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const char* const kExtensions[] = {".off", ".ply", ".stl", ".obj"};
  if (size < 1) return 0;
  const char* ext = kExtensions[data[0] % (sizeof(kExtensions) / sizeof(kExtensions[0]))];
  const std::string path = nerfreg::WriteFuzzInput(data + 1, size - 1, ext);
  try {
    nerfreg::LoadMesh(path);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
