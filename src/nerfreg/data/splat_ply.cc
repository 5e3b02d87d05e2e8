#include "nerfreg/data/splat_ply.h"

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

void Splats::Resize(std::int64_t n, int degree, bool normals) {
  if (degree < 0 || degree > 3) throw std::invalid_argument("Splats::Resize: SH degree must be 0..3");
  sh_degree = degree;
  position.resize(3, n);
  normal.resize(3, normals ? n : 0);
  f_dc.resize(3, n);
  f_rest.resize(3 * (ShCoefficientCount(degree) - 1), n);
  opacity.resize(n);
  log_scale.resize(3, n);
  rotation.resize(4, n);
  extras.clear();
}

void Splats::CheckShapes() const {
  const std::int64_t n = size();
  bool ok = sh_degree >= 0 && sh_degree <= 3 && (normal.cols() == 0 || normal.cols() == n) && f_dc.cols() == n &&
            f_rest.cols() == n && f_rest.rows() == 3 * (ShCoefficientCount(sh_degree) - 1) && opacity.size() == n &&
            log_scale.cols() == n && rotation.cols() == n;
  for (const auto& e : extras) ok = ok && static_cast<std::int64_t>(e.values.size()) == n;
  if (!ok) throw std::invalid_argument("Splats: arrays of inconsistent sizes");
}

namespace {

// A header of a deg-3 INRIA file is ~1.5 KB; anything past this is not a splat file.
constexpr size_t kMaxHeaderBytes = 65536;
// Properties besides the splat's own, kept as doubles: bounded so that a file of one-byte extras
// cannot expand eightfold in memory.
constexpr int kMaxExtras = 16;

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool ParsePlyType(const std::string& t, PlyType* type) {
  static const std::pair<const char*, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [name, value] : kNames) {
    if (t == name) {
      *type = value;
      return true;
    }
  }
  return false;
}

int PlyTypeBytes(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kFloat64:
      return 8;
    default:
      return 4;
  }
}

bool IsFloatType(PlyType t) { return t == PlyType::kFloat32 || t == PlyType::kFloat64; }

// Where a vertex property's value goes.
enum class Slot { kPosition, kNormal, kDc, kRest, kOpacity, kScale, kRotation, kExtra };

struct Property {
  std::string name, type_name;
  PlyType type = PlyType::kFloat32;
  Slot slot = Slot::kExtra;
  int index = 0;  // the component (or extra) index within its slot
};

struct Header {
  bool ascii = false;
  std::int64_t vertices = 0;
  std::vector<Property> properties;  // of the vertex element
  size_t body = 0;                   // offset of the first byte after the header
  int sh_degree = 0;
  bool normals = false;
};

std::vector<std::string> SplitWords(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// The header's lines (without line breaks) up to end_header; `body` gets the offset after it.
std::vector<std::string> HeaderLines(const std::string& bytes, const std::string& src, size_t* body) {
  std::vector<std::string> lines;
  size_t pos = 0;
  while (true) {
    const size_t end = bytes.find('\n', pos);
    if (end == std::string::npos || end >= kMaxHeaderBytes) {
      ThrowInputError(src, "header",
                      "a PLY header ending in an end_header line within " + std::to_string(kMaxHeaderBytes) + " bytes");
    }
    std::string line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    for (char c : line) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') {
        ThrowInputError(src, "header",
                        "printable text (a control byte in line " + std::to_string(lines.size() + 1) + ")");
      }
    }
    pos = end + 1;
    lines.push_back(line);
    if (lines.size() == 1 && line != "ply") ThrowInputError(src, "magic", "a PLY file (first line \"ply\")");
    if (line == "end_header") break;
  }
  *body = pos;
  return lines;
}

