#include "nerfreg/render/mesh.h"

#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>
#include <open3d/utility/Logging.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "nerfreg/render/ply_check.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {
namespace {

// Open3D's OFF reader hands every face to its ear clipping without checking it: a face of fewer
// than 3 vertices or an index beyond the vertex count reads out of bounds (a crash found by
// fuzz/mesh_fuzz.cc). The file is walked here the way Open3D reads it (lines stripped, blank and
// '#' lines skipped; the keyword; "vertices faces edges"; one vertex, then one face per line) and
// every face is checked. Files Open3D refuses by itself (another keyword, short lines) pass.
void CheckOff(const std::string& path, std::int64_t size, std::istream* in) {
  auto next_line = [&]() -> std::string {
    for (std::string line; std::getline(*in, line);) {
      const size_t a = line.find_first_not_of(" \t\r\n\v\f");
      if (a == std::string::npos || line[a] == '#') continue;
      const size_t b = line.find_last_not_of(" \t\r\n\v\f");
      return line.substr(a, b - a + 1);
    }
    return "";
  };
  const std::string header = next_line();
  if (header != "OFF" && header != "COFF" && header != "NOFF" && header != "CNOFF") return;
  std::istringstream info(next_line());
  std::int64_t num_vertices, num_faces;
  if (!(info >> num_vertices >> num_faces)) return;
  // An ASCII vertex takes >= 6 bytes ("0 0 0\n"), a face >= 8 ("3 0 0 0\n").
  if (num_vertices < 0 || num_vertices > size / 6) {
    ThrowInputError(
        path, "vertex count",
        "a count the file's " + std::to_string(size) + " bytes can hold (got " + std::to_string(num_vertices) + ")");
  }
  if (num_faces < 0 || num_faces > size / 8) {
    ThrowInputError(
        path, "face count",
        "a count the file's " + std::to_string(size) + " bytes can hold (got " + std::to_string(num_faces) + ")");
  }
  for (std::int64_t v = 0; v < num_vertices; ++v) next_line();
  for (std::int64_t f = 0; f < num_faces; ++f) {
    std::istringstream face(next_line());
    std::int64_t n;
    // Open3D does not check this read either: a missing count left it unset.
    if (!(face >> n))
      ThrowInputError(path, "face " + std::to_string(f), "a line \"N i1 ... iN\" (missing or unreadable)");
    if (n < 3)
      ThrowInputError(path, "face " + std::to_string(f),
                      "a polygon of at least 3 vertices (got " + std::to_string(n) + ")");
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t index;
      if (!(face >> index)) return;
      if (index < 0 || index >= num_vertices) {
        ThrowInputError(path, "face " + std::to_string(f),
                        "vertex indices below the vertex count " + std::to_string(num_vertices) + " (got " +
                            std::to_string(index) + ")");
      }
    }
  }
}

