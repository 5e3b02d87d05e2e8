#!/usr/bin/env bash
# The GPU check, one command on a machine with an NVIDIA GPU and no network (docs/gpu.md). It needs
# PyTorch with CUDA (its LibTorch is built against), nvcc, CMake >= 3.24, Ninja, and the learned
# core's header libraries (Eigen, nlohmann-json, spdlog, fmt, GoogleTest, zlib, libexif). It
#   1. builds the learned core with the CUDA kernels from the working tree (build-gpu/),
#   2. runs the CUDA cases (they must run, not skip) and the 2-process NCCL test (it runs where 2
#      GPUs are present and skips, reported, on one),
#   3. times the learned core on the GPU and the hash encoding on the CPU too (bench/gpu_bench.cc):
#      a NeRF block at 100x100 to 28 dB, an 800x800 block of 100 views, DReg-NeRF training steps and
#      DBARF pretraining steps in the paper configurations,
#   4. with GPU_DREG_DATA, trains the DReg-NeRF paper network on real blocks it makes on the GPU
#      from carried renders, and scores it on held-out pairs (bench/gpu_dreg.cc),
#   5. runs the nerfreg commands users run with --device cuda (scripts/cli_device_check.sh: nerf
#      train / --resume / eval / render / export, reg extract, dbarf pretrain / --resume / finetune,
#      reg train) on a carried block dataset; with GPU_DBARF_DATA, then pretrains DBARF's paper
#      configuration for GPU_DBARF_SECONDS (scripts/dbarf_device_train.sh, resumable),
#   6. runs all of the learned core's tests (last: the longest step),
#   7. writes results/gpu.json (machine, versions, build time, tests, timings, the DReg run, the
#      commands).
#
#   PYTHON          the Python whose torch is used (default python3)
#   GPU_BUILD_DIR   build folder (default build-gpu)
#   GPU_RESULTS     output JSON (default results/gpu.json)
#   CUDA_ARCHS      CMAKE_CUDA_ARCHITECTURES (default native: the GPU present)
#   GPU_CTEST_JOBS, GPU_CTEST_TIMEOUT  ctest's -j (default 4) and per-test limit in s (default 900)
#   GPU_BUILD_ONLY=1  stop after the build (to run chosen tests first; a second call rebuilds nothing)
#   GPU_SKIP_TESTS=1  reuse the test logs of an earlier run in the same build folder (a second
#                   call on a warm machine that only times)
#   GPU_TESTS=0     leave out step 5 (a short lease spent on training; recorded as not run)
#   GPU_DREG_DATA   a folder of train/, val/, test/ made by `reg make-data --render-only`
#                   (scripts/gpu_dreg_data.sh); GPU_DREG_ARGS: more flags for nerfreg_gpu_dreg
#   GPU_CLI_DATA    the block dataset of step 5 (default: the first test object's block_0 of
#                   GPU_DREG_DATA; step 5 is left out without either); its reg train trains on
#                   the pairs step 4 made
#   GPU_DBARF_DATA  a folder of scripts/dbarf_data.sh (train.txt, val.txt) to pretrain DBARF's
#                   paper configuration on, for GPU_DBARF_SECONDS (default 240), in
#                   GPU_LOGS/dbarf_paper/ (its weights; a later call with the same logs resumes)
#   GPU_LOGS        the logs' folder (default GPU_BUILD_DIR/gpu_check)
#   GPU_BENCH       which timings (default hash,nerf100,nerf800,reg,dbarf)
#   GPU_QUICK=1     a short smoke run of the timings (not for results)
#   GPU_DEPS        a folder of Debian packages made by scripts/gpu_deps.sh (header libraries, fmt,
#                   spdlog, GoogleTest, zlib, libexif, Gloo's headers) for a machine that lacks them: unpacked
#                   under /tmp/nerfreg-gpu-deps and put on CMake's and the loader's paths
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
BUILD_DIR=${GPU_BUILD_DIR:-build-gpu}
RESULTS=${GPU_RESULTS:-results/gpu.json}
JOBS=${JOBS:-$(nproc)}

