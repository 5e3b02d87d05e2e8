#include "nerfreg/render/sh3f.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {
namespace {

void AppendUtf8(std::string* out, std::uint32_t c) {
  if (c < 0x80) {
    out->push_back(static_cast<char>(c));
  } else if (c < 0x800) {
    out->push_back(static_cast<char>(0xC0 | (c >> 6)));
    out->push_back(static_cast<char>(0x80 | (c & 0x3F)));
  } else {
    out->push_back(static_cast<char>(0xE0 | (c >> 12)));
    out->push_back(static_cast<char>(0x80 | ((c >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (c & 0x3F)));
  }
}

// Unescapes a key or value (escapes as Java's Properties.load; bytes as ISO-8859-1).
std::string Unescape(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c != '\\' || i + 1 == s.size()) {
      AppendUtf8(&out, c);
      continue;
    }
    const char e = s[++i];
    if (e == 'u' && i + 4 < s.size() + 0 && s.find_first_not_of("0123456789abcdefABCDEF", i + 1) >= i + 5) {
      AppendUtf8(&out, static_cast<std::uint32_t>(std::stoul(s.substr(i + 1, 4), nullptr, 16)));
      i += 4;
    } else {
      AppendUtf8(&out, e == 't'   ? '\t'
                       : e == 'n' ? '\n'
                       : e == 'r' ? '\r'
                       : e == 'f' ? '\f'
                                  : static_cast<unsigned char>(e));
    }
  }
  return out;
}

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\f'; }

}  // namespace

std::vector<std::pair<std::string, std::string>> ParseJavaProperties(const std::string& text) {
  std::vector<std::pair<std::string, std::string>> out;
  std::vector<std::string> raw;
  {
    std::string line;
    for (size_t i = 0; i <= text.size(); ++i) {
      if (i < text.size() && text[i] != '\n' && text[i] != '\r') {
        line.push_back(text[i]);
        continue;
      }
      if (i + 1 < text.size() && text[i] == '\r' && text[i + 1] == '\n') ++i;
      raw.push_back(line);
      line.clear();
    }
  }
  std::string logical;
  bool continued = false;
  for (std::string line : raw) {
    size_t a = 0;
    while (a < line.size() && IsSpace(line[a])) ++a;
    line = line.substr(a);
    if (!continued && (line.empty() || line[0] == '#' || line[0] == '!')) continue;
    // An odd number of trailing backslashes continues the line.
    size_t slashes = 0;
    while (slashes < line.size() && line[line.size() - 1 - slashes] == '\\') ++slashes;
    const bool continues = slashes % 2 == 1;
    logical += continues ? line.substr(0, line.size() - 1) : line;
    continued = continues;
    if (continued) continue;
    size_t k = 0;
    while (k < logical.size() && logical[k] != '=' && logical[k] != ':' && !IsSpace(logical[k])) {
      k += logical[k] == '\\' ? 2 : 1;
    }
    k = std::min(k, logical.size());
    const std::string key = logical.substr(0, k);
    size_t v = k;
    while (v < logical.size() && IsSpace(logical[v])) ++v;
    if (v < logical.size() && (logical[v] == '=' || logical[v] == ':')) ++v;
    while (v < logical.size() && IsSpace(logical[v])) ++v;
    out.emplace_back(Unescape(key), Unescape(logical.substr(v)));
    logical.clear();
  }
  return out;
}

