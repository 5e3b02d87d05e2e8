#!/usr/bin/env bash
# Fetches the CUDA LibTorch that `make cuda` builds against, once, into a cache folder, and prints
# the folder of its TorchConfig.cmake (the value for -DTorch_DIR). The LibTorch is the one inside
# PyTorch's wheel on PyPI, pinned by version and sha256; only its lib/, include/ and share/ are
# unpacked. The wheel's CUDA runtime libraries come from pip's nvidia-* packages, which are not
# fetched: the build links against the toolkit's (see cmake/NerfregDependencies.cmake).
#
#   NERFREG_CACHE   cache folder (default ~/.cache/nerfreg)
set -euo pipefail

TORCH_VERSION=2.11.0
TORCH_CUDA=cu130
# The cp311 manylinux_2_28 x86_64 wheel (PyTorch 2.11.0 + CUDA 13.0). Any CPython tag carries the
# same LibTorch; one is pinned so the hash is one.
WHEEL=torch-${TORCH_VERSION}-cp311-cp311-manylinux_2_28_x86_64.whl
WHEEL_SHA256=7aa2f9bbc6d4595ba72138026b2074be1233186150e9292865e04b7a63b8c67a

CACHE=${NERFREG_CACHE:-${HOME}/.cache/nerfreg}
DEST=${CACHE}/libtorch-${TORCH_VERSION}-${TORCH_CUDA}
CONFIG_DIR=${DEST}/torch/share/cmake/Torch

if [ -f "${CONFIG_DIR}/TorchConfig.cmake" ]; then
  echo "${CONFIG_DIR}"
  exit 0
fi
if [ "$(uname -m)" != x86_64 ]; then
  echo "error: fetch_libtorch.sh: expected an x86_64 machine (the pinned wheel is x86_64; pass TORCH_DIR=... instead)" >&2
  exit 2
fi

mkdir -p "${CACHE}/wheels"
if [ ! -f "${CACHE}/wheels/${WHEEL}" ]; then
  echo "fetch_libtorch: downloading ${WHEEL} (~530 MB) into ${CACHE}/wheels" >&2
  python3 -m pip download "torch==${TORCH_VERSION}" --no-deps --only-binary=:all: \
    --platform manylinux_2_28_x86_64 --python-version 3.11 --implementation cp --abi cp311 \
    -d "${CACHE}/wheels" >&2
fi
echo "${WHEEL_SHA256}  ${CACHE}/wheels/${WHEEL}" | sha256sum --check --quiet - >&2 || {
  echo "error: ${CACHE}/wheels/${WHEEL}: sha256: expected ${WHEEL_SHA256} (removed; run again)" >&2
  rm -f "${CACHE}/wheels/${WHEEL}"
  exit 2
}

# Unpacked beside the final folder, then moved into place: an interrupted run leaves no half tree.
TMP=$(mktemp -d "${CACHE}/.libtorch.XXXXXX")
trap 'rm -rf "${TMP}"' EXIT
echo "fetch_libtorch: unpacking LibTorch into ${DEST}" >&2
python3 - "${CACHE}/wheels/${WHEEL}" "${TMP}" <<'PY'
import sys, zipfile
wheel, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(wheel) as z:
    names = [n for n in z.namelist() if n.startswith(("torch/lib/", "torch/include/", "torch/share/")) or n == "torch/version.py"]
    z.extractall(out, names)
PY
rm -rf "${DEST}"
mv "${TMP}" "${DEST}"
trap - EXIT
echo "${CONFIG_DIR}"