fail() {
  echo "error: gpu_check: $*" >&2
  exit 2
}
if [ -n "${GPU_DEPS:-}" ]; then
  [ -d "${GPU_DEPS}" ] || fail "GPU_DEPS=${GPU_DEPS}: expected a folder of .deb files (scripts/gpu_deps.sh)"
  DEPS_ROOT=/tmp/nerfreg-gpu-deps
  mkdir -p "${DEPS_ROOT}"
  for deb in "${GPU_DEPS}"/*.deb; do dpkg-deb -x "${deb}" "${DEPS_ROOT}" 2>/dev/null || fail "${deb}: expected a Debian package"; done
  export CMAKE_PREFIX_PATH="${DEPS_ROOT}/usr:${DEPS_ROOT}/usr/lib/x86_64-linux-gnu/cmake${CMAKE_PREFIX_PATH:+:${CMAKE_PREFIX_PATH}}"
  export LD_LIBRARY_PATH="${DEPS_ROOT}/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:${LD_LIBRARY_PATH}}"
  # Gloo's headers (c10d's ProcessGroupGloo includes them) only where the compiler finds no other:
  # CPLUS_INCLUDE_PATH is searched after every -I and -isystem folder.
  mkdir -p "${DEPS_ROOT}/gloo-include"
  ln -sfn "${DEPS_ROOT}/usr/include/gloo" "${DEPS_ROOT}/gloo-include/gloo"
  export CPLUS_INCLUDE_PATH="${DEPS_ROOT}/gloo-include${CPLUS_INCLUDE_PATH:+:${CPLUS_INCLUDE_PATH}}"
fi
for tool in cmake ninja nvidia-smi "${PYTHON}"; do
  command -v "${tool}" >/dev/null || fail "${tool}: expected on PATH"
done

TORCH_DIR=$("${PYTHON}" -c 'import os, torch; print(os.path.join(torch.utils.cmake_prefix_path, "Torch"))') ||
  fail "${PYTHON}: expected an importable torch"
TORCH_VERSION=$("${PYTHON}" -c 'import torch; print(torch.__version__)')
TORCH_CUDA=$("${PYTHON}" -c 'import torch; print(torch.version.cuda or "")')
[ -n "${TORCH_CUDA}" ] || fail "torch ${TORCH_VERSION}: expected a build with CUDA"
"${PYTHON}" -c 'import torch, sys; sys.exit(0 if torch.cuda.is_available() else 1)' ||
  fail "torch.cuda.is_available(): expected True (a GPU and its driver)"

NVCC=${CUDACXX:-$(command -v nvcc || true)}
for candidate in /usr/local/cuda/bin/nvcc /usr/local/cuda-*/bin/nvcc; do
  if [ -z "${NVCC}" ] && [ -x "${candidate}" ]; then NVCC=${candidate}; fi
done
[ -n "${NVCC}" ] || fail "nvcc: expected the CUDA toolkit (PATH, CUDACXX or /usr/local/cuda)"
CUDA_ROOT=$(dirname "$(dirname "$(readlink -f "${NVCC}")")")
GPU_NAME=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -n 1)
DRIVER=$(nvidia-smi --query-gpu=driver_version --format=csv,noheader | head -n 1)
echo "gpu_check: ${GPU_NAME} (driver ${DRIVER}), torch ${TORCH_VERSION} (CUDA ${TORCH_CUDA}), ${NVCC}"

LOGS=${GPU_LOGS:-${BUILD_DIR}/gpu_check}
mkdir -p "${LOGS}"

# 1. Build.
build_start=$(date +%s)
# A compiler with only a static libstdc++ (the GPU machines' /opt/gcc) gets the system's shared one
# linked first by the build itself (cmake/NerfregDependencies.cmake).
cmake -S . -B "${BUILD_DIR}" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DNERFREG_CUDA=ON -DNERFREG_LEARNED_CORE_ONLY=ON -DNERFREG_BUILD_BENCH=OFF \
  -DTorch_DIR="${TORCH_DIR}" -DCMAKE_CUDA_COMPILER="${NVCC}" -DCUDAToolkit_ROOT="${CUDA_ROOT}" \
  -DCMAKE_CUDA_ARCHITECTURES="${CUDA_ARCHS:-native}" >"${LOGS}/configure.log" 2>&1 ||
  { tail -n 40 "${LOGS}/configure.log" >&2; fail "configure failed (${LOGS}/configure.log)"; }