// Assigns each vertex property its slot; checks the splat's own properties are there, float, and
// that the f_rest count is that of an SH degree.
void AssignSlots(Header* h, const std::string& src) {
  struct Named {
    std::string name;
    Slot slot;
    int index;
  };
  std::vector<Named> own = {
      {"x", Slot::kPosition, 0},      {"y", Slot::kPosition, 1},     {"z", Slot::kPosition, 2},
      {"f_dc_0", Slot::kDc, 0},       {"f_dc_1", Slot::kDc, 1},      {"f_dc_2", Slot::kDc, 2},
      {"opacity", Slot::kOpacity, 0}, {"scale_0", Slot::kScale, 0},  {"scale_1", Slot::kScale, 1},
      {"scale_2", Slot::kScale, 2},   {"rot_0", Slot::kRotation, 0}, {"rot_1", Slot::kRotation, 1},
      {"rot_2", Slot::kRotation, 2},  {"rot_3", Slot::kRotation, 3}};
  const std::vector<Named> normals = {{"nx", Slot::kNormal, 0}, {"ny", Slot::kNormal, 1}, {"nz", Slot::kNormal, 2}};
  auto find = [&](const std::string& name) -> Property* {
    for (Property& p : h->properties)
      if (p.name == name) return &p;
    return nullptr;
  };
  auto require_float = [&](Property* p) {
    if (p->type != PlyType::kFloat32) {
      ThrowInputError(src, "property " + p->name, "type float (got " + p->type_name + ")");
    }
  };
  for (const Named& n : own) {
    Property* p = find(n.name);
    if (!p) ThrowInputError(src, "property " + n.name, "a float property of the vertex element (it is missing)");
    require_float(p);
    p->slot = n.slot;
    p->index = n.index;
  }
  int have_normals = 0;
  for (const Named& n : normals) have_normals += find(n.name) != nullptr;
  if (have_normals != 0 && have_normals != 3) ThrowInputError(src, "property nx", "nx, ny and nz together, or none");
  h->normals = have_normals == 3;
  for (const Named& n : normals) {
    if (Property* p = find(n.name)) {
      require_float(p);
      p->slot = n.slot;
      p->index = n.index;
    }
  }
  int rest = 0;
  while (find("f_rest_" + std::to_string(rest))) ++rest;
  for (const Property& p : h->properties) {
    if (p.name.rfind("f_rest_", 0) == 0 && p.name.size() > 7) {
      int k = -1;
      const auto r = std::from_chars(p.name.data() + 7, p.name.data() + p.name.size(), k);
      if (r.ec != std::errc() || r.ptr != p.name.data() + p.name.size() || k >= rest) {
        ThrowInputError(src, "property " + p.name,
                        "f_rest_0 .. f_rest_" + std::to_string(rest) + " numbered without gaps");
      }
    }
  }
  h->sh_degree = -1;
  for (int d = 0; d <= 3; ++d)
    if (rest == 3 * (ShCoefficientCount(d) - 1)) h->sh_degree = d;
  if (h->sh_degree < 0) {
    ThrowInputError(src, "property f_rest_0",
                    "0, 9, 24 or 45 f_rest properties (SH degree 0-3), got " + std::to_string(rest));
  }
  for (int k = 0; k < rest; ++k) {
    Property* p = find("f_rest_" + std::to_string(k));
    require_float(p);
    p->slot = Slot::kRest;
    p->index = k;
  }
  int extras = 0;
  for (Property& p : h->properties) {
    if (p.slot != Slot::kExtra) continue;
    if (extras == kMaxExtras) {
      ThrowInputError(src, "property " + p.name,
                      "at most " + std::to_string(kMaxExtras) + " properties besides the splat's own");
    }
    p.index = extras++;
  }
}

