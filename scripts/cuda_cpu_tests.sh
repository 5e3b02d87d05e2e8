#!/usr/bin/env bash
# Runs the CUDA build's tests on the CPU of a machine with no GPU and no CUDA runtime from pip
# (docs/gpu.md): every test of `make cuda` against LibTorch 2.11, the CUDA cases skipping.
#   bash scripts/cuda_cpu_tests.sh [BUILD_DIR (default build-cuda)] [ctest flags...]
# The wheel's libtorch_cuda.so names three libraries that pip installs beside PyTorch and the CUDA
# toolkit lacks (cuFile, cuSPARSELt, NVSHMEM); PyPI's mirror here has only placeholders of them.
# The loader needs them before main() runs, and nothing on the CPU calls them, so this script
# builds empty libraries of those names (NVSHMEM's with its symbol version) in a temporary folder
# and puts it on LD_LIBRARY_PATH. A call into one would stop the process with a symbol lookup
# error, not pass quietly. On a machine with PyTorch installed they are not needed.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${1:-build-cuda}
shift || true
[ -f "${BUILD_DIR}/CTestTestfile.cmake" ] || { echo "error: ${BUILD_DIR}: expected a build folder (make cuda)" >&2; exit 2; }
STUBS=$(mktemp -d)
trap 'rm -rf "${STUBS}"' EXIT
echo "NVSHMEM { };" >"${STUBS}/nvshmem.map"
for soname in libcufile.so.0 libcusparseLt.so.0 libnvshmem_host.so.3; do
  version=()
  if [ "${soname}" = libnvshmem_host.so.3 ]; then version=(-Wl,--version-script="${STUBS}/nvshmem.map"); fi
  echo "" | cc -shared -x c - -o "${STUBS}/${soname}" -Wl,-soname,"${soname}" "${version[@]}"
done
export LD_LIBRARY_PATH="${STUBS}${LD_LIBRARY_PATH:+:${LD_LIBRARY_PATH}}"
ctest --test-dir "${BUILD_DIR}" --output-on-failure -j "${JOBS:-$(nproc)}" --timeout 400 "$@"