# -k 0: every compile error of one run, not the first (a GPU machine's time is scarce).
cmake --build "${BUILD_DIR}" -j "${JOBS}" -- -k 0 >"${LOGS}/build.log" 2>&1 ||
  { grep -B2 -A12 -E "error:|FAILED:" "${LOGS}/build.log" | head -n 150 >&2; fail "build failed (${LOGS}/build.log)"; }
build_seconds=$(( $(date +%s) - build_start ))
echo "gpu_check: built ${BUILD_DIR} in ${build_seconds} s"
if [ "${GPU_BUILD_ONLY:-0}" = 1 ]; then exit 0; fi

# 2. The CUDA cases alone, first: they must run, not skip, and they are what a short lease is for.
cuda_rc=0
"${BUILD_DIR}/src/nerfreg/nerf/nerfreg_nerf_kernels_test" --gtest_filter='*HashEncodingDevice*cuda_*:*VolumeRenderingDevice*/cuda:*NerfTrainDevice*/cuda' >"${LOGS}/cuda_tests.log" 2>&1 || cuda_rc=$?
cuda_ran=$(grep -c '^\[       OK \]' "${LOGS}/cuda_tests.log" || true)
cuda_skipped=$(grep -c '^\[  SKIPPED \]' "${LOGS}/cuda_tests.log" || true)
echo "gpu_check: CUDA kernel tests: ${cuda_ran} passed, ${cuda_skipped} skipped, exit ${cuda_rc}"
# Data-parallel training on NCCL: two processes, one GPU each, all-reduce and broadcast on the
# devices (docs/distributed.md). It needs 2 GPUs; on fewer it skips and the check says so.
gpu_count=$(nvidia-smi --query-gpu=name --format=csv,noheader | wc -l)
nccl_rc=0
"${BUILD_DIR}/src/nerfreg/dist/nerfreg_dist_test" --gtest_filter='DistGroupNccl.*:ProcessDevice.*' >"${LOGS}/nccl_tests.log" 2>&1 || nccl_rc=$?
nccl_ran=$(grep -c '^\[       OK \] DistGroupNccl' "${LOGS}/nccl_tests.log" || true)
nccl_skipped=$(grep -c '^\[  SKIPPED \] DistGroupNccl' "${LOGS}/nccl_tests.log" || true)
echo "gpu_check: NCCL test (${gpu_count} GPUs): ${nccl_ran} passed, ${nccl_skipped} skipped, exit ${nccl_rc}"

# 3. Timings.
quick=()
if [ "${GPU_QUICK:-0}" = 1 ]; then quick=(--quick); fi
BENCH=${BUILD_DIR}/bench/nerfreg_gpu_bench
# A timing that fails is reported in gpu.json; the tests still run.
bench_rc=0
"${BENCH}" --device cuda --work "${BUILD_DIR}/gpu_bench_work" --out "${LOGS}/bench_cuda.json" "${quick[@]}" \
  --only "${GPU_BENCH:-hash,nerf100,nerf800,reg,dbarf}" \
  2>&1 | tee "${LOGS}/bench_cuda.log" || bench_rc=$?
"${BENCH}" --device cpu --only hash --out "${LOGS}/bench_cpu_hash.json" "${quick[@]}" 2>&1 |
  tee "${LOGS}/bench_cpu.log" || bench_rc=$?