Header ParseHeader(const std::string& bytes, const std::string& src) {
  Header h;
  const std::vector<std::string> lines = HeaderLines(bytes, src, &h.body);
  if (lines.size() < 2 || (lines[1] != "format ascii 1.0" && lines[1] != "format binary_little_endian 1.0")) {
    ThrowInputError(src, "format",
                    "\"format binary_little_endian 1.0\" or \"format ascii 1.0\" after \"ply\" (got \"" +
                        (lines.size() < 2 ? std::string() : lines[1].substr(0, 64)) + "\")");
  }
  h.ascii = lines[1] == "format ascii 1.0";
  int element = -1;  // elements seen; only the first (vertex) is read
  for (size_t i = 2; i + 1 < lines.size(); ++i) {
    const std::vector<std::string> w = SplitWords(lines[i]);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "element") {
      ++element;
      if (w.size() != 3) ThrowInputError(src, "header line " + std::to_string(i + 1), "\"element NAME COUNT\"");
      if (element == 0 && w[1] != "vertex") ThrowInputError(src, "element " + w[1], "the vertex element first");
      if (element > 0) continue;
      const std::string& c = w[2];
      if (c.size() > 15 || c.find_first_not_of("0123456789") != std::string::npos) {
        ThrowInputError(src, "element vertex", "a decimal count (got \"" + c.substr(0, 32) + "\")");
      }
      h.vertices = std::stoll(c);
    } else if (w[0] == "property") {
      if (element < 0)
        ThrowInputError(src, "header line " + std::to_string(i + 1), "a property after its element line");
      if (element > 0) continue;
      if (w.size() >= 2 && w[1] == "list") {
        ThrowInputError(src, "property " + w.back(), "a scalar property (the vertex element has no lists)");
      }
      Property p;
      if (w.size() != 3 || !ParsePlyType(w[1], &p.type)) {
        ThrowInputError(src, "header line " + std::to_string(i + 1), "\"property TYPE NAME\" with a PLY scalar type");
      }
      p.type_name = w[1];
      p.name = w[2];
      for (const Property& q : h.properties)
        if (q.name == p.name) ThrowInputError(src, "property " + p.name, "one vertex property of each name");
      h.properties.push_back(p);
    } else {
      ThrowInputError(src, "header line " + std::to_string(i + 1),
                      "element, property, comment or end_header (got \"" + w[0].substr(0, 32) + "\")");
    }
  }
  if (element < 0) ThrowInputError(src, "element vertex", "a vertex element");
  AssignSlots(&h, src);
  // Before anything is allocated: the body must be able to hold every vertex the header claims.
  const std::int64_t available = static_cast<std::int64_t>(bytes.size() - h.body);
  const std::int64_t per_vertex = [&] {
    std::int64_t n = 0;
    // ASCII: at least one character and one separator per value (the last may end the file).
    for (const Property& p : h.properties) n += h.ascii ? 2 : PlyTypeBytes(p.type);
    return n;
  }();
  const std::int64_t fits = (available + (h.ascii ? 1 : 0)) / per_vertex;
  if (h.vertices > fits) {
    ThrowInputError(src, "element vertex",
                    "at most " + std::to_string(fits) + " vertices in the " + std::to_string(available) +
                        " bytes after the header (" + std::to_string(per_vertex) + (h.ascii ? " or more" : "") +
                        " bytes each; the header claims " + std::to_string(h.vertices) + ")");
  }
  return h;
}

double ReadBinary(const char* p, PlyType t) {
  auto as = [p](auto x) {
    std::memcpy(&x, p, sizeof(x));
    return static_cast<double>(x);
  };
  switch (t) {
    case PlyType::kInt8:
      return as(std::int8_t());
    case PlyType::kUint8:
      return as(std::uint8_t());
    case PlyType::kInt16:
      return as(std::int16_t());
    case PlyType::kUint16:
      return as(std::uint16_t());
    case PlyType::kInt32:
      return as(std::int32_t());
    case PlyType::kUint32:
      return as(std::uint32_t());
    case PlyType::kFloat32:
      return as(float());
    default:
      return as(double());
  }
}

// ASCII values: whitespace-separated tokens, read with from_chars (no locale).
class AsciiBody {
 public:
  AsciiBody(const std::string& bytes, size_t start, const std::string& src) : b_(bytes), pos_(start), src_(src) {}
  double Next(const Property& p, std::int64_t vertex) {
    while (pos_ < b_.size() && std::isspace(static_cast<unsigned char>(b_[pos_]))) ++pos_;
    const size_t start = pos_;
    while (pos_ < b_.size() && !std::isspace(static_cast<unsigned char>(b_[pos_]))) ++pos_;
    const std::string field = "vertex[" + std::to_string(vertex) + "]." + p.name;
    if (start == pos_) ThrowInputError(src_, field, "a value (the file ends early)");
    const char* first = b_.data() + start;
    const char* last = b_.data() + pos_;
    const std::string token(first, std::min<size_t>(pos_ - start, 32));
    if (IsFloatType(p.type)) {
      double v = 0;
      const auto r = std::from_chars(first, last, v);
      if (r.ec != std::errc() || r.ptr != last) ThrowInputError(src_, field, "a number (got \"" + token + "\")");
      if (p.type == PlyType::kFloat32 && std::isfinite(v) && std::fabs(v) > FLT_MAX) {
        ThrowInputError(src_, field, "a value a float can hold (got " + token + ")");
      }
      return p.type == PlyType::kFloat32 ? static_cast<double>(static_cast<float>(v)) : v;
    }
    std::int64_t v = 0;
    const auto r = std::from_chars(first, last, v);
    const int bits = 8 * PlyTypeBytes(p.type);
    const bool is_unsigned = p.type == PlyType::kUint8 || p.type == PlyType::kUint16 || p.type == PlyType::kUint32;
    const std::int64_t lo = is_unsigned ? 0 : -(std::int64_t(1) << (bits - 1));
    const std::int64_t hi = is_unsigned ? (std::int64_t(1) << bits) - 1 : (std::int64_t(1) << (bits - 1)) - 1;
    if (r.ec != std::errc() || r.ptr != last || v < lo || v > hi) {
      ThrowInputError(src_, field, "an integer of type " + p.type_name + " (got \"" + token + "\")");
    }
    return static_cast<double>(v);
  }

