#!/usr/bin/env bash
# Installs every Debian package nerfreg needs. Idempotent: packages already present are skipped,
# and apt is not touched at all when nothing is missing. Arguments name more packages, for a bench
# that needs data the build and tests do not (bench/real_poses.sh: visp-images-data).
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config
  # the format check of make test (scripts/check_format.sh)
  clang-format
  # learned core
  libtorch-dev libopenblas0-pthread libeigen3-dev
  # torch c10d's ProcessGroupGloo headers include Gloo's (data-parallel training, dist/)
  libgloo-dev
  # edges: ray casting, point-cloud baselines, pose graphs, image features
  libembree-dev libopen3d-dev libceres-dev libopencv-dev
  # oneDNN's headers: the SIFT matcher's integer descriptor products (its library comes with LibTorch);
  # its CMake config requires OpenCL's, only a recommendation of libdnnl-dev that
  # --no-install-recommends skips
  libdnnl-dev ocl-icd-opencl-dev
  # header-only and small utilities
  nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev libstb-dev zlib1g-dev
  # photos' EXIF (focal length, sensor resolution, orientation; util/exif.cc)
  libexif-dev
  # tests and benchmarks
  googletest libgtest-dev libgmock-dev libbenchmark-dev
  # the HTML report is checked in a real browser; its 3D views inline three.js
  chromium libjs-three
  # fuzzing (libFuzzer) and the sanitizer build
  clang libclang-rt-14-dev
  # meshes used by tests and training data (the CGAL demo meshes are reserved for independent
  # evaluation and are never installed or used here)
  assimp-testmodels openscad-testing-data
  # textured artist meshes (.sh3f) for the registration network's training data (docs/data.md)
  sweethome3d-furniture
  # COLMAP interop tests and baselines
  colmap
  "$@"
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
