#!/usr/bin/env bash
# Poses of unposed images by every method, on procedural forward-facing scenes never used in
# training (seeds 5000+): `dbarf poses --method network` (the pose network from the identity),
# the same followed by `dbarf finetune --refine-cameras` (network+finetune), `--method auto`,
# `--method classical`, and COLMAP 3.8 (CPU). Rows: 20 views at 128x96 and 320x240; sparse sets of
# 3, 4 and 5 views on a wider camera spiral (10 sets each); low-texture and repetitive scenes
# (`render --material`). Per method: images posed, sets fully posed, median rotation error,
# translation-direction error, centre error, wall time. Writes results/dbarf_poses.md and
# results/dbarf_poses.json (date, machine, command, every set's figures).
# Reduced configurations by environment: SIZES20, SEEDS20, SPARSE_VIEWS, SPARSE_SETS, SPARSE_SPREAD,
# HARD_MATERIALS, HARD_SETS, HARD_VIEWS, METHODS, FINETUNE_STEPS, FINETUNE_SCHEDULE, FINETUNE_DECAY_STEPS,
# FINETUNE_STAGE_STEPS, FINETUNE_DEPTH_BA_STEPS, FINETUNE_DEPTH_BA_SOURCES (REDUCED: a sentence saying
# so in the .md); TWO_VIEW (ransac|usac: `dbarf poses --two-view`, else the binary's default);
# OUT_MD / OUT_JSON elsewhere than results/.
# Usage: bench/dbarf_poses_bench.sh [WORK_DIR]   (needs build/nerfreg and colmap)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
exec python3 "$ROOT/bench/dbarf_poses_bench.py" "${1:-/tmp/dbarf_poses_bench}"
