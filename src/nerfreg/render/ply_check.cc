#include "nerfreg/render/ply_check.h"

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <vector>

#include "nerfreg/util/error.h"

namespace nerfreg {
namespace {

constexpr int kEof = -1;
// rply.c's WORDSIZE and LINESIZE: a longer word or comment line fails in rply itself.
constexpr size_t kMaxWord = 255, kMaxLine = 1023;
// rply fills an 8 KB buffer first; a header inside it is tokenised without refills. (Its refill at
// the end of a file can read stale bytes from the previous fill, so nothing past it is guessed.)
constexpr std::int64_t kMaxHeaderBytes = 8000;

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64, kList, kUnknown };

// rply's type names (rply.c ply_type_list).
PlyType ParsePlyType(const std::string& t) {
  if (t == "int8" || t == "char") return PlyType::kInt8;
  if (t == "uint8" || t == "uchar") return PlyType::kUint8;
  if (t == "int16" || t == "short") return PlyType::kInt16;
  if (t == "uint16" || t == "ushort") return PlyType::kUint16;
  if (t == "int32" || t == "int") return PlyType::kInt32;
  if (t == "uint32" || t == "uint") return PlyType::kUint32;
  if (t == "float32" || t == "float") return PlyType::kFloat32;
  if (t == "float64" || t == "double") return PlyType::kFloat64;
  if (t == "list") return PlyType::kList;
  return PlyType::kUnknown;
}

int PlyTypeBytes(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
    default:
      return 0;
  }
}

bool IsFloat(PlyType t) { return t == PlyType::kFloat32 || t == PlyType::kFloat64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kUnknown;        // the value type (of each list entry for a list)
  PlyType count_type = PlyType::kUnknown;  // kUnknown for a scalar
  bool is_list() const { return count_type != PlyType::kUnknown; }
};

struct PlyElement {
  std::string name;
  std::int64_t count = 0;
  std::vector<PlyProperty> properties;
};

// The file as rply consumes it: one byte at a time, words split as ply_read_word splits them.
class PlyReader {
 public:
  // `in` stands at byte `offset` of the file.
  PlyReader(const std::string& path, std::istream* in, std::int64_t offset)
      : path_(path), buf_(in->rdbuf()), offset_(offset) {}

  std::int64_t offset() const { return offset_; }
  // In the header every byte is checked: control bytes other than \t \r \n are refused (rply's
  // word and line splitting treat \v, \f and NUL differently from each other and from us).
  void set_header(bool header) { header_ = header; }

  int Get() {
    const int c = buf_->sbumpc();
    if (c == std::char_traits<char>::eof()) return kEof;
    ++offset_;
    if (header_) CheckHeaderByte(c);
    return c;
  }
  int Peek() {
    const int c = buf_->sgetc();
    return c == std::char_traits<char>::eof() ? kEof : c;
  }

  // rply's ply_read_word: skips " \n\r\t", then reads up to the next of those or a NUL, and
  // consumes that one terminating byte (*terminator; kEof when the word ends the file). False
  // where rply fails: the file ends before a word, a NUL starts it, or it is longer than 255.
  bool ReadWord(std::string* word, int* terminator) {
    word->clear();
    int c = Get();
    while (c == ' ' || c == '\n' || c == '\r' || c == '\t') c = Get();
    while (c != kEof && c != 0 && c != ' ' && c != '\n' && c != '\r' && c != '\t') {
      word->push_back(static_cast<char>(c));
      c = Get();
    }
    *terminator = c;
    return !word->empty() && word->size() <= kMaxWord;
  }

  // rply's ply_read_line (a comment or obj_info): everything up to and including the next '\n'.
  bool SkipLine() {
    size_t n = 0;
    for (int c = Get(); c != '\n'; c = Get(), ++n)
      if (c == kEof || n >= kMaxLine) return false;
    return true;
  }

  // Skips `n` bytes of a binary body (the caller knows the file holds them).
  bool Skip(std::int64_t n) {
    if (buf_->pubseekoff(n, std::ios::cur, std::ios::in) < 0) return false;
    offset_ += n;
    return true;
  }

 private:
  void CheckHeaderByte(int c) {
    if (offset_ > kMaxHeaderBytes) {
      ThrowInputError(path_, "header", "a PLY header of at most " + std::to_string(kMaxHeaderBytes) + " bytes");
    }
    if (c < 0x20 && c != '\t' && c != '\r' && c != '\n') {
      ThrowInputError(path_, "header",
                      "printable text, spaces, tabs and line breaks (byte " + std::to_string(c) + " at offset " +
                          std::to_string(offset_ - 1) + ")");
    }
  }

  std::string path_;
  std::streambuf* buf_;
  std::int64_t offset_;
  bool header_ = false;
};

