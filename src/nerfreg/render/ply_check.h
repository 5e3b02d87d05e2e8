// The check a PLY file passes before Open3D 0.16 reads it as a triangle mesh.
//
// Open3D reads PLY through rply and hands every face to its ear clipping unchecked: a face of
// fewer than 3 vertices, or an index beyond the vertex count, reads out of bounds (SEGVs found by
// fuzz/mesh_fuzz.cc), and it sizes its arrays from the header's element counts. So the file is
// read here the way rply reads it (rply.c: a word-based header, words split on " \n\r\t" or a NUL,
// the body's start after "end_header", strtol / strtod for ASCII values) and the faces Open3D
// would triangulate are checked. Where rply itself would fail later, the check may stop early:
// everything before that point has been checked. Where rply's reading is ill-defined (a header
// past its first 8 KB buffer, control bytes in the header, a float list count, an ASCII value
// that ends the file) the file is refused.
#ifndef NERFREG_RENDER_PLY_CHECK_H_
#define NERFREG_RENDER_PLY_CHECK_H_

#include <string>

namespace nerfreg {

// Throws InputError naming `path` and the field (a header keyword, "element NAME", "property
// NAME" or "face I") when Open3D would read the file out of bounds or ask for more memory than the
// file can describe. Files Open3D refuses by itself (no "ply" magic) pass unchanged.
void CheckPlyForOpen3d(const std::string& path);

}  // namespace nerfreg

#endif  // NERFREG_RENDER_PLY_CHECK_H_
