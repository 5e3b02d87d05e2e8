#include "nerfreg/data/npy.h"

#include <cstring>
#include <regex>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

std::int64_t NpyArray::Size() const {
  std::int64_t n = 1;
  for (auto d : shape) n *= d;
  return n;
}

namespace {

std::uint64_t ReadLittle(const unsigned char* p, int n) {
  std::uint64_t v = 0;
  for (int k = n - 1; k >= 0; --k) v = (v << 8) | p[k];
  return v;
}

// Reads one element of `size` bytes and kind ('f', 'i', 'u', 'b') as a double.
double Element(const unsigned char* p, char kind, int size, bool big_endian) {
  unsigned char b[8];
  for (int k = 0; k < size; ++k) b[k] = big_endian ? p[size - 1 - k] : p[k];
  const std::uint64_t bits = ReadLittle(b, size);
  switch (kind) {
    case 'f':
      if (size == 8) {
        double d;
        std::memcpy(&d, &bits, 8);
        return d;
      } else {
        const std::uint32_t u = static_cast<std::uint32_t>(bits);
        float f;
        std::memcpy(&f, &u, 4);
        return f;
      }
    case 'i': {
      const int shift = 64 - 8 * size;
      return static_cast<double>(static_cast<std::int64_t>(bits << shift) >> shift);
    }
    default:  // 'u', 'b'
      return static_cast<double>(bits);
  }
}

}  // namespace

NpyArray ParseNpy(const std::string& bytes, const std::string& src) {
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < 10 || std::memcmp(bytes.data(), "\x93NUMPY", 6) != 0) {
    ThrowInputError(src, "magic", "a .npy file (\\x93NUMPY header)");
  }
  const int major = u[6];
  size_t header_len = 0, header_start = 0;
  if (major == 1) {
    header_len = ReadLittle(u + 8, 2);
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) ThrowInputError(src, "header", "a complete header");
    header_len = ReadLittle(u + 8, 4);
    header_start = 12;
  } else {
    ThrowInputError(src, "version", "format version 1, 2 or 3, got " + std::to_string(major));
  }
  if (header_start + header_len > bytes.size()) ThrowInputError(src, "header", "a complete header (file truncated)");
  const std::string header = bytes.substr(header_start, header_len);

  std::smatch m;
  static const std::regex descr_re(R"('descr'\s*:\s*'([<>|=])([fiub])(\d+)')");
  static const std::regex order_re(R"('fortran_order'\s*:\s*(True|False))");
  static const std::regex shape_re(R"('shape'\s*:\s*\(([^)]*)\))");
  if (!std::regex_search(header, m, descr_re)) ThrowInputError(src, "descr", "a numeric dtype such as '<f8'");
  const char order_char = m[1].str()[0];
  const char kind = m[2].str()[0];
  const int size = std::stoi(m[3].str().substr(0, 2));
  if (!((kind == 'f' && (size == 4 || size == 8)) ||
        ((kind == 'i' || kind == 'u') && (size == 1 || size == 2 || size == 4 || size == 8)) ||
        (kind == 'b' && size == 1))) {
    ThrowInputError(src, "descr", "f4, f8, i1-i8, u1-u8 or b1, got " + m[0].str());
  }
  const bool big_endian = order_char == '>';
  if (!std::regex_search(header, m, order_re)) ThrowInputError(src, "fortran_order", "True or False");
  const bool fortran = m[1].str() == "True";
  if (!std::regex_search(header, m, shape_re)) ThrowInputError(src, "shape", "a tuple of sizes");
  NpyArray array;
  {
    const std::string dims = m[1].str();
    size_t pos = 0;
    std::int64_t total = 1;
    while (pos < dims.size()) {
      const size_t comma = dims.find(',', pos);
      std::string token = dims.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
      token.erase(0, token.find_first_not_of(" \t"));
      token.erase(token.find_last_not_of(" \tL") + 1);
      if (!token.empty()) {
        if (token.size() > 12 || token.find_first_not_of("0123456789") != std::string::npos) {
          ThrowInputError(src, "shape", "non-negative integer sizes, got '" + token + "'");
        }
        const std::int64_t d = std::stoll(token);
        array.shape.push_back(d);
        if (d > 0 && total > kMaxNpyElements / d) ThrowInputError(src, "shape", "at most 2^31 elements");
        total *= d;
      }
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
  }
  const std::int64_t n = array.Size();
  const size_t data_start = header_start + header_len;
  if (static_cast<std::uint64_t>(n) * size > bytes.size() - data_start) {
    ThrowInputError(src, "shape",
                    std::to_string(n) + " elements of " + std::to_string(size) + " bytes, file has only " +
                        std::to_string(bytes.size() - data_start) + " data bytes (truncated?)");
  }
  array.data.resize(static_cast<size_t>(n));
  // An empty array has no data; its other dimensions may be huge (only their product is bounded),
  // so no strides are formed from them (the fuzzer's (0, 44, 444, ...) overflowed them).
  if (n == 0) return array;
  const unsigned char* p = u + data_start;
  if (!fortran || array.shape.size() < 2) {
    for (std::int64_t k = 0; k < n; ++k) array.data[k] = Element(p + k * size, kind, size, big_endian);
  } else {
    // Fortran order: the first index varies fastest. Map each stored element to its C index.
    const size_t nd = array.shape.size();
    std::vector<std::int64_t> idx(nd, 0), c_stride(nd, 1);
    for (int d = static_cast<int>(nd) - 2; d >= 0; --d) c_stride[d] = c_stride[d + 1] * array.shape[d + 1];
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t c = 0;
      for (size_t d = 0; d < nd; ++d) c += idx[d] * c_stride[d];
      array.data[c] = Element(p + k * size, kind, size, big_endian);
      for (size_t d = 0; d < nd; ++d) {
        if (++idx[d] < array.shape[d]) break;
        idx[d] = 0;
      }
    }
  }
  return array;
}

NpyArray ReadNpy(const std::string& path) { return ParseNpy(ReadFileToString(path), path); }

std::string SerializeNpy(const NpyArray& array) {
  std::string shape = "(";
  for (size_t k = 0; k < array.shape.size(); ++k)
    shape += std::to_string(array.shape[k]) + (array.shape.size() == 1 || k + 1 < array.shape.size() ? "," : "");
  shape += ")";
  std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': " + shape + ", }";
  // Pad so that the data starts at a multiple of 64 bytes, header ending in '\n'.
  const size_t total = 10 + header.size() + 1;
  header += std::string((64 - total % 64) % 64, ' ') + "\n";
  std::string out = "\x93NUMPY";
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>((header.size() >> 8) & 0xff);
  out += header;
  static_assert(sizeof(double) == 8, "double must be 64-bit");
  const size_t start = out.size();
  out.resize(start + array.data.size() * 8);
  std::memcpy(out.data() + start, array.data.data(), array.data.size() * 8);  // x86/ARM: little-endian
  return out;
}

void WriteNpy(const std::string& path, const NpyArray& array) {
  if (static_cast<std::int64_t>(array.data.size()) != array.Size()) {
    throw std::invalid_argument("WriteNpy: data size does not match the shape");
  }
  WriteFileAtomic(path, SerializeNpy(array));
}

}  // namespace nerfreg
