#include "nerfreg/render/mesh.h"

#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>
#include <open3d/utility/Logging.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

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
    ThrowInputError(path, "vertex count", "a count the file's " + std::to_string(size) + " bytes can hold (got " +
                                               std::to_string(num_vertices) + ")");
  }
  if (num_faces < 0 || num_faces > size / 8) {
    ThrowInputError(path, "face count", "a count the file's " + std::to_string(size) + " bytes can hold (got " +
                                             std::to_string(num_faces) + ")");
  }
  for (std::int64_t v = 0; v < num_vertices; ++v) next_line();
  for (std::int64_t f = 0; f < num_faces; ++f) {
    std::istringstream face(next_line());
    std::int64_t n;
    // Open3D does not check this read either: a missing count left it unset.
    if (!(face >> n)) ThrowInputError(path, "face " + std::to_string(f), "a line \"N i1 ... iN\" (missing or unreadable)");
    if (n < 3) ThrowInputError(path, "face " + std::to_string(f), "a polygon of at least 3 vertices (got " + std::to_string(n) + ")");
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t index;
      if (!(face >> index)) return;
      if (index < 0 || index >= num_vertices) {
        ThrowInputError(path, "face " + std::to_string(f),
                        "vertex indices below the vertex count " + std::to_string(num_vertices) + " (got " + std::to_string(index) + ")");
      }
    }
  }
}

// Size in bytes of a PLY scalar type (rply's names), 0 when unknown.
int PlyTypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" || t == "float" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// One PLY value of type `t` as a double; false at the end of the file or on a malformed value.
bool ReadPlyValue(std::istream* in, const std::string& format, const std::string& t, double* v) {
  if (format == "ascii") {
    std::string word;
    if (!(*in >> word)) return false;
    char* end = nullptr;
    *v = std::strtod(word.c_str(), &end);
    return end == word.c_str() + word.size();
  }
  unsigned char b[8];
  const int n = PlyTypeSize(t);
  if (!in->read(reinterpret_cast<char*>(b), n)) return false;
  if (format == "binary_big_endian") std::reverse(b, b + n);  // to the host's little-endian order
  auto as = [&](auto x) {
    std::memcpy(&x, b, sizeof(x));
    return static_cast<double>(x);
  };
  if (t == "char" || t == "int8") *v = as(std::int8_t());
  else if (t == "uchar" || t == "uint8") *v = as(std::uint8_t());
  else if (t == "short" || t == "int16") *v = as(std::int16_t());
  else if (t == "ushort" || t == "uint16") *v = as(std::uint16_t());
  else if (t == "int" || t == "int32") *v = as(std::int32_t());
  else if (t == "uint" || t == "uint32") *v = as(std::uint32_t());
  else if (t == "float" || t == "float32") *v = as(float());
  else *v = as(double());
  return true;
}

// Open3D's PLY reader sizes its arrays from the element counts, and hands every face to its ear
// clipping unchecked: a face of fewer than 3 vertices or an index beyond the vertex count reads
// out of bounds (crashes found by fuzz/mesh_fuzz.cc). The header is parsed and the body walked
// here as rply reads them, and the faces Open3D would read ("face" / "vertex_indices", else
// "vertex_index") are checked. Headers this parser does not understand are refused; bodies that
// end early pass (rply fails on them before the incomplete face reaches the ear clipping).
void CheckPly(const std::string& path, std::int64_t size, std::istream* in) {
  struct Property {
    std::string name, type, count_type;  // count_type: empty for a scalar
  };
  struct Element {
    std::string name;
    std::int64_t count = 0;
    std::vector<Property> properties;
  };
  auto refuse = [&](const std::string& field, const std::string& expected) { ThrowInputError(path, field, expected); };
  std::string line, format;
  if (!std::getline(*in, line) || line.rfind("ply", 0) != 0) return;  // Open3D refuses it itself
  std::vector<Element> elements;
  bool end_header = false;
  while (std::getline(*in, line)) {
    std::istringstream ls(line);
    std::string word;
    if (!(ls >> word) || word == "comment" || word == "obj_info") continue;
    if (word == "end_header") {
      // Where the body starts must be unambiguous: rply and we would disagree on "end_header\t...".
      if (line != "end_header") refuse("end_header", "\"end_header\" alone on its line");
      end_header = true;
      break;
    }
    if (word == "format") {
      ls >> format;
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
        refuse("format", "ascii, binary_little_endian or binary_big_endian");
      }
    } else if (word == "element") {
      Element e;
      if (!(ls >> e.name >> e.count)) refuse("element", "\"element NAME COUNT\" in the PLY header");
      if (e.count < 0 || e.count > size) {
        refuse("element " + e.name, "a count the file's " + std::to_string(size) + " bytes can hold (got " +
                                        std::to_string(e.count) + ")");
      }
      elements.push_back(e);
    } else if (word == "property") {
      Property p;
      std::string type;
      if (elements.empty() || !(ls >> type)) refuse("property", "\"property TYPE NAME\" after an element");
      if (type == "list") ls >> p.count_type >> p.type;
      else p.type = type;
      if (!(ls >> p.name) || PlyTypeSize(p.type) == 0 || (type == "list" && PlyTypeSize(p.count_type) == 0)) {
        refuse("property", "\"property TYPE NAME\" or \"property list TYPE TYPE NAME\" with PLY types");
      }
      elements.back().properties.push_back(p);
    } else {
      refuse("header", "format, element, property, comment or end_header lines (got \"" + word + "\")");
    }
  }
  if (!end_header || format.empty()) return;  // Open3D refuses it itself
  std::int64_t num_vertices = 0;
  for (const Element& e : elements)
    if (e.name == "vertex") num_vertices = e.count;
  for (const Element& e : elements) {
    // The face list Open3D reads: vertex_indices, or vertex_index when there is none.
    int face_list = -1;
    for (size_t k = 0; e.name == "face" && k < e.properties.size(); ++k)
      if (e.properties[k].name == "vertex_indices") face_list = static_cast<int>(k);
    for (size_t k = 0; e.name == "face" && face_list < 0 && k < e.properties.size(); ++k)
      if (e.properties[k].name == "vertex_index") face_list = static_cast<int>(k);
    for (std::int64_t i = 0; i < e.count; ++i) {
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const Property& p = e.properties[k];
        const std::string face = "face " + std::to_string(i);
        double count = 1, v;
        if (!p.count_type.empty() && !ReadPlyValue(in, format, p.count_type, &count)) return;
        if (static_cast<int>(k) == face_list && (p.count_type.empty() || !(count >= 3))) {
          refuse(face, "a polygon of at least 3 vertices");
        }
        if (!(count >= 0 && count <= static_cast<double>(size))) return;  // rply fails on it itself
        for (std::int64_t j = 0; j < static_cast<std::int64_t>(count); ++j) {
          if (!ReadPlyValue(in, format, p.type, &v)) return;
          if (static_cast<int>(k) == face_list && !(v >= 0 && v < num_vertices)) {
            refuse(face, "vertex indices below the vertex count " + std::to_string(num_vertices));
          }
        }
      }
    }
  }
}

