#pragma once
// Wavefront OBJ with its MTL materials and textures, read from memory by our own parser (Sweet Home
// 3D furniture comes as OBJ + MTL + PNG / JPEG inside a zip: render/sh3f.h). Unlike LoadMesh
// (Open3D: one texture per mesh, files on disk), every "usemtl" material is kept per triangle
// (TriangleMesh::materials): a texture (map_Kd) or a flat colour (Kd).
//
// Read: v (x y z; extra numbers ignored), vt (u [v]), f (v, v/vt, v//vn, v/vt/vn; negative indices
// relative; polygons fanned into triangles), usemtl, mtllib; MTL newmtl, Kd, map_Kd (options such
// as "-s 1 1 1" skipped; a path with spaces kept whole). Ignored: vn (the renderer shades with the
// geometric normal), g, o, s, l, p, other MTL statements (transparency included: every surface is
// opaque). Vertices no face uses are dropped.
//
// Bad input never crashes and is named: text that is not an OBJ at all, or no face left, throws
// InputError(name: ...); a broken line (a face with fewer than 3 corners or an index out of range,
// a vertex or colour that is not numbers), an unknown material, a missing or undecodable MTL or
// texture is a warning in ObjReadReport and the rest is read (a face skipped, a flat colour).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "nerfreg/render/mesh.h"

namespace nerfreg {

// The files next to the OBJ: `path` is relative to the OBJ's folder as written in the OBJ or MTL
// (it may hold "..", '\\' or be absolute); the source resolves it (or refuses it) and returns
// false when there is no such file.
using ObjFileSource = std::function<bool(const std::string& path, std::string* bytes)>;

struct ObjReadOptions {
  // Textures are box-filtered down by an integer factor until their larger side is at most this
  // (renders are ~100 pixels wide; a float RGB texture takes 12 bytes a pixel).
  int max_texture_side = 1024;
  // Textures of more pixels than this are not decoded (a warning; the material's flat colour).
  std::int64_t max_texture_pixels = std::int64_t(1) << 26;
  int max_warnings = 20;  // warnings kept in the report (the rest only counted)
  void Check() const;     // throws std::invalid_argument
};

struct ObjReadReport {
  std::vector<std::string> warnings;  // the first max_warnings, each "NAME: line N: ..." or about a file
  int warning_count = 0;              // all of them
  int skipped_faces = 0;              // faces left out (fewer than 3 corners, bad indices)
  int textures = 0;                   // textures decoded
  int missing_textures = 0;           // map_Kd files missing or undecodable (flat colour instead)
};

// Reads `obj` (the OBJ's bytes; `name` stands for it in messages). `report` may be null.
TriangleMesh ReadObjWithMaterials(const std::string& obj, const std::string& name, const ObjFileSource& files,
                                  const ObjReadOptions& options = ObjReadOptions(), ObjReadReport* report = nullptr);

}  // namespace nerfreg
