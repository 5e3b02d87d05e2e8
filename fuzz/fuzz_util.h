#pragma once
// libFuzzer harness helpers: the parsers take paths (they report the file in their errors), so
// each input is written to a file in /dev/shm first. A parser may only ever throw InputError on
// bad bytes; anything else (another exception, a crash, a sanitizer report) is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace nerfreg {

inline std::string WriteFuzzInput(const uint8_t* data, size_t size, const char* suffix) {
  // One file per process and suffix (the mesh fuzzer varies the extension, which picks the reader).
  const std::string path = "/dev/shm/nerfreg_fuzz_" + std::to_string(::getpid()) + suffix;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0) std::fwrite(data, 1, size, f);
  std::fclose(f);
  return path;
}

}  // namespace nerfreg
