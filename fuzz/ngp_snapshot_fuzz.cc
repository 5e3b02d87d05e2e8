// Fuzzes instant-ngp snapshot reading (.msgpack and zlib/gzip .ingp): msgpack structure, config
// ranges, parameter and density-grid sizes, inflate limits.
#include "fuzz_util.h"
#include "nerfreg/data/ngp_snapshot.h"
#include "nerfreg/util/error.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = nerfreg::WriteFuzzInput(data, size, ".ingp");
  nerfreg::NgpReadOptions options;
  options.max_inflated_bytes = std::int64_t(64) << 20;  // within the fuzzer's memory limit
  try {
    nerfreg::ReadNgpSnapshot(path, options);
  } catch (const nerfreg::InputError&) {
  }
  return 0;
}
