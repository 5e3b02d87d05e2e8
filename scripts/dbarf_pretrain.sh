#!/usr/bin/env bash
# Makes the DBARF pretraining data and trains the shipped weights (models/dbarf_cpu.pt) the way
# they were made: 16 procedural forward-facing scenes (seeds 1001-1016; 20 views, 128x96, every 8th
# a test view kept out of training), whose cameras, depth range and view graph `dbarf pretrain`
# estimates from the images; 2400 steps of the original schedule compressed to stages of 240 steps.
# Resumable: re-running continues from OUT.train (RESUME=1) or starts over (default: refuses to
# overwrite OUT; FORCE=1 overwrites).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
DATA=${DATA:-data/dbarf}
OUT=${OUT:-runs/dbarf/dbarf_cpu.pt}
STEPS=${STEPS:-2400}
mkdir -p "$DATA" "$(dirname "$OUT")"
scenes=()
for seed in $(seq 1001 1016); do
  d=$DATA/train_$seed
  [ -f "$d/transforms.json" ] || "$BIN" render --procedural "$seed" --trajectory forward --views 20 --test-every 8 \
    --quiet --out "$d" --force
  scenes+=("$d/transforms.json")
done
flags=(--steps "$STEPS" --stage-steps 240 --joint-decay 3e-4 --checkpoint-every 100 --out "$OUT")
[ "${RESUME:-0}" = 1 ] && flags+=(--resume)
[ "${FORCE:-0}" = 1 ] && flags+=(--force)
"$BIN" dbarf pretrain "${scenes[@]}" "${flags[@]}"