// OBJ through Open3D + Assimp 5.2.5. Open3D takes every face Assimp returns as a triangle, so a
// face Assimp reads as fewer than 3 corners (a line or point) is read out of bounds (SEGV; found
// by fuzz/mesh_fuzz.cc: "f 1/1/3/1 4/4/1"). Assimp's face parser runs past the end of its line
// buffer after an unsupported token: a 4th index in a corner, or "v/vt/vn" before any "vt" line
// once a "vn" came (it then takes vt's slot for vn, and vn's for a 4th; a fuzzer find that crashed
// only after other inputs had filled that buffer). And a vertex index out of range makes Assimp
// throw after allocating its mesh, which it leaks (LeakSanitizer). So the file is read as Assimp
// reads it, and faces are checked against the vertices Assimp keeps:
//   - lines end at \n, \r, \f or NUL (Assimp's IsLineEnd); '\\' at a line's end (a continuation,
//     which Assimp joins up to the next \n whatever ended the line) is refused;
//   - a line's first byte picks its kind: "v " / "v\t" is a vertex, kept by Assimp when it has 3,
//     4 or 6 numbers (counted here only when every word is a number starting with a digit or a
//     sign, so never more than Assimp keeps; w = 0 in 4 is refused: Assimp throws on it), "vt" a
//     texture coordinate, "vn" a normal, 'f' a face (its corners follow the first word: "f1/1 2 3"
//     has two), 'l' / 'p' lines and points, refused as not surfaces;
//   - a corner is "v", "v/vt", "v//vn" or "v/vt/vn", each index written as Assimp's atoi steps
//     over it (-?[1-9][0-9]*: no '+', no leading zero) and within the count: all of the file's for
//     a positive index, those so far for a negative one (Assimp resolves it where it stands);
//   - no texture index before the first "vt" line; at least 3 corners.
void CheckObj(const std::string& path, std::istream* in) {
  std::vector<std::string> lines;
  {
    std::string line;
    for (int c; (c = in->get()) != std::char_traits<char>::eof();) {
      if (c != '\n' && c != '\r' && c != '\f' && c != '\0') {
        line.push_back(static_cast<char>(c));
        continue;
      }
      if (!line.empty() && line.back() == '\\') {
        ThrowInputError(path, "line " + std::to_string(lines.size() + 1),
                        "no line continuation ('\\' at the end of a line)");
      }
      lines.push_back(line);
      line.clear();
    }
    lines.push_back(line);
  }
  // Assimp skips a UTF-8 byte-order mark before the first line.
  if (lines[0].compare(0, 3, "\xEF\xBB\xBF") == 0) lines[0].erase(0, 3);

  enum Kind { kOther, kVertex, kTexCoord, kNormal, kFace, kNotSurface };
  const auto kind_of = [&](size_t i) {
    const std::string& line = lines[i];
    if (line.empty()) return kOther;
    if (line[0] == 'f') return kFace;
    if (line[0] == 'l' || line[0] == 'p') return kNotSurface;
    if (line.size() < 2 || line[0] != 'v') return kOther;
    if (line[1] == 't') return kTexCoord;
    if (line[1] == 'n') return kNormal;
    if (line[1] != ' ' && line[1] != '\t') return kOther;
    std::istringstream ls(line.substr(2));
    std::vector<double> values;
    for (std::string word; ls >> word;) {
      char* end = nullptr;
      const double v = std::strtod(word.c_str(), &end);
      if (!(std::isdigit(static_cast<unsigned char>(word[0])) || word[0] == '-' || word[0] == '+') ||
          end != word.c_str() + word.size()) {
        return kOther;
      }
      values.push_back(v);
    }
    if (values.size() == 4 && values[3] == 0) {
      ThrowInputError(path, "line " + std::to_string(i + 1), "a homogeneous vertex with w != 0");
    }
    return values.size() == 3 || values.size() == 4 || values.size() == 6 ? kVertex : kOther;
  };
  std::vector<Kind> kinds(lines.size());
  std::int64_t total[3] = {0, 0, 0};  // vertices, texture coordinates, normals
  for (size_t i = 0; i < lines.size(); ++i) {
    kinds[i] = kind_of(i);
    if (kinds[i] == kVertex) ++total[0];
    if (kinds[i] == kTexCoord) ++total[1];
    if (kinds[i] == kNormal) ++total[2];
  }
  // A canonical non-zero index: positive ones within the file's count, negative ones within the
  // count so far.
  const auto index_ok = [](const std::string& text, std::int64_t total, std::int64_t so_far) {
    const size_t digits = text[0] == '-' ? 1 : 0;
    if (text.size() <= digits || text.size() > digits + 12 || text[digits] == '0' ||
        text.find_first_not_of("0123456789", digits) != std::string::npos) {
      return false;
    }
    const long long v = std::stoll(text);
    return v <= total && -v <= so_far;
  };
  std::int64_t so_far[3] = {0, 0, 0};
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (kinds[i] == kVertex) ++so_far[0];
    if (kinds[i] == kTexCoord) ++so_far[1];
    if (kinds[i] == kNormal) ++so_far[2];
    const std::string field = "\"" + line.substr(0, 40) + "\"";
    if (kinds[i] == kNotSurface) {
      ThrowInputError(path, field, "faces (\"f\"); line and point statements are not surfaces");
    }
    if (kinds[i] != kFace) continue;
    // Corners follow the first word, whatever it is; only digits, '-', '/', spaces and tabs.
    const size_t first_end = line.find_first_of(" \t");
    const std::string corners_text = first_end == std::string::npos ? "" : line.substr(first_end);
    if (corners_text.find_first_not_of("0123456789-/ \t") != std::string::npos) {
      ThrowInputError(path, field, "face corners of digits, '-' and '/' separated by spaces");
    }
    std::istringstream ls(corners_text);
    std::string corner;
    int corners = 0;
    while (ls >> corner) {
      std::vector<std::string> parts;
      size_t start = 0;
      for (size_t slash; (slash = corner.find('/', start)) != std::string::npos; start = slash + 1)
        parts.push_back(corner.substr(start, slash - start));
      parts.push_back(corner.substr(start));
      bool ok = parts.size() <= 3 && !parts[0].empty();
      for (size_t k = 0; ok && k < parts.size(); ++k) {
        ok = parts[k].empty() ? k > 0 : index_ok(parts[k], total[k], so_far[k]);
      }
      if (!ok) {
        ThrowInputError(path, field,
                        "face corners v, v/vt, v//vn or v/vt/vn with indices within the file's " +
                            std::to_string(total[0]) + " vertices (" + std::to_string(so_far[0]) +
                            " so far for a negative index)");
      }
      if (parts.size() >= 2 && !parts[1].empty() && so_far[1] == 0) {
        ThrowInputError(path, field, "texture coordinate indices after the first \"vt\" line");
      }
      ++corners;
    }
    if (corners < 3) ThrowInputError(path, field, "a face of at least 3 corners");
  }
}

