// A libFuzzer target without libFuzzer: runs LLVMFuzzerTestOneInput on every file of a corpus
// folder, then on deterministic mutations of each (truncations, flipped bytes, overwritten runs),
// in the ordinary (GCC, unsanitized) build. `make test` runs the LibTorch archive target this way:
// its sanitized libFuzzer build compiles the nerf, reg and dbarf libraries a second time, which
// CI's time limit cannot carry, while the replay is one translation unit of the build CI makes
// anyway. `make fuzz` still fuzzes it under ASan + UBSan (scripts/fuzz.sh).
//
//   replay CORPUS_DIR [MUTATIONS_PER_SEED]
//
// A finding is what it is under libFuzzer: the target lets an exception other than InputError
// escape (std::terminate), or crashes. Exit 0 when every input ran; 2 on a bad command line.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv);
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

std::vector<uint8_t> ReadBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void Run(const std::vector<uint8_t>& bytes) { LLVMFuzzerTestOneInput(bytes.data(), bytes.size()); }

// One mutation of `seed`; the first byte (the target's selector) is kept so each mutation reaches
// the seed's loader and mode.
std::vector<uint8_t> Mutate(const std::vector<uint8_t>& seed, std::mt19937& rng) {
  std::vector<uint8_t> m = seed;
  if (m.size() < 2) return m;
  std::uniform_int_distribution<size_t> at(1, m.size() - 1);
  switch (rng() % 3) {
    case 0:  // truncated
      m.resize(at(rng));
      break;
    case 1:  // a few bytes flipped
      for (int k = 0; k < 4; ++k) m[at(rng)] ^= static_cast<uint8_t>(1u << (rng() % 8));
      break;
    default: {  // a run overwritten with one value (sizes, lengths, CRCs)
      const size_t begin = at(rng);
      const size_t end = std::min(m.size(), begin + 1 + rng() % 16);
      const uint8_t value = static_cast<uint8_t>(rng() % 2 ? 0xff : rng());
      for (size_t i = begin; i < end; ++i) m[i] = value;
    }
  }
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3 || !std::filesystem::is_directory(argv[1])) {
    std::fprintf(stderr, "error: %s: CORPUS_DIR: expected a folder of fuzz inputs\n", argc > 1 ? argv[1] : "replay");
    return 2;
  }
  const int mutations = argc == 3 ? std::atoi(argv[2]) : 0;
  LLVMFuzzerInitialize(&argc, &argv);
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(argv[1]))
    if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::mt19937 rng(1);
  for (const auto& f : files) {
    const std::vector<uint8_t> seed = ReadBytes(f);
    Run(seed);
    for (int k = 0; k < mutations; ++k) Run(Mutate(seed, rng));
  }
  std::printf("replay: %zu seeds, %d mutations each, no finding\n", files.size(), mutations);
  return files.empty() ? 2 : 0;
}