# 4. The paper DReg network on blocks made here (the renders were carried; issue 24, item 6).
dreg_rc=0
if [ -n "${GPU_DREG_DATA:-}" ]; then
  [ -f "${GPU_DREG_DATA}/test/pairs.json" ] || fail "GPU_DREG_DATA=${GPU_DREG_DATA}: expected train/, val/, test/ of reg make-data --render-only"
  # shellcheck disable=SC2086  # GPU_DREG_ARGS is a list of flags
  "${BUILD_DIR}/bench/nerfreg_gpu_dreg" --data "${GPU_DREG_DATA}" --device cuda --work "${BUILD_DIR}/gpu_dreg_work" \
    --out "${LOGS}/gpu_dreg.json" ${GPU_DREG_ARGS:-} 2>&1 | tee "${LOGS}/gpu_dreg.log" || dreg_rc=$?
fi

# 5. The nerfreg binary's commands on the GPU, as users run them (the learned-core build has the
# commands of its layers: exe/commands.h).
cli_rc=0
CLI_DATA=${GPU_CLI_DATA:-}
if [ -z "${CLI_DATA}" ] && [ -n "${GPU_DREG_DATA:-}" ]; then
  CLI_DATA=$(find "${GPU_DREG_DATA}/test" -path '*/nerf/data/block_0' -type d | sort | head -n 1)
fi
if [ -n "${CLI_DATA}" ]; then
  cli_pairs=()
  if [ -n "${GPU_DREG_DATA:-}" ] && [ -f "${GPU_DREG_DATA}/train/pairs_gpu.json" ]; then
    cli_pairs=("${GPU_DREG_DATA}/train/pairs_gpu.json")
  fi
  PYTHON="${PYTHON}" bash scripts/cli_device_check.sh "${BUILD_DIR}/nerfreg" "${CLI_DATA}" "${BUILD_DIR}/cli_check" cuda \
    "${LOGS}/cli_cuda.json" "${cli_pairs[@]}" 2>&1 | tee "${LOGS}/cli_cuda.log" || cli_rc=$?
fi

# 5b. DBARF's paper configuration pretrained on carried scenes, for a fixed time (resumable).
dbarf_rc=0
if [ -n "${GPU_DBARF_DATA:-}" ]; then
  PYTHON="${PYTHON}" DBARF_TRAIN_SECONDS="${GPU_DBARF_SECONDS:-240}" bash scripts/dbarf_device_train.sh \
    "${BUILD_DIR}/nerfreg" "${GPU_DBARF_DATA}" "${LOGS}/dbarf_paper" cuda "${LOGS}/dbarf_paper.json" 2>&1 |
    tee "${LOGS}/dbarf_paper.log" || dbarf_rc=$?
fi

# 6. All of the learned core's tests, last: the longest step, and the one a short lease can do without.
tests_rc=0
if [ "${GPU_TESTS:-1}" = 0 ]; then
  echo "gpu_check: GPU_TESTS=0: the learned core's tests were not run" | tee "${LOGS}/ctest.log"
elif [ "${GPU_SKIP_TESTS:-0}" = 1 ] && [ -f "${LOGS}/ctest.log" ]; then
  echo "gpu_check: GPU_SKIP_TESTS=1: the tests' logs of the last run in ${LOGS} are reported again"
  grep -q "tests passed, 0 tests failed\|100% tests passed" "${LOGS}/ctest.log" || tests_rc=8
else
ctest --test-dir "${BUILD_DIR}" --output-on-failure -j "${GPU_CTEST_JOBS:-4}" --timeout "${GPU_CTEST_TIMEOUT:-900}" >"${LOGS}/ctest.log" 2>&1 || tests_rc=$?
fi
tests_summary=$(grep -E "tests passed|tests failed" "${LOGS}/ctest.log" | tail -n 1 || true)
# A backtrace of each failed test (cuda-gdb also debugs host code; the GPU images have no gdb), so
# one GPU session is enough to see where a crash is. The test binary is the command's *_test
# (the first command word was cmake itself there on 2026-11-26).
if [ "${tests_rc}" -ne 0 ] && command -v cuda-gdb >/dev/null; then
  : >"${LOGS}/backtraces.log"
  grep -E "^[[:space:]]+[0-9]+ - .* \((Failed|Subprocess aborted|SEGFAULT|Exception)\)" "${LOGS}/ctest.log" |
    sed -E 's/^[[:space:]]+[0-9]+ - (.*) \(.*\)$/\1/' | head -n 8 | while read -r name; do
    binary=$(ctest --test-dir "${BUILD_DIR}" -N -V -R "^${name}\$" 2>/dev/null | sed -n 's/.*Test command: \([^ ]*_test\).*/\1/p' | head -n 1)
    [ -n "${binary}" ] || continue
    { echo "=== ${name}"; timeout 120 cuda-gdb -batch -ex run -ex bt --args "${binary}" --gtest_filter="${name}" 2>&1 | tail -n 40; } \
      >>"${LOGS}/backtraces.log" || true
  done
  echo "gpu_check: backtraces of the failed tests in ${LOGS}/backtraces.log"