// Open3D's OFF, PLY and STL readers size their arrays from the counts in the header before
// reading any element, and its OFF and PLY readers triangulate faces unchecked, so a corrupt or
// hostile file asked for tens of GB or read out of bounds (found by fuzz/mesh_fuzz.cc). Those
// formats are checked here first; every element takes at least one byte of the file, so a count
// above the file's size is refused. OBJ faces are checked too (CheckObj); glTF and GLB (Open3D +
// Assimp) are not.
void CheckBeforeOpen3d(const std::string& path, const std::string& ext) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError(path, "", "a readable mesh file");
  in.seekg(0, std::ios::end);
  const std::int64_t size = in.tellg();
  in.seekg(0);

  if (ext == ".stl") {
    // Binary STL: an 80-byte header, a uint32 triangle count, 50 bytes per triangle. ASCII STL
    // ("solid ...") has no count; Open3D reads it as it goes.
    char header[84];
    if (!in.read(header, 84)) {
      if (size >= 5 && std::string(header, 5) == "solid") return;
      ThrowInputError(path, "header", "a binary STL (80-byte header and a triangle count)");
    }
    std::uint32_t n;
    std::memcpy(&n, header + 80, 4);
    if (84 + 50 * std::int64_t(n) > size && std::string(header, 5) != "solid") {
      ThrowInputError(
          path, "triangle count",
          std::to_string(n) + " triangles of 50 bytes in a binary STL of " + std::to_string(size) + " bytes");
    }
  } else if (ext == ".off") {
    CheckOff(path, size, &in);
  } else if (ext == ".ply") {
    CheckPlyForOpen3d(path);
  } else if (ext == ".obj") {
    CheckObj(path, &in);
  }
}

}  // namespace

void TriangleMesh::Bounds(Eigen::Vector3f* mn, Eigen::Vector3f* mx) const {
  if (vertices.empty()) {
    *mn = *mx = Eigen::Vector3f::Zero();
    return;
  }
  *mn = *mx = vertices[0];
  for (const auto& v : vertices) {
    *mn = mn->cwiseMin(v);
    *mx = mx->cwiseMax(v);
  }
}

void TriangleMesh::Append(const TriangleMesh& o) {
  const bool colors = (vertices.empty() || HasColors()) && o.HasColors();
  const bool materials_kept = (triangles.empty() || HasMaterials()) && o.HasMaterials();
  const bool uvs = materials_kept && (triangles.empty() || triangle_uvs.size() == 3 * triangles.size()) &&
                   o.triangle_uvs.size() == 3 * o.triangles.size();
  const int offset = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), o.vertices.begin(), o.vertices.end());
  for (const auto& t : o.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  if (colors)
    vertex_colors.insert(vertex_colors.end(), o.vertex_colors.begin(), o.vertex_colors.end());
  else
    vertex_colors.clear();
  if (materials_kept) {
    const int material_offset = static_cast<int>(materials.size());
    materials.insert(materials.end(), o.materials.begin(), o.materials.end());
    for (int m : o.triangle_materials) triangle_materials.push_back(m + material_offset);
  } else {
    materials.clear();
    triangle_materials.clear();
  }
  if (uvs)
    triangle_uvs.insert(triangle_uvs.end(), o.triangle_uvs.begin(), o.triangle_uvs.end());
  else
    triangle_uvs.clear();
  texture = Image();  // one texture per mesh: a union drops the single texture
}

