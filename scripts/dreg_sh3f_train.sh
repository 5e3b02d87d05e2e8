#!/usr/bin/env bash
# Fine-tunes the shipped DReg-NeRF `cpu` weights (models/dreg_cpu.pt) on synthesised pairs of the
# Sweet Home 3D furniture's train split (issue 46), in the frame reg register --scale free gives the
# network (--scale-augment, issue 43), validating on the val split. Trains in slices of SLICE steps
# (--stop-after, then --resume), so each slice re-reads the pairs files (a make-data still running
# adds its pairs) and its weights are kept as OUT_DIR/step_N.pt for the choice on val
# (bench/dreg_real_shapes.sh). One thread. The data: scripts/reg_data.sh's sh3f section.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
DATA=${DATA:-data/reg_sh3f}
OUT_DIR=${OUT_DIR:-runs/dreg_sh3f}
ITERS=${ITERS:-15000}
# LR: the AdamW rate (halved every 6000 steps); 2e-4 in the run of docs/notes/2026-11-29-dreg-furniture-longer.md.
SLICE=${SLICE:-500}
INIT=${INIT:-models/dreg_cpu.pt}
export OMP_NUM_THREADS=1
mkdir -p "$OUT_DIR"
opts=(--config cpu --init "$INIT" --iters "$ITERS" --lr "${LR:-1e-4}" --lr-step 6000 --move-deg 180 --mirror 0.5 --recolour 0.5
  --val-every 1000 --checkpoint-every 200 --seed 46 --quiet)
for ((stop = SLICE; stop <= ITERS; stop += SLICE)); do
  [ -f "$OUT_DIR/step_$stop.pt" ] && continue
  files=()
  for f in "$DATA"/train2 "$DATA"/train4 "$DATA"/val2; do [ -f "$f/pairs.json" ] && files+=("$f/pairs.json"); done
  resume=()
  [ -f "$OUT_DIR/dreg_cpu.pt.train" ] && resume=(--resume)
  "$BIN" reg train "${files[@]}" --out "$OUT_DIR/dreg_cpu.pt" "${opts[@]}" --stop-after "$stop" "${resume[@]}"
  cp "$OUT_DIR/dreg_cpu.pt" "$OUT_DIR/step_$stop.pt"
  cp "$OUT_DIR/dreg_cpu.pt.json" "$OUT_DIR/step_$stop.json"
done