// One value of type `t` as rply's input handlers read it (iascii_* / ibinary_*); false where
// rply fails on it. An ASCII value that ends the file is refused (see kMaxHeaderBytes).
bool ReadValue(const std::string& path, PlyReader* r, bool ascii, bool big_endian, PlyType t, double* v) {
  if (ascii) {
    std::string word;
    int terminator;
    if (!r->ReadWord(&word, &terminator)) return false;
    if (terminator == kEof) {
      ThrowInputError(path, "body", "whitespace after the last value of an ASCII PLY (the file ends inside it)");
    }
    char* end = nullptr;
    if (IsFloat(t)) {
      *v = std::strtod(word.c_str(), &end);
      const double limit = t == PlyType::kFloat32 ? FLT_MAX : DBL_MAX;
      return *end == '\0' && !(*v < -limit || *v > limit);
    }
    *v = static_cast<double>(std::strtol(word.c_str(), &end, 10));
    double lo = 0, hi = 0;
    switch (t) {
      case PlyType::kInt8:
        lo = INT8_MIN, hi = INT8_MAX;
        break;
      case PlyType::kUint8:
        hi = UINT8_MAX;
        break;
      case PlyType::kInt16:
        lo = INT16_MIN, hi = INT16_MAX;
        break;
      case PlyType::kUint16:
        hi = UINT16_MAX;
        break;
      case PlyType::kInt32:
        lo = INT32_MIN, hi = INT32_MAX;
        break;
      default:
        hi = UINT32_MAX;
        break;
    }
    return *end == '\0' && *v >= lo && *v <= hi;
  }
  unsigned char b[8];
  const int n = PlyTypeBytes(t);
  for (int k = 0; k < n; ++k) {
    const int c = r->Get();
    if (c == kEof) return false;
    b[k] = static_cast<unsigned char>(c);
  }
  if (big_endian) std::reverse(b, b + n);  // to the host's little-endian order
  auto as = [&](auto x) {
    std::memcpy(&x, b, sizeof(x));
    return static_cast<double>(x);
  };
  switch (t) {
    case PlyType::kInt8:
      *v = as(std::int8_t());
      break;
    case PlyType::kUint8:
      *v = as(std::uint8_t());
      break;
    case PlyType::kInt16:
      *v = as(std::int16_t());
      break;
    case PlyType::kUint16:
      *v = as(std::uint16_t());
      break;
    case PlyType::kInt32:
      *v = as(std::int32_t());
      break;
    case PlyType::kUint32:
      *v = as(std::uint32_t());
      break;
    case PlyType::kFloat32:
      *v = as(float());
      break;
    default:
      *v = as(double());
      break;
  }
  return true;
}

}  // namespace

