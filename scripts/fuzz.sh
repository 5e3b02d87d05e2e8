#!/usr/bin/env bash
# Builds the parsers with clang + ASan + UBSan + libFuzzer (no LibTorch: build-san/), runs the
# sanitized unit tests of those layers, then every fuzz target for FUZZ_SECONDS each on its seed
# corpus, as many at once as there are cores (each fuzzer is one process on one core). Then the
# torch-archive fuzzer, in its own LibTorch build (build-fuzz-torch/: only the nerf, reg and dbarf
# libraries it links, ~60 files; FUZZ_TORCH=0 skips it). `make fuzz` runs long; `make test` runs it
# briefly and with FUZZ_TORCH=0: its ctest replays the torch-archive target's corpus and mutations
# of it in the ordinary build (fuzz/replay_main.cc), which costs CI no second LibTorch build.
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS=${FUZZ_SECONDS:-10}
BUILD=${SAN_BUILD_DIR:-build-san}
TORCH_BUILD=${FUZZ_TORCH_BUILD_DIR:-build-fuzz-torch}
FUZZ_TORCH=${FUZZ_TORCH:-1}

# run_fuzzer BINARY CORPUS_NAME [libFuzzer flags...] (given flags come last: libFuzzer keeps the last)
run_fuzzer() {
  local fuzzer=$1 name=$2
  shift 2
  local corpus
  corpus=$(mktemp -d)
  cp -r fuzz/corpus/"$name"/. "$corpus"/ 2>/dev/null || true
  echo "== fuzz $name for ${FUZZ_SECONDS}s"
  "$fuzzer" -max_total_time="$FUZZ_SECONDS" -rss_limit_mb=2048 -max_len=65536 -timeout=30 -print_final_stats=0 \
    -artifact_prefix="$corpus/crash-" "$@" "$corpus" 2>"$corpus.log" || { grep -v "^    #[0-9]" "$corpus.log" | tail -30; echo "fuzz $name FAILED (input kept in $corpus)"; exit 1; }
  grep -E "^Done|#[0-9]+ *DONE" "$corpus.log" | tail -1 || true
  rm -rf "$corpus" "$corpus.log"
}

if [ ! -f "$BUILD/build.ninja" ]; then
  # -O1 and line tables alone (symbolised reports keep their lines): a sixth less compile time than
  # RelWithDebInfo's -O2 -g on the heaviest unit.
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
    -DCMAKE_CXX_COMPILER=clang++ -DNERFREG_WITH_TORCH=OFF -DNERFREG_SANITIZE=ON -DNERFREG_FUZZ=ON \
    -DNERFREG_BUILD_BENCH=OFF >/dev/null
fi
cmake --build "$BUILD" -j "$(nproc)"
echo "== sanitized unit tests (ASan + UBSan)"
# The pair-selection tests on rendered orbits (SIFT on whole renders) run 20x slower sanitized
# (114-127 s each) and parse nothing the other tests do not: the normal build runs them, as it runs
# the layout and format checks.
(cd "$BUILD" && ctest --output-on-failure -j "$(nproc)" -E 'PairSelection\.(Retrieval|SequentialWithLoop|AutoJoins)|^check_')
# Each fuzzer's output goes to its own log, printed when it ends, so parallel runs do not interleave.
JOBS=${FUZZ_JOBS:-$(nproc)}
logs=$(mktemp -d)
pids=() names=()
for fuzzer in "$BUILD"/fuzz/*_fuzz; do
  while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do wait -n || true; done
  name=$(basename "$fuzzer" _fuzz)
  run_fuzzer "$fuzzer" "$name" > "$logs/$name.log" 2>&1 &
  pids+=($!) names+=("$name")
done
failed=0
for i in "${!pids[@]}"; do
  if ! wait "${pids[$i]}"; then failed=1; fi
  cat "$logs/${names[$i]}.log"
done
rm -rf "$logs"
if [ "$failed" != 0 ]; then
  echo "fuzz: a target failed (above)"
  exit 1
fi

if [ "$FUZZ_TORCH" != 0 ]; then
  # ASan + UBSan instrument our code only (Debian's LibTorch is not rebuilt); -O1 and line tables
  # alone keep the build of the torch layers short, and without -DNDEBUG header assertions (JSON
  # access to a missing key: one finding) stay on. No tests, benchmarks or binary are built.
  if [ ! -f "$TORCH_BUILD/build.ninja" ]; then
    cmake -S . -B "$TORCH_BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -gline-tables-only" \
      -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DNERFREG_WITH_TORCH=ON -DNERFREG_SANITIZE=ON \
      -DNERFREG_FUZZ=ON -DNERFREG_BUILD_TESTS=OFF -DNERFREG_BUILD_BENCH=OFF >/dev/null
  fi
  cmake --build "$TORCH_BUILD" -j "$(nproc)" --target torch_archive_fuzz
  # Seed archives are up to 447 KB (DBARF weights: ~200 small modules, each tensor its own entry).
  run_fuzzer "$TORCH_BUILD/fuzz/torch_archive_fuzz" torch_archive -max_len=524288
fi
echo "fuzz: all targets ran clean"
