#!/usr/bin/env bash
# Downloads, here, the Debian packages the learned core builds against that a GPU machine without
# network may lack (header libraries, fmt / spdlog, GoogleTest, zlib, libexif, stb, Gloo's and Open3D's headers), into a folder
# that travels with the working tree (default .gpudeps/, ignored by git, ~4 MB). scripts/gpu_check.sh
# unpacks them under /tmp on the GPU machine when GPU_DEPS names that folder:
#   bash scripts/gpu_deps.sh && GPU_DEPS=.gpudeps bash scripts/gpu_check.sh   # (there)
# The packages are Debian's (bookworm) builds, run on a glibc at least as new as bookworm's.
set -euo pipefail
cd "$(dirname "$0")/.."
DIR=${GPU_DEPS:-.gpudeps}
PACKAGES=(libeigen3-dev nlohmann-json3-dev libcli11-dev libfmt-dev libfmt9 libspdlog-dev libspdlog1.10
          libgtest-dev libgmock-dev zlib1g-dev zlib1g libexif-dev libexif12 libgloo-dev libstb-dev libstb0
          libopen3d-dev)  # libopen3d-dev: headers only (nerf/mesh_export.cc reads its marching-cubes tables)
mkdir -p "${DIR}"
# apt-get download writes into the current folder; as root it warns that _apt cannot, harmlessly.
(cd "${DIR}"; apt-get download "${PACKAGES[@]}" 2>&1 | { grep -v "unsandboxed as root" || true; })
count=$(find "${DIR}" -name '*.deb' | wc -l)
[ "${count}" -ge "${#PACKAGES[@]}" ] || { echo "error: ${DIR}: expected ${#PACKAGES[@]} .deb files, found ${count}" >&2; exit 2; }
echo "gpu_deps: ${count} packages in ${DIR} ($(du -sh "${DIR}" | cut -f1))"
