#!/usr/bin/env bash
# The renders a GPU machine trains DReg-NeRF's paper network from (scripts/gpu_check.sh with
# GPU_DREG_DATA; bench/gpu_dreg.cc): procedural objects rendered into 4 blocks each at 100x100 by
# `reg make-data --render-only`, nothing trained. Seeds as docs/data.md: train from the training
# objects (2000-), val 5000-5001 (held out), test 6000-6003 (the registration test set's objects).
# Only what the blocks need is kept (the whole-orbit copy of the views is dropped), ~1.7 MB an
# object, so the folder travels with the working tree (the device's carry: 64 MiB in all).
#   bash scripts/gpu_dreg_data.sh [OUT (default .gpudreg)] [TRAIN_OBJECTS (default 24)]
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-.gpudreg}
TRAIN=${2:-24}
NERFREG=${NERFREG:-build/nerfreg}
make_split() {  # split, first seed, objects
  "${NERFREG}" reg make-data --procedural "$3" --procedural-seed "$2" --mesh-pairs 0 --nerf-objects "$3" \
    --render-only --blocks 4 --image-size 100 --quiet --out "${OUT}/$1" >/dev/null
}
make_split test 6000 4
make_split val 5000 2
make_split train 2000 "${TRAIN}"
find "${OUT}" -path '*/nerf/data/images' -type d -prune -exec rm -rf {} +
find "${OUT}" -path '*/nerf/data/transforms.json' -delete
echo "gpu_dreg_data: ${OUT}: $(find "${OUT}" -name ground_truth.json | wc -l) objects, $(du -sh "${OUT}" | cut -f1)"
