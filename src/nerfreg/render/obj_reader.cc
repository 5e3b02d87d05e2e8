#include "nerfreg/render/obj_reader.h"

#include <charconv>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string_view>

#include "nerfreg/util/error.h"

namespace nerfreg {

void ObjReadOptions::Check() const {
  if (max_texture_side < 1 || max_texture_pixels < 1 || max_warnings < 0) {
    throw std::invalid_argument("ObjReadOptions: limits must be positive");
  }
}

namespace {

struct Token {
  std::string_view text;
  size_t begin = 0;  // offset in the line
};

std::vector<Token> Tokens(std::string_view line) {
  std::vector<Token> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const size_t b = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > b) out.push_back({line.substr(b, i - b), b});
  }
  return out;
}

std::string_view Trim(std::string_view s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string_view::npos) return {};
  return s.substr(a, s.find_last_not_of(" \t\r") - a + 1);
}

bool ParseFloat(std::string_view s, float* v) {
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(*v);
}

bool ParseIndex(std::string_view s, long long* v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), *v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Calls f(line_number, line) for every line ('\n' ends a line; a trailing '\r' is dropped).
template <typename F>
void ForEachLine(const std::string& text, F f) {
  size_t start = 0;
  for (int number = 1; start <= text.size(); ++number) {
    size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    f(number, Trim(std::string_view(text).substr(start, end - start)));
    start = end + 1;
  }
}

class Warnings {
 public:
  Warnings(ObjReadReport* report, int max) : report_(report), max_(max) {}
  void Add(const std::string& message) {
    ++report_->warning_count;
    if (static_cast<int>(report_->warnings.size()) < max_) report_->warnings.push_back(message);
  }

 private:
  ObjReadReport* report_;
  int max_;
};

struct MtlMaterial {
  Eigen::Vector3f diffuse = Eigen::Vector3f::Constant(0.8f);
  std::string texture;           // path relative to the OBJ's folder, "" for none
  std::string texture_fallback;  // the file's base name in the MTL's folder (archives flatten paths)
};

std::string Dir(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

std::string Base(const std::string& path) {
  const size_t slash = path.find_last_of("/\\");
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// The file name of a map_* statement: the options (words starting with '-' and the numbers or
// on/off after them, at most 3) skipped, then the rest of the line, spaces included.
std::string MapFileName(std::string_view line, const std::vector<Token>& t) {
  size_t k = 1;
  while (k < t.size() && t[k].text.size() > 1 && t[k].text[0] == '-') {
    ++k;
    float unused;
    for (int n = 0;
         n < 3 && k + 1 < t.size() && (ParseFloat(t[k].text, &unused) || t[k].text == "on" || t[k].text == "off"); ++n)
      ++k;
  }
  if (k >= t.size()) return "";
  return std::string(Trim(line.substr(t[k].begin)));
}

void ParseMtl(const std::string& text, const std::string& mtl_name, const std::string& mtl_dir,
              std::map<std::string, MtlMaterial>* out, Warnings* warn) {
  MtlMaterial* current = nullptr;
  ForEachLine(text, [&](int number, std::string_view line) {
    if (line.empty() || line[0] == '#') return;
    const std::vector<Token> t = Tokens(line);
    const std::string where = mtl_name + ": line " + std::to_string(number) + ": ";
    if (t[0].text == "newmtl") {
      const std::string name(t.size() > 1 ? Trim(line.substr(t[1].begin)) : "");
      current = out->count(name) ? nullptr : &(*out)[name];  // the first definition wins
      return;
    }
    if (t[0].text != "Kd" && t[0].text != "map_Kd") return;
    if (current == nullptr) {
      if (out->empty()) warn->Add(where + std::string(t[0].text) + " before any newmtl (ignored)");
      return;
    }
    if (t[0].text == "Kd") {
      float c[3];
      bool ok = t.size() == 2 || t.size() == 4;
      for (size_t k = 1; ok && k < t.size(); ++k) ok = ParseFloat(t[k].text, &c[k - 1]);
      if (!ok) {
        warn->Add(where + "expected \"Kd r g b\" (numbers; kept the default colour)");
        return;
      }
      if (t.size() == 2) c[1] = c[2] = c[0];
      current->diffuse = Eigen::Vector3f(c[0], c[1], c[2]).cwiseMax(0.f).cwiseMin(1.f);
    } else {
      const std::string file = MapFileName(line, t);
      if (file.empty()) {
        warn->Add(where + "expected \"map_Kd [options] FILE\" (no file; flat colour)");
        return;
      }
      current->texture = mtl_dir + file;
      current->texture_fallback = mtl_dir + Base(file);
    }
  });
}

// Box filter by an integer factor so that the larger side is at most max_side; RGB.
Image ShrinkTexture(const Image& in, int max_side) {
  const int f = (std::max(in.width, in.height) + max_side - 1) / max_side;
  if (f <= 1) return in;
  const int w = std::max(1, in.width / f), h = std::max(1, in.height / f);
  Image out(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        float sum = 0;
        for (int dy = 0; dy < f; ++dy)
          for (int dx = 0; dx < f; ++dx)
            sum += in.at(std::min(x * f + dx, in.width - 1), std::min(y * f + dy, in.height - 1), c);
        out.at(x, y, c) = sum / float(f * f);
      }
  return out;
}

Eigen::Vector3f MeanColour(const Image& image) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) sum(c) += image.at(x, y, c);
  return (sum / std::max(1.0, double(image.width) * image.height)).cast<float>();
}

}  // namespace

