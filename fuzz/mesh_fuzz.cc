// Fuzzes the mesh-loading entry point (render/mesh.h LoadMesh: our checks, then Open3D's readers)
// for the formats LoadMesh guards: OFF, PLY, STL and OBJ. Byte 0 picks the file's extension, which picks
// the reader; the rest is the file. What this fuzzer found, and LoadMesh now checks before Open3D
// sees the file: element counts that ask for multi-GB arrays (OFF, PLY, binary STL), and faces of
// fewer than 3 vertices or with indices out of range, which Open3D's ear clipping reads out of
// bounds with (OFF, PLY).
//
// PLY: the check must read the file exactly as rply does (render/ply_check.h). A line-based check
// missed a face list declared on its element's line and a NUL ending a face count (rply splits
// words on NULs and reads its header word by word): Open3D then triangulated an empty face (SEGV).
//
// OBJ: Open3D 0.16 reads it through Assimp 5.2.5 and then takes every face as a triangle: a face
// Assimp reads as a line or a point ("f 1/1/3/1 4/4/1" found here, also "l" and "p" statements) was
// read out of bounds inside ReadTriangleMeshUsingASSIMP (SEGV). Assimp's face parser also reads past
// its line buffer after an unsupported token ("v/vt/vn" before any "vt" once a "vn" came; found
// here, heap-dependent: it crashed only after other inputs had run). LoadMesh checks OBJ faces as
// Assimp splits and steps over them (render/mesh.cc CheckObj).
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
