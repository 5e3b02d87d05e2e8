#pragma once
// NumPy .npy arrays (format 1.0, 2.0, 3.0), read and written without numpy: LLFF's
// poses_bounds.npy is one. Any numeric dtype of 1-8 bytes in either byte order and either memory
// order is read into a row-major double array.
#include <cstdint>
#include <string>
#include <vector>

namespace nerfreg {

struct NpyArray {
  std::vector<std::int64_t> shape;
  std::vector<double> data;  // row-major (C order), size = product of shape
  std::int64_t Size() const;
};

// Largest element count a .npy may claim (2^31): checked against the header and against the
// file's actual size before allocating.
constexpr std::int64_t kMaxNpyElements = std::int64_t(1) << 31;

// Throws InputError("FILE: FIELD: expected ...") on a bad magic, header, dtype, shape or a file
// shorter than its header says.
NpyArray ReadNpy(const std::string& path);
NpyArray ParseNpy(const std::string& bytes, const std::string& source_name);

// Writes little-endian float64, C order, format 1.0, atomically.
void WriteNpy(const std::string& path, const NpyArray& array);
std::string SerializeNpy(const NpyArray& array);

}  // namespace nerfreg