void CheckPlyForOpen3d(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) ThrowInputError(path, "", "a readable PLY file");
  in.seekg(0, std::ios::end);
  const std::int64_t size = in.tellg();
  in.seekg(0);
  auto refuse = [&](const std::string& field, const std::string& expected) { ThrowInputError(path, field, expected); };

  // rply's magic: "ply" and any isspace byte; a "\r\n" there makes it skip one more byte after
  // end_header's terminator.
  char magic[5] = {0, 0, 0, 0, 0};
  in.read(magic, 5);
  if (std::strncmp(magic, "ply", 3) != 0 || !std::isspace(static_cast<unsigned char>(magic[3]))) return;
  const bool rn = magic[3] == '\r' && magic[4] == '\n';
  in.clear();
  in.seekg(3);

  PlyReader r(path, &in, 3);
  r.set_header(true);
  std::string w;
  int terminator = kEof;
  // Every header word: failing where rply fails (the file ends, a word of 256+ bytes).
  auto word = [&] {
    if (!r.ReadWord(&w, &terminator)) refuse("header", "words of at most 255 bytes up to end_header");
  };
  auto skip_line = [&](const std::string& keyword) {
    if (terminator == kEof || !r.SkipLine()) refuse(keyword, "a line of at most 1023 bytes ending in a line break");
  };

  word();
  std::string format;
  if (w == "format") {
    word();
    format = w;
    word();
  }
  if ((format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") || w != "1.0") {
    refuse("format", "\"format ascii|binary_little_endian|binary_big_endian 1.0\" after \"ply\"");
  }
  word();
  std::vector<PlyElement> elements;
  while (w != "end_header") {
    if (w == "comment" || w == "obj_info") {
      skip_line(w);
      word();
      continue;
    }
    if (w != "element") refuse("header", "element, property, comment, obj_info or end_header (got \"" + w + "\")");
    PlyElement e;
    word();
    e.name = w;
    word();
    // rply reads the count with sscanf("%ld"), which takes "3abc" as 3: digits alone are accepted.
    if (w.empty() || w.size() > 18 || w.find_first_not_of("0123456789") != std::string::npos) {
      refuse("element " + e.name, "a decimal count (got \"" + w + "\")");
    }
    e.count = std::stoll(w);
    // Open3D sizes its arrays from the count (every instance takes at least one byte), and rply
    // hands the count back as an int.
    if (e.count > size || e.count > INT_MAX) {
      refuse("element " + e.name,
             "a count the file's " + std::to_string(size) + " bytes can hold (got " + std::to_string(e.count) + ")");
    }
    word();
    for (;;) {
      if (w == "property") {
        PlyProperty p;
        word();
        p.type = ParsePlyType(w);
        if (p.type == PlyType::kList) {
          word();
          p.count_type = ParsePlyType(w);
          word();
          p.type = ParsePlyType(w);
          // rply casts a float count to long, which is undefined past 2^63: integer counts only.
          if (PlyTypeBytes(p.count_type) == 0 || IsFloat(p.count_type)) {
            refuse("property", "\"property list COUNT_TYPE TYPE NAME\" with an integer COUNT_TYPE");
          }
        }
        if (PlyTypeBytes(p.type) == 0) refuse("property", "\"property TYPE NAME\" with a PLY type (got \"" + w + "\")");
        word();
        p.name = w;
        e.properties.push_back(p);
        word();
      } else if (w == "comment" || w == "obj_info") {
        skip_line(w);
        word();
      } else {
        break;
      }
    }
    elements.push_back(e);
  }
  // Where the body starts must be unambiguous: end_header, then the magic line's line break.
  if (rn ? (terminator != '\r' || r.Get() != '\n') : terminator != '\n') {
    refuse("end_header",
           std::string("\"end_header\" followed by the line break after \"ply\" (") + (rn ? "\\r\\n" : "\\n") + ")");
  }
  r.set_header(false);

  // What Open3D reads (FilePLY.cpp): the vertex count of the first "vertex" element, if it has
  // an "x"; faces from the first "face" element's first "vertex_indices" list, else its first
  // "vertex_index" list (rply finds the first element and property of a name).
  const PlyElement* vertex = nullptr;
  const PlyElement* face = nullptr;
  for (const PlyElement& e : elements) {
    if (e.name == "vertex" && !vertex) vertex = &e;
    if (e.name == "face" && !face) face = &e;
  }
  auto find = [](const PlyElement* e, const std::string& name) -> const PlyProperty* {
    for (const PlyProperty& p : e->properties)
      if (p.name == name) return &p;
    return nullptr;
  };
  if (!vertex || !find(vertex, "x")) return;  // Open3D refuses a PLY without vertices itself
  const std::int64_t num_vertices = vertex->count;
  const PlyProperty* face_list = nullptr;
  if (face) face_list = find(face, "vertex_indices") ? find(face, "vertex_indices") : find(face, "vertex_index");
  if (!face_list || face->count == 0) return;
  if (!face_list->is_list()) refuse("property " + face_list->name, "a list (\"property list COUNT_TYPE TYPE NAME\")");

  const bool ascii = format == "ascii";
  const bool big_endian = format == "binary_big_endian";
  for (const PlyElement& e : elements) {
    // A binary element of scalars has a fixed size: skipped, not read.
    if (!ascii && &e != face) {
      std::int64_t bytes = 0;
      bool fixed = true;
      for (const PlyProperty& p : e.properties) {
        fixed = fixed && !p.is_list();
        bytes += PlyTypeBytes(p.type);
      }
      if (fixed) {
        if (bytes * e.count > size - r.offset()) return;  // rply fails on the short file itself
        if (!r.Skip(bytes * e.count)) return;
        continue;
      }
    }
    for (std::int64_t i = 0; i < e.count; ++i) {
      for (const PlyProperty& p : e.properties) {
        const bool checked = &p == face_list;
        double count = 1, v;
        if (p.is_list() && !ReadValue(path, &r, ascii, big_endian, p.count_type, &count)) return;
        if (checked && count < 3) {
          refuse("face " + std::to_string(i),
                 "a polygon of at least 3 vertices (got " + std::to_string(static_cast<std::int64_t>(count)) + ")");
        }
        // rply reads max(count, 0) values; a count past the file's end fails in rply.
        const std::int64_t n = std::max<std::int64_t>(0, static_cast<std::int64_t>(count));
        if (n > size - r.offset()) return;
        for (std::int64_t j = 0; j < n; ++j) {
          if (!ReadValue(path, &r, ascii, big_endian, p.type, &v)) return;
          if (checked && !(v >= 0 && v < num_vertices)) {
            refuse("face " + std::to_string(i),
                   "vertex indices below the vertex count " + std::to_string(num_vertices));
          }
        }
      }
    }
    if (&e == face) return;  // nothing after the faces is triangulated
  }
}

}  // namespace nerfreg