std::vector<Sh3fModel> ReadSh3fCatalog(const ZipReader& archive, std::vector<std::string>* warnings) {
  const std::string catalog = "PluginFurnitureCatalog.properties";
  if (!archive.Has(catalog)) ThrowInputError(archive.name(), catalog, "a Sweet Home 3D furniture catalog entry");
  std::map<int, std::map<std::string, std::string>> by_index;
  for (const auto& [key, value] : ParseJavaProperties(archive.Read(catalog))) {
    const size_t hash = key.rfind('#');
    if (hash == std::string::npos || hash + 1 >= key.size() ||
        key.find_first_not_of("0123456789", hash + 1) != std::string::npos || key.size() - hash > 7) {
      continue;
    }
    by_index[std::stoi(key.substr(hash + 1))][key.substr(0, hash)] = value;
  }
  const auto warn = [&](const std::string& w) {
    if (warnings != nullptr) warnings->push_back(archive.name() + ": " + w);
  };
  std::vector<Sh3fModel> out;
  for (auto& [index, f] : by_index) {
    Sh3fModel m;
    m.id = f["id"];
    m.name = f["name"];
    m.category = f["category"];
    m.archive = archive.name();
    std::string path = f["model"];
    while (!path.empty() && path[0] == '/') path.erase(0, 1);
    m.model = ResolveArchivePath("", path);
    const std::string where = "model #" + std::to_string(index) + " (" + m.id + ")";
    if (m.id.empty() || m.model.empty()) {
      warn(where + ": expected an id and a model path inside the archive (left out)");
      continue;
    }
    if (!archive.Has(m.model)) {
      warn(where + ": expected its model " + m.model + " in the archive (left out)");
      continue;
    }
    const char* dims[3] = {"width", "height", "depth"};
    for (int k = 0; k < 3; ++k) {
      char* end = nullptr;
      const std::string& text = f[dims[k]];
      const float v = std::strtof(text.c_str(), &end);
      m.size_cm[k] = !text.empty() && end == text.c_str() + text.size() && std::isfinite(v) && v > 0 ? v : 0.f;
    }
    if (f.count("modelRotation")) {
      std::istringstream in(f["modelRotation"]);
      Eigen::Matrix3f r;
      bool ok = true;
      for (int k = 0; k < 9 && ok; ++k) ok = static_cast<bool>(in >> r(k / 3, k % 3));
      if (ok && r.allFinite() && std::abs(std::abs(r.determinant()) - 1.f) < 1e-3f) {
        m.model_rotation = r;
      } else {
        warn(where + ": expected modelRotation as 9 numbers of a rotation (ignored)");
      }
    }
    out.push_back(m);
  }
  return out;
}

std::vector<Sh3fModel> ReadSh3fCatalogs(const std::string& dir, std::vector<std::string>* warnings) {
  std::vector<std::string> archives;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    if (e.path().extension() == ".sh3f") archives.push_back(e.path().string());
  }
  if (archives.empty()) {
    ThrowInputError(dir, "", "a folder of .sh3f furniture archives (Debian: apt-get install sweethome3d-furniture)");
  }
  std::sort(archives.begin(), archives.end());
  std::vector<Sh3fModel> out;
  std::set<std::string> ids;
  for (const auto& a : archives) {
    for (const auto& m : ReadSh3fCatalog(ZipReader::Open(a), warnings)) {
      if (!ids.insert(m.id).second) ThrowInputError(a, m.id, "model ids unique across the archives");
      out.push_back(m);
    }
  }
  return out;
}

TriangleMesh LoadSh3fModel(const ZipReader& archive, const Sh3fModel& model, const ObjReadOptions& options,
                           ObjReadReport* report) {
  const std::string where = archive.name() + ":" + model.model;
  const size_t slash = model.model.rfind('/');
  const std::string dir = slash == std::string::npos ? "" : model.model.substr(0, slash + 1);
  const ObjFileSource files = [&](const std::string& path, std::string* bytes) {
    const std::string entry = ResolveArchivePath(dir, path);
    if (entry.empty() || !archive.Has(entry)) return false;
    *bytes = archive.Read(entry);
    return true;
  };
  TriangleMesh mesh = ReadObjWithMaterials(archive.Read(model.model), where, files, options, report);
  for (auto& v : mesh.vertices) v = model.model_rotation * v;
  Eigen::Vector3f mn, mx;
  mesh.Bounds(&mn, &mx);
  const Eigen::Vector3f extent = mx - mn;
  Eigen::Vector3f scale = Eigen::Vector3f::Zero();
  float sum = 0;
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    if (model.size_cm[k] > 0 && extent[k] > 0) {
      scale[k] = model.size_cm[k] / extent[k];
      sum += scale[k];
      ++n;
    }
  }
  if (n > 0) {
    for (int k = 0; k < 3; ++k) {
      if (!(scale[k] > 0)) scale[k] = sum / n;
    }
    for (auto& v : mesh.vertices) v = (v - mn).cwiseProduct(scale) + mn;
  }
  mesh.Check(where);
  return mesh;
}

TriangleMesh LoadSh3fModel(const Sh3fModel& model, const ObjReadOptions& options, ObjReadReport* report) {
  return LoadSh3fModel(ZipReader::Open(model.archive), model, options, report);
}

}  // namespace nerfreg
