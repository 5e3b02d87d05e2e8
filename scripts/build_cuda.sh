#!/usr/bin/env bash
# `make cuda`: all of nerfreg (every library, build-cuda/nerfreg, the tests) with the CUDA kernels,
# against a CUDA LibTorch, in its own build folder; `make cuda-core`: the learned core alone (util,
# geometry, data, dist, nerf, reg, reg_train, dbarf, their tests and a nerfreg with their commands),
# for a machine without Embree, Open3D, Ceres or OpenCV. Compiles and links on a machine without a
# GPU; the CUDA tests skip there.
#
#   TORCH_DIR        a CUDA LibTorch's TorchConfig.cmake folder (default: the pinned PyPI wheel,
#                    fetched once by scripts/fetch_libtorch.sh)
#   CUDA_SCOPE       full (default) or core
#   CUDA_BUILD_DIR   build folder (default build-cuda, build-cuda-core for core; `make test`'s
#                    unoptimised compile check: build-cuda-check)
#   CUDA_ARCHS       CMAKE_CUDA_ARCHITECTURES (default 90-real;90-virtual: H100, PTX for newer)
#   CUDA_TARGETS     build only these targets (default: all). `make test` builds the two binaries
#                    and the kernels' tests: the other tests are the CPU build's, compiled there
#   JOBS, CMAKE_FLAGS as for `make build`
#   CUDA_IF_TOOLKIT  1: a machine without nvcc skips the build with a message instead of failing
#                    (`make test`, which compiles and links the CUDA build wherever the toolkit is)
set -euo pipefail
cd "$(dirname "$0")/.."

SCOPE=${CUDA_SCOPE:-full}
case "${SCOPE}" in
  full) CORE_ONLY=OFF DEFAULT_DIR=build-cuda ;;
  core) CORE_ONLY=ON DEFAULT_DIR=build-cuda-core ;;
  *)
    echo "error: CUDA_SCOPE: ${SCOPE}: expected full or core" >&2
    exit 2
    ;;
esac
BUILD_DIR=${CUDA_BUILD_DIR:-${DEFAULT_DIR}}
JOBS=${JOBS:-$(nproc)}
TORCH_DIR=${TORCH_DIR:-}

NVCC=${CUDACXX:-}
if [ -z "${NVCC}" ]; then
  NVCC=$(command -v nvcc || true)
fi
for candidate in /usr/local/cuda/bin/nvcc /usr/local/cuda-*/bin/nvcc; do
  if [ -z "${NVCC}" ] && [ -x "${candidate}" ]; then NVCC=${candidate}; fi
done
if [ -z "${NVCC}" ]; then
  if [ "${CUDA_IF_TOOLKIT:-0}" = 1 ]; then
    echo "make cuda: skipped: this machine has no CUDA toolkit (nvcc)"
    exit 0
  fi
  echo "error: nvcc: expected the CUDA toolkit (nvcc on PATH, CUDACXX, or /usr/local/cuda)" >&2
  exit 2
fi

if [ -z "${TORCH_DIR}" ]; then
  TORCH_DIR=$(bash scripts/fetch_libtorch.sh)
fi
if [ ! -f "${TORCH_DIR}/TorchConfig.cmake" ]; then
  echo "error: TORCH_DIR: ${TORCH_DIR}: expected a folder holding TorchConfig.cmake" >&2
  exit 2
fi
CUDA_ROOT=$(dirname "$(dirname "$(readlink -f "${NVCC}")")")

start=$(date +%s)
# shellcheck disable=SC2086  # CMAKE_FLAGS is a list of flags
cmake -S . -B "${BUILD_DIR}" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DNERFREG_CUDA=ON -DNERFREG_LEARNED_CORE_ONLY="${CORE_ONLY}" -DNERFREG_BUILD_BENCH=OFF \
  -DTorch_DIR="${TORCH_DIR}" -DCMAKE_CUDA_COMPILER="${NVCC}" -DCUDAToolkit_ROOT="${CUDA_ROOT}" \
  -DCMAKE_CUDA_ARCHITECTURES="${CUDA_ARCHS:-90-real;90-virtual}" ${CMAKE_FLAGS:-}
# shellcheck disable=SC2086  # CUDA_TARGETS is a list of targets
cmake --build "${BUILD_DIR}" -j "${JOBS}" ${CUDA_TARGETS:+--target ${CUDA_TARGETS}}
echo "make cuda: built ${BUILD_DIR} (${SCOPE}) in $(( $(date +%s) - start )) s (Torch_DIR=${TORCH_DIR})"