void TriangleMesh::Check(const std::string& source) const {
  if (vertices.empty() || triangles.empty()) ThrowInputError(source, "triangles", "a mesh with at least one triangle");
  const int n = static_cast<int>(vertices.size());
  for (const auto& t : triangles) {
    if ((t.array() < 0).any() || (t.array() >= n).any())
      ThrowInputError(source, "triangles", "vertex indices in range");
  }
  for (const auto& v : vertices) {
    if (!v.allFinite()) ThrowInputError(source, "vertices", "finite coordinates");
  }
  if (!triangle_materials.empty()) {
    if (triangle_materials.size() != triangles.size())
      ThrowInputError(source, "materials", "one material per triangle");
    for (int m : triangle_materials) {
      if (m < 0 || m >= static_cast<int>(materials.size()))
        ThrowInputError(source, "materials", "material indices in range");
    }
  }
  // Coinciding vertices (or all triangles on a line) render nothing: every image would be empty.
  Eigen::Vector3f mn, mx;
  Bounds(&mn, &mx);
  const float side = (mx - mn).maxCoeff();
  if (!(side > 0) || !std::isfinite(side)) {
    ThrowInputError(source, "vertices", "vertices spanning a finite, non-zero extent (they all coincide)");
  }
  double largest_area = 0;
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = vertices[t[0]].cast<double>(), b = vertices[t[1]].cast<double>(),
                          c = vertices[t[2]].cast<double>();
    largest_area = std::max(largest_area, 0.5 * (b - a).cross(c - a).norm());
  }
  if (!(largest_area > 1e-12 * double(side) * double(side))) {
    ThrowInputError(source, "triangles", "at least one triangle of non-zero area (every triangle is degenerate)");
  }
}

TriangleMesh LoadMesh(const std::string& path) {
  if (!FileExists(path)) ThrowInputError(path, "", "an existing mesh file");
  const std::string ext = LowerExtension(path);
  if (ext != ".off" && ext != ".ply" && ext != ".obj" && ext != ".stl" && ext != ".gltf" && ext != ".glb") {
    ThrowInputError(path, "extension", ".off, .ply, .obj, .stl, .gltf or .glb");
  }
  CheckBeforeOpen3d(path, ext);
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  open3d::geometry::TriangleMesh o3d;
  open3d::io::ReadTriangleMeshOptions options;
  if (!open3d::io::ReadTriangleMesh(path, o3d, options) || o3d.triangles_.empty()) {
    ThrowInputError(path, "", "a readable triangle mesh with at least one triangle");
  }
  TriangleMesh mesh;
  for (const auto& v : o3d.vertices_) mesh.vertices.push_back(v.cast<float>());
  for (const auto& t : o3d.triangles_) mesh.triangles.push_back(t);
  if (o3d.HasVertexColors()) {
    for (const auto& c : o3d.vertex_colors_) mesh.vertex_colors.push_back(c.cast<float>().cwiseMax(0.f).cwiseMin(1.f));
  }
  if (o3d.HasTriangleUvs() && !o3d.textures_.empty() && !o3d.textures_[0].IsEmpty()) {
    const auto& tex = o3d.textures_[0];
    if (tex.bytes_per_channel_ == 1 &&
        (tex.num_of_channels_ == 3 || tex.num_of_channels_ == 4 || tex.num_of_channels_ == 1)) {
      mesh.texture = Image(tex.width_, tex.height_, 3);
      for (int y = 0; y < tex.height_; ++y)
        for (int x = 0; x < tex.width_; ++x)
          for (int c = 0; c < 3; ++c) {
            const int src_c = tex.num_of_channels_ == 1 ? 0 : c;
            mesh.texture.at(x, y, c) = *tex.PointerAt<uint8_t>(x, y, src_c) / 255.f;
          }
      for (const auto& uv : o3d.triangle_uvs_) mesh.triangle_uvs.push_back(uv.cast<float>());
    }
  }
  mesh.Check(path);
  return mesh;
}

float NormalizeMesh(TriangleMesh* mesh, float largest_side) {
  Eigen::Vector3f mn, mx;
  mesh->Bounds(&mn, &mx);
  const Eigen::Vector3f centre = 0.5f * (mn + mx);
  const float side = (mx - mn).maxCoeff();
  const float s = side > 0 ? largest_side / side : 1.f;
  for (auto& v : mesh->vertices) v = (v - centre) * s;
  return s;
}

}  // namespace nerfreg