fi
echo "gpu_check: tests: ${tests_summary:-see ${LOGS}/ctest.log}"
# 7. results/gpu.json.
mkdir -p "$(dirname "${RESULTS}")"
"${PYTHON}" - "${RESULTS}" "${LOGS}" <<PY
import json, os, subprocess, sys, datetime
out, logs = sys.argv[1], sys.argv[2]
def load(name):
    try:
        with open(os.path.join(logs, name)) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        return {"error": str(e)}
commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
result = {
    "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
    "commit": commit,
    "command": "bash scripts/gpu_check.sh",
    "gpu": "${GPU_NAME}",
    "driver": "${DRIVER}",
    "torch": "${TORCH_VERSION}",
    "torch_cuda": "${TORCH_CUDA}",
    "cpu_threads": os.cpu_count(),
    "build_seconds": ${build_seconds},
    "tests": {"exit_code": ${tests_rc}, "summary": "${tests_summary}"},
    "cuda_kernel_tests": {"passed": ${cuda_ran}, "skipped": ${cuda_skipped}, "exit_code": ${cuda_rc}},
    "nccl_test": {"gpus": ${gpu_count}, "passed": ${nccl_ran}, "skipped": ${nccl_skipped}, "exit_code": ${nccl_rc}},
    "quick": "${GPU_QUICK:-0}" == "1",
    "cuda": load("bench_cuda.json"),
    "bench_exit_code": ${bench_rc},
    "cpu_hash_encoding": load("bench_cpu_hash.json").get("hash_encoding"),
}
if "${GPU_DREG_DATA:-}":
    result["dreg_paper_on_gpu_blocks"] = dict(load("gpu_dreg.json"), exit_code=${dreg_rc}, args="${GPU_DREG_ARGS:-}")
if "${CLI_DATA}":
    result["cli"] = dict(load("cli_cuda.json"), exit_code=${cli_rc}, data="${CLI_DATA}")
if "${GPU_DBARF_DATA:-}":
    result["dbarf_paper"] = dict(load("dbarf_paper.json"), exit_code=${dbarf_rc}, data="${GPU_DBARF_DATA:-}")
if "${GPU_TESTS:-1}" == "0":
    result["tests"] = {"exit_code": None, "summary": "not run (GPU_TESTS=0)"}
tmp = out + ".tmp"
with open(tmp, "w") as f:
    json.dump(result, f, indent=2)
    f.write("\n")
os.replace(tmp, out)
print("gpu_check: wrote " + out)
PY
if [ "${tests_rc}" -ne 0 ] || [ "${cuda_rc}" -ne 0 ] || [ "${cuda_skipped}" -ne 0 ] || [ "${bench_rc}" -ne 0 ] ||
  [ "${dreg_rc}" -ne 0 ] || [ "${cli_rc}" -ne 0 ] || [ "${dbarf_rc}" -ne 0 ]; then
  fail "tests or timings failed, or the CUDA cases skipped (${LOGS}/ctest.log, ${LOGS}/cuda_tests.log)"
fi
if [ "${nccl_rc}" -ne 0 ] || { [ "${gpu_count}" -ge 2 ] && [ "${nccl_ran}" -ne 1 ]; }; then
  fail "the NCCL test failed, or skipped on ${gpu_count} GPUs (${LOGS}/nccl_tests.log)"
fi