TriangleMesh ReadObjWithMaterials(const std::string& obj, const std::string& name, const ObjFileSource& files,
                                  const ObjReadOptions& options, ObjReadReport* report_out) {
  options.Check();
  ObjReadReport local;
  ObjReadReport& report = report_out != nullptr ? *report_out : local;
  report = ObjReadReport();
  Warnings warn(&report, options.max_warnings);

  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector2f> uvs;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Eigen::Vector3i> triangle_uv_index;  // -1: none
  std::vector<int> triangle_group;                 // index into group_names
  std::vector<std::string> group_names = {""};     // "" before any usemtl
  std::map<std::string, int> group_of = {{"", 0}};
  std::vector<std::string> mtllibs;
  int group = 0, statements = 0;

  ForEachLine(obj, [&](int number, std::string_view line) {
    if (line.empty() || line[0] == '#') return;
    const std::vector<Token> t = Tokens(line);
    const std::string_view key = t[0].text;
    const auto where = [&] { return name + ": line " + std::to_string(number) + ": "; };
    if (key == "v") {
      ++statements;
      Eigen::Vector3f p = Eigen::Vector3f::Zero();
      bool ok = t.size() >= 4;
      for (int k = 0; ok && k < 3; ++k) ok = ParseFloat(t[k + 1].text, &p[k]);
      if (!ok) warn.Add(where() + "expected \"v x y z\" (finite numbers; vertex set to 0 0 0)");
      positions.push_back(ok ? p : Eigen::Vector3f::Zero());
    } else if (key == "vt") {
      Eigen::Vector2f uv = Eigen::Vector2f::Zero();
      if (t.size() < 2 || !ParseFloat(t[1].text, &uv.x()) || (t.size() > 2 && !ParseFloat(t[2].text, &uv.y()))) {
        warn.Add(where() + "expected \"vt u [v]\" (finite numbers; set to 0 0)");
        uv.setZero();
      }
      uvs.push_back(uv);
    } else if (key == "f") {
      ++statements;
      std::vector<int> v_index, vt_index;
      bool ok = true, all_uv = true;
      for (size_t k = 1; ok && k < t.size(); ++k) {
        const std::string_view corner = t[k].text;
        const size_t s1 = corner.find('/');
        long long v = 0, vt = 0;
        ok = ParseIndex(corner.substr(0, s1), &v);
        if (ok && v < 0) v += static_cast<long long>(positions.size()) + 1;
        ok = ok && v >= 1 && v <= static_cast<long long>(positions.size());
        if (!ok) break;
        v_index.push_back(static_cast<int>(v - 1));
        bool has_uv = false;
        if (s1 != std::string_view::npos) {
          const std::string_view rest = corner.substr(s1 + 1);
          const std::string_view vt_text = rest.substr(0, rest.find('/'));
          if (!vt_text.empty() && ParseIndex(vt_text, &vt)) {
            if (vt < 0) vt += static_cast<long long>(uvs.size()) + 1;
            has_uv = vt >= 1 && vt <= static_cast<long long>(uvs.size());
          }
        }
        all_uv = all_uv && has_uv;
        vt_index.push_back(has_uv ? static_cast<int>(vt - 1) : -1);
      }
      if (!ok || v_index.size() < 3) {
        ++report.skipped_faces;
        warn.Add(where() + "expected a face of at least 3 corners with vertex indices within the " +
                 std::to_string(positions.size()) + " vertices so far (face skipped)");
        return;
      }
      for (size_t k = 1; k + 1 < v_index.size(); ++k) {
        triangles.emplace_back(v_index[0], v_index[k], v_index[k + 1]);
        triangle_uv_index.push_back(all_uv ? Eigen::Vector3i(vt_index[0], vt_index[k], vt_index[k + 1])
                                           : Eigen::Vector3i::Constant(-1));
        triangle_group.push_back(group);
      }
    } else if (key == "usemtl") {
      const std::string material(t.size() > 1 ? Trim(line.substr(t[1].begin)) : "");
      auto [it, inserted] = group_of.emplace(material, static_cast<int>(group_names.size()));
      if (inserted) group_names.push_back(material);
      group = it->second;
    } else if (key == "mtllib" && t.size() > 1) {
      mtllibs.emplace_back(Trim(line.substr(t[1].begin)));
    }
  });
  if (statements == 0) ThrowInputError(name, "", "an OBJ with \"v\" and \"f\" statements");
  if (triangles.empty()) ThrowInputError(name, "faces", "at least one face of 3 or more valid corners");

  // Materials: every mtllib (a name with spaces whole, else each word), first definition wins.
  std::map<std::string, MtlMaterial> defined;
  for (const std::string& lib : mtllibs) {
    std::vector<std::string> candidates = {lib};
    for (const Token& t : Tokens(lib))
      if (t.text != lib) candidates.emplace_back(t.text);
    bool found = false;
    for (const std::string& c : candidates) {
      std::string bytes;
      if (!files(c, &bytes)) continue;
      ParseMtl(bytes, c, Dir(c), &defined, &warn);
      found = true;
      break;
    }
    if (!found) warn.Add(name + ": mtllib " + lib + ": no such file (flat colours)");
  }

  std::map<std::string, Image> texture_cache;  // by path; empty: missing or undecodable
  const auto load_texture = [&](const std::string& path, const std::string& fallback) -> const Image& {
    if (auto it = texture_cache.find(path); it != texture_cache.end()) return it->second;
    Image& image = texture_cache[path];
    std::string bytes, used = path;
    bool found = files(path, &bytes);
    if (!found && fallback != path) found = files(used = fallback, &bytes);
    if (!found) {
      ++report.missing_textures;
      warn.Add(name + ": texture " + path + ": no such file (flat colour)");
      return image;
    }
    try {
      image = ShrinkTexture(DecodeImage(bytes, used, 3, options.max_texture_pixels), options.max_texture_side);
      ++report.textures;
    } catch (const InputError& e) {
      ++report.missing_textures;
      warn.Add(std::string(e.what()) + " (flat colour)");
    }
    return image;
  };

  TriangleMesh mesh;
  std::vector<int> material_of_group(group_names.size(), -1), flat_of_group(group_names.size(), -1);
  for (size_t g = 0; g < group_names.size(); ++g) {
    MeshMaterial m;
    m.name = group_names[g];
    if (auto it = defined.find(group_names[g]); it != defined.end()) {
      m.diffuse = it->second.diffuse;
      if (!it->second.texture.empty()) m.texture = load_texture(it->second.texture, it->second.texture_fallback);
    } else if (!group_names[g].empty()) {
      warn.Add(name + ": usemtl " + group_names[g] + ": no such material in the MTL files (flat grey)");
    }
    material_of_group[g] = static_cast<int>(mesh.materials.size());
    mesh.materials.push_back(m);
  }
  // A textured material on a face without texture coordinates: the texture's mean colour.
  const auto flat_variant = [&](int g) {
    if (flat_of_group[g] < 0) {
      MeshMaterial m = mesh.materials[material_of_group[g]];
      m.diffuse = MeanColour(m.texture);
      m.texture = Image();
      flat_of_group[g] = static_cast<int>(mesh.materials.size());
      mesh.materials.push_back(m);
    }
    return flat_of_group[g];
  };
  bool any_texture = false;
  for (const auto& m : mesh.materials) any_texture = any_texture || !m.texture.empty();

  // Keep the vertices faces use, in first-use order.
  std::vector<int> new_index(positions.size(), -1);
  for (size_t k = 0; k < triangles.size(); ++k) {
    Eigen::Vector3i tri;
    for (int c = 0; c < 3; ++c) {
      int& n = new_index[triangles[k][c]];
      if (n < 0) {
        n = static_cast<int>(mesh.vertices.size());
        mesh.vertices.push_back(positions[triangles[k][c]]);
      }
      tri[c] = n;
    }
    mesh.triangles.push_back(tri);
    const int g = triangle_group[k];
    const bool has_uv = triangle_uv_index[k][0] >= 0;
    const bool textured = !mesh.materials[material_of_group[g]].texture.empty();
    mesh.triangle_materials.push_back(textured && !has_uv ? flat_variant(g) : material_of_group[g]);
    if (any_texture) {
      for (int c = 0; c < 3; ++c)
        mesh.triangle_uvs.push_back(has_uv ? uvs[triangle_uv_index[k][c]] : Eigen::Vector2f::Zero());
    }
  }
  mesh.Check(name);
  return mesh;
}

}  // namespace nerfreg
