#!/usr/bin/env bash
# Builds the parsers with clang + ASan + UBSan + libFuzzer (no LibTorch: build-san/), runs the
# sanitized unit tests of those layers, then every fuzz target for FUZZ_SECONDS each on its seed
# corpus. `make fuzz` runs long; `make test` runs it briefly.
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS=${FUZZ_SECONDS:-10}
BUILD=${SAN_BUILD_DIR:-build-san}
if [ ! -f "$BUILD/build.ninja" ]; then
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
    -DCMAKE_CXX_COMPILER=clang++ -DNERFREG_WITH_TORCH=OFF -DNERFREG_SANITIZE=ON -DNERFREG_FUZZ=ON \
    -DNERFREG_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$BUILD" -j "$(nproc)"
echo "== sanitized unit tests (ASan + UBSan)"
(cd "$BUILD" && ctest --output-on-failure -j "$(nproc)")
for fuzzer in "$BUILD"/fuzz/*_fuzz; do
  name=$(basename "$fuzzer" _fuzz)
  corpus=$(mktemp -d)
  cp -r fuzz/corpus/"$name"/. "$corpus"/ 2>/dev/null || true
  echo "== fuzz $name for ${FUZZ_SECONDS}s"
  "$fuzzer" -max_total_time="$FUZZ_SECONDS" -rss_limit_mb=2048 -max_len=65536 -print_final_stats=0 \
    -artifact_prefix="$corpus/crash-" "$corpus" 2>"$corpus.log" || { grep -v "^    #[0-9]" "$corpus.log" | tail -30; echo "fuzz $name FAILED (input kept in $corpus)"; exit 1; }
  grep -E "^Done|#[0-9]+ *DONE" "$corpus.log" | tail -1 || true
  rm -rf "$corpus" "$corpus.log"
done
echo "fuzz: all targets ran clean"
