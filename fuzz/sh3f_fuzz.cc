// Fuzzes the Sweet Home 3D furniture reader (render/sh3f.h): our zip reader (util/zip_reader.h),
// the catalog (Java properties), and our OBJ + MTL parser (render/obj_reader.h) with textures
// decoded from the archive. Byte 0 picks the input: even, the rest is a .sh3f archive (every model
// of its catalog is loaded); odd, the rest is an OBJ, then "\n====\n" and the one file served for
// every path it names (its MTL, or a texture the MTL names).
#include <string>

#include "fuzz_util.h"
#include "nerfreg/render/sh3f.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  nerfreg::ObjReadOptions options;
  options.max_texture_pixels = 1 << 16;
  try {
    if (data[0] % 2 == 0) {
      nerfreg::ZipLimits limits;
      limits.max_entry_bytes = 1 << 20;
      limits.max_total_bytes = 1 << 22;
      const nerfreg::ZipReader zip = nerfreg::ZipReader::FromBytes(bytes, "fuzz.sh3f", limits);
      for (const auto& model : nerfreg::ReadSh3fCatalog(zip)) {
        try {
          nerfreg::LoadSh3fModel(zip, model, options);
        } catch (const nerfreg::InputError&) {
        }
      }
    } else {
      const size_t split = bytes.find("\n====\n");
      const std::string obj = bytes.substr(0, split);
      const std::string file = split == std::string::npos ? "" : bytes.substr(split + 6);
      const nerfreg::ObjFileSource files = [&](const std::string&, std::string* out) {
        *out = file;
        return split != std::string::npos;
      };
      nerfreg::ReadObjWithMaterials(obj, "fuzz.obj", files, options);
    }
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
