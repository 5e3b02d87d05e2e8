#include "nerfreg/data/npy.h"

#include <gtest/gtest.h>

#include <cstring>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// Hand-assembles a .npy file: numpy is not available here, so the bytes are built as the format
// specification describes them.
std::string NpyBytes(int major, const std::string& header_dict, const std::string& payload) {
  std::string header = header_dict;
  const size_t prefix = major == 1 ? 10 : 12;
  header += std::string((64 - (prefix + header.size() + 1) % 64) % 64, ' ') + "\n";
  std::string out = "\x93NUMPY";
  out += static_cast<char>(major);
  out += '\0';
  const size_t len = header.size();
  out += static_cast<char>(len & 0xff);
  out += static_cast<char>((len >> 8) & 0xff);
  if (major != 1) {
    out += '\0';
    out += '\0';
  }
  return out + header + payload;
}

template <typename T>
std::string Raw(std::initializer_list<T> values, bool big_endian = false) {
  std::string out;
  for (T v : values) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));
    out.append(b, sizeof(T));
  }
  return out;
}

TEST(Npy, ReadsCOrderFloat64) {
  const auto a = ParseNpy(
      NpyBytes(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }", Raw<double>({1, 2, 3, 4, 5, 6})),
      "a.npy");
  EXPECT_EQ(a.shape, (std::vector<std::int64_t>{2, 3}));
  EXPECT_EQ(a.data, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  // An empty Fortran array whose other dimensions multiply past 2^63 reads as empty. The fuzzer's
  // file: npy_fuzz (UBSan) flagged the strides formed from them; it replays it from
  // fuzz/corpus/npy/empty_fortran_huge_strides.
  const std::string found(
      "\x93NUMPY\x02.t\x00\x00\x00{'descr': '>f4',\x1d'fortran_order': True, 'shape': (0, 44, "
      "444,434, 44,444, 444,434, 44,4,44,4,43)44\xed }\x00\x00\xfe\xff\xff\xa9\x00\x00\x00      "
      "\x00\x00\x00\x00\x00\x00\x00",
      135);
  const auto e = ParseNpy(found, "e.npy");
  EXPECT_TRUE(e.data.empty());
  EXPECT_EQ(e.shape.size(), 13u);
}

TEST(Npy, ReadsFortranOrderAsRowMajor) {
  // Matrix [[1,2,3],[4,5,6]] stored column by column.
  const auto a = ParseNpy(
      NpyBytes(1, "{'descr': '<f8', 'fortran_order': True, 'shape': (2, 3), }", Raw<double>({1, 4, 2, 5, 3, 6})),
      "a.npy");
  EXPECT_EQ(a.data, (std::vector<double>{1, 2, 3, 4, 5, 6}));
}

TEST(Npy, ReadsBigEndianFloat32AndVersion2AndInts) {
  const auto a = ParseNpy(
      NpyBytes(2, "{'descr': '>f4', 'fortran_order': False, 'shape': (3,), }", Raw<float>({1.5f, -2.f, 3.25f}, true)),
      "b.npy");
  EXPECT_EQ(a.data, (std::vector<double>{1.5, -2, 3.25}));
  const auto i = ParseNpy(
      NpyBytes(1, "{'descr': '<i4', 'fortran_order': False, 'shape': (2,), }", Raw<std::int32_t>({-7, 9})), "c.npy");
  EXPECT_EQ(i.data, (std::vector<double>{-7, 9}));
}

TEST(Npy, WriteReadRoundTrip) {
  ScopedTempDir dir;
  NpyArray a;
  a.shape = {4, 17};
  for (int k = 0; k < 68; ++k) a.data.push_back(k * 0.125 - 3);
  WriteNpy(dir.File("x.npy"), a);
  const NpyArray b = ReadNpy(dir.File("x.npy"));
  EXPECT_EQ(b.shape, a.shape);
  EXPECT_EQ(b.data, a.data);
  // The header is padded so the data is 64-byte aligned, as numpy writes it.
  EXPECT_EQ((ReadFileToString(dir.File("x.npy")).size() - 68 * 8) % 64, 0u);
}

std::string NpyErrorOf(const std::string& bytes) {
  return InputErrorOf([&] { ParseNpy(bytes, "bad.npy"); });
}

TEST(Npy, BadFilesAreNamedErrorsWithoutAllocating) {
  EXPECT_NE(NpyErrorOf("not numpy").find("bad.npy: magic"), std::string::npos);
  // A header claiming 10^12 elements: refused from the header, nothing allocated.
  EXPECT_NE(NpyErrorOf(NpyBytes(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000, 1000000), }", ""))
                .find("bad.npy: shape"),
            std::string::npos);
  // Fewer bytes than the shape needs: truncated.
  EXPECT_NE(NpyErrorOf(NpyBytes(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (4,), }", Raw<double>({1, 2})))
                .find("truncated"),
            std::string::npos);
  EXPECT_NE(NpyErrorOf(NpyBytes(1, "{'descr': '<c16', 'fortran_order': False, 'shape': (1,), }", std::string(16, 0)))
                .find("descr"),
            std::string::npos);
  EXPECT_NE(NpyErrorOf(NpyBytes(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (-3,), }", "")).find("shape"),
            std::string::npos);
  std::string truncated_header = NpyBytes(1, "{'descr': '<f8', 'fortran_order': False, 'shape': (1,), }", "");
  EXPECT_NE(NpyErrorOf(truncated_header.substr(0, 30)).find("header"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