 private:
  const std::string& b_;
  size_t pos_;
  const std::string& src_;
};

// Checks one splat's values (the file's own numbers, before any use).
void CheckSplat(const Splats& s, std::int64_t i, const std::string& src) {
  const std::string v = "vertex[" + std::to_string(i) + "]";
  auto finite = [&](const auto& m, const char* name) {
    if (!m.allFinite()) ThrowInputError(src, v + "." + name, "finite numbers (not NaN or infinite)");
  };
  finite(s.position.col(i), "xyz");
  if (s.position.col(i).cwiseAbs().maxCoeff() > kMaxSplatCoordinate) {
    ThrowInputError(src, v + ".xyz", "coordinates within 1e7 scene units");
  }
  // Normals, SH coefficients and quaternion components are bounded so that rotating them (reg
  // apply) stays within a float.
  auto bounded = [&](const auto& m, const char* name, const char* what) {
    finite(m, name);
    if (m.size() > 0 && m.cwiseAbs().maxCoeff() > kMaxSplatValue) {
      ThrowInputError(src, v + "." + name, std::string(what) + " within 1e6");
    }
  };
  if (s.has_normals()) bounded(s.normal.col(i), "normal", "components");
  bounded(s.f_dc.col(i), "f_dc", "SH coefficients");
  if (s.f_rest.rows() > 0) bounded(s.f_rest.col(i), "f_rest", "SH coefficients");
  if (!std::isfinite(s.opacity(i))) ThrowInputError(src, v + ".opacity", "a finite number (not NaN or infinite)");
  finite(s.log_scale.col(i), "scale");
  if (s.log_scale.col(i).cwiseAbs().maxCoeff() > kMaxLogScale) {
    ThrowInputError(src, v + ".scale", "log scales within [-40, 40]");
  }
  bounded(s.rotation.col(i), "rot", "quaternion components");
  if (!(s.rotation.col(i).cast<double>().squaredNorm() > 1e-30)) {
    ThrowInputError(src, v + ".rot", "a non-zero quaternion (rot_0..3 are all zero)");
  }
}

void Store(Splats* s, const Property& p, std::int64_t i, double v) {
  const float f = static_cast<float>(v);
  switch (p.slot) {
    case Slot::kPosition:
      s->position(p.index, i) = f;
      break;
    case Slot::kNormal:
      s->normal(p.index, i) = f;
      break;
    case Slot::kDc:
      s->f_dc(p.index, i) = f;
      break;
    case Slot::kRest:
      s->f_rest(p.index, i) = f;
      break;
    case Slot::kOpacity:
      s->opacity(i) = f;
      break;
    case Slot::kScale:
      s->log_scale(p.index, i) = f;
      break;
    case Slot::kRotation:
      s->rotation(p.index, i) = f;
      break;
    case Slot::kExtra:
      s->extras[p.index].values[i] = v;
      break;
  }
}

}  // namespace

Splats ParseSplatPly(const std::string& bytes, const std::string& src) {
  const Header h = ParseHeader(bytes, src);
  Splats s;
  s.Resize(h.vertices, h.sh_degree, h.normals);
  for (const Property& p : h.properties) {
    if (p.slot == Slot::kExtra) s.extras.push_back({p.name, p.type_name, std::vector<double>(h.vertices)});
  }
  if (h.ascii) {
    AsciiBody body(bytes, h.body, src);
    for (std::int64_t i = 0; i < h.vertices; ++i)
      for (const Property& p : h.properties) Store(&s, p, i, body.Next(p, i));
  } else {
    const char* ptr = bytes.data() + h.body;
    for (std::int64_t i = 0; i < h.vertices; ++i) {
      for (const Property& p : h.properties) {
        Store(&s, p, i, ReadBinary(ptr, p.type));
        ptr += PlyTypeBytes(p.type);
      }
    }
  }
  for (std::int64_t i = 0; i < h.vertices; ++i) CheckSplat(s, i, src);
  return s;
}

Splats ReadSplatPly(const std::string& path) { return ParseSplatPly(ReadFileToString(path), path); }

bool IsSplatPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::string head(kMaxHeaderBytes, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  if (head.rfind("ply", 0) != 0) return false;
  const size_t end = head.find("end_header");
  std::istringstream lines(head.substr(0, end));
  for (std::string line; std::getline(lines, line);) {
    const std::vector<std::string> w = SplitWords(line);
    if (w.size() == 3 && w[0] == "property" &&
        (w[2] == "f_dc_0" || w[2] == "opacity" || w[2] == "rot_0" || w[2] == "scale_0")) {
      return true;
    }
  }
  return false;
}