// OBJ through Open3D + Assimp: Open3D takes every face Assimp returns as a triangle, and Assimp
// returns a face of fewer than 3 corners as a line or point, which Open3D then reads out of bounds
// (found by fuzz/mesh_fuzz.cc: "f 1/1/3/1 4/4/1"). So every face must have >= 3 corners, each
// "v", "v/vt", "v//vn" or "v/vt/vn" with non-zero indices within the file's counts (negative ones
// count back from the last), and line / point statements ("l", "p"), which are not surfaces, are
// refused.
void CheckObj(const std::string& path, std::istream* in) {
  // Assimp dispatches on a line's first character ("f1/1 2 3" is a face, its corners those after
  // the first word), so this does too; it counts vertices only on "v", "vt" and "vn" words, so an
  // index is never accepted here that Assimp could read past.
  std::vector<std::string> lines;
  std::int64_t counts[3] = {0, 0, 0};  // v, vt, vn
  for (std::string line; std::getline(*in, line);) {
    const size_t a = line.find_first_not_of(" \t\r\v\f");
    if (a == std::string::npos) continue;
    line = line.substr(a);
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "v") ++counts[0];
    else if (word == "vt") ++counts[1];
    else if (word == "vn") ++counts[2];
    if (line[0] == 'f' || line[0] == 'l' || line[0] == 'p') lines.push_back(line);
  }
  const auto parse_index = [](const std::string& text, std::int64_t count, bool optional, bool* ok) {
    if (text.empty()) {
      *ok = optional;
      return;
    }
    size_t used = 0;
    long long v = 0;
    try {
      v = std::stoll(text, &used);
    } catch (const std::exception&) {
      *ok = false;
      return;
    }
    *ok = used == text.size() && v != 0 && v <= count && -v <= count;
  };
  for (const std::string& line : lines) {
    const std::string field = "\"" + line.substr(0, 40) + "\"";
    if (line[0] != 'f') ThrowInputError(path, field, "faces (\"f\"); line and point statements are not surfaces");
    // Corners follow the first word, whatever it is ("f1/1 2 3" has two).
    std::istringstream ls(line);
    std::string corner;
    ls >> corner;
    int corners = 0;
    while (ls >> corner) {
      std::vector<std::string> parts;
      size_t start = 0;
      for (size_t slash; (slash = corner.find('/', start)) != std::string::npos; start = slash + 1)
        parts.push_back(corner.substr(start, slash - start));
      parts.push_back(corner.substr(start));
      bool ok = parts.size() <= 3;
      for (size_t k = 0; ok && k < parts.size(); ++k) parse_index(parts[k], counts[k], k > 0, &ok);
      if (!ok) ThrowInputError(path, field, "face corners v, v/vt, v//vn or v/vt/vn with indices within the file's " +
                                                std::to_string(counts[0]) + " vertices");
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
      ThrowInputError(path, "triangle count", std::to_string(n) + " triangles of 50 bytes in a binary STL of " +
                                                  std::to_string(size) + " bytes");
    }
  } else if (ext == ".off") {
    CheckOff(path, size, &in);
  } else if (ext == ".ply") {
    CheckPly(path, size, &in);
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
  const int offset = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), o.vertices.begin(), o.vertices.end());
  for (const auto& t : o.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  if (colors) vertex_colors.insert(vertex_colors.end(), o.vertex_colors.begin(), o.vertex_colors.end());
  else vertex_colors.clear();
  triangle_uvs.clear();  // one texture per mesh: a union drops textures
  texture = Image();
}

void TriangleMesh::Check(const std::string& source) const {
  if (vertices.empty() || triangles.empty()) ThrowInputError(source, "triangles", "a mesh with at least one triangle");
  const int n = static_cast<int>(vertices.size());
  for (const auto& t : triangles) {
    if ((t.array() < 0).any() || (t.array() >= n).any()) ThrowInputError(source, "triangles", "vertex indices in range");
  }
  for (const auto& v : vertices) {
    if (!v.allFinite()) ThrowInputError(source, "vertices", "finite coordinates");
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
    if (tex.bytes_per_channel_ == 1 && (tex.num_of_channels_ == 3 || tex.num_of_channels_ == 4 || tex.num_of_channels_ == 1)) {
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