namespace {

// The properties in the INRIA order, then the extras: (name, type) and how to fetch splat i's value.
struct OutProperty {
  std::string name, type;
  std::function<double(std::int64_t)> value;
};

std::vector<OutProperty> OutProperties(const Splats& s) {
  std::vector<OutProperty> out;
  auto add = [&](const std::string& name, std::function<double(std::int64_t)> f) { out.push_back({name, "float", f}); };
  const char* xyz[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) add(xyz[k], [&s, k](std::int64_t i) { return s.position(k, i); });
  if (s.has_normals()) {
    const char* n[] = {"nx", "ny", "nz"};
    for (int k = 0; k < 3; ++k) add(n[k], [&s, k](std::int64_t i) { return s.normal(k, i); });
  }
  for (int k = 0; k < 3; ++k) add("f_dc_" + std::to_string(k), [&s, k](std::int64_t i) { return s.f_dc(k, i); });
  for (int k = 0; k < s.f_rest.rows(); ++k) {
    add("f_rest_" + std::to_string(k), [&s, k](std::int64_t i) { return s.f_rest(k, i); });
  }
  add("opacity", [&s](std::int64_t i) { return s.opacity(i); });
  for (int k = 0; k < 3; ++k) add("scale_" + std::to_string(k), [&s, k](std::int64_t i) { return s.log_scale(k, i); });
  for (int k = 0; k < 4; ++k) add("rot_" + std::to_string(k), [&s, k](std::int64_t i) { return s.rotation(k, i); });
  for (const auto& e : s.extras) out.push_back({e.name, e.type, [&e](std::int64_t i) { return e.values[i]; }});
  return out;
}

void AppendBinary(std::string* out, PlyType t, double v) {
  auto put = [out](auto x) { out->append(reinterpret_cast<const char*>(&x), sizeof(x)); };
  switch (t) {
    case PlyType::kInt8:
      put(static_cast<std::int8_t>(v));
      break;
    case PlyType::kUint8:
      put(static_cast<std::uint8_t>(v));
      break;
    case PlyType::kInt16:
      put(static_cast<std::int16_t>(v));
      break;
    case PlyType::kUint16:
      put(static_cast<std::uint16_t>(v));
      break;
    case PlyType::kInt32:
      put(static_cast<std::int32_t>(v));
      break;
    case PlyType::kUint32:
      put(static_cast<std::uint32_t>(v));
      break;
    case PlyType::kFloat32:
      put(static_cast<float>(v));
      break;
    default:
      put(v);
      break;
  }
}

}  // namespace

std::string SerializeSplatPly(const Splats& s, bool ascii) {
  s.CheckShapes();
  const std::vector<OutProperty> props = OutProperties(s);
  std::string out = std::string("ply\nformat ") + (ascii ? "ascii" : "binary_little_endian") + " 1.0\nelement vertex " +
                    std::to_string(s.size()) + "\n";
  std::vector<PlyType> types;
  for (const OutProperty& p : props) {
    PlyType t;
    if (!ParsePlyType(p.type, &t)) throw std::invalid_argument("SerializeSplatPly: unknown PLY type " + p.type);
    types.push_back(t);
    out += "property " + p.type + " " + p.name + "\n";
  }
  out += "end_header\n";
  out.reserve(out.size() + s.size() * props.size() * (ascii ? 16 : 4));
  char buf[64];
  for (std::int64_t i = 0; i < s.size(); ++i) {
    for (size_t k = 0; k < props.size(); ++k) {
      const double v = props[k].value(i);
      if (!ascii) {
        AppendBinary(&out, types[k], v);
        continue;
      }
      // %.9g reads back to the same float; %.17g to the same double.
      const int n = types[k] == PlyType::kFloat32   ? std::snprintf(buf, sizeof(buf), "%.9g", v)
                    : types[k] == PlyType::kFloat64 ? std::snprintf(buf, sizeof(buf), "%.17g", v)
                                                    : std::snprintf(buf, sizeof(buf), "%.0f", v);
      out.append(buf, n);
      out += k + 1 == props.size() ? '\n' : ' ';
    }
  }
  return out;
}

void WriteSplatPly(const Splats& splats, const std::string& path, bool ascii) {
  WriteFileAtomic(path, SerializeSplatPly(splats, ascii));
}

}  // namespace nerfreg
