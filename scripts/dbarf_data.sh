#!/usr/bin/env bash
# Renders the DBARF pose-network data: procedural forward-facing scenes (20 views, 128x96, every 8th
# a test view), with ground-truth cameras in each transforms.json.
#   train: seeds TRAIN_FIRST .. TRAIN_FIRST + TRAIN_COUNT - 1 (default 2001-2300)
#   val:   seeds VAL_FIRST .. VAL_FIRST + VAL_COUNT - 1 (default 3001-3012): choose models and
#          settings on these
#   test:  seeds 201-203 are the held-out test scenes (bench/dbarf_novel_views.sh): never rendered
#          here, never trained or chosen on.
# Writes DATA/train_SEED/, DATA/val_SEED/ and the lists DATA/train.txt, DATA/val.txt (one
# transforms.json a line). Scenes already rendered are kept, so re-running extends or resumes.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
DATA=${DATA:-data/dbarf_poses}
TRAIN_FIRST=${TRAIN_FIRST:-2001}
TRAIN_COUNT=${TRAIN_COUNT:-300}
VAL_FIRST=${VAL_FIRST:-3001}
VAL_COUNT=${VAL_COUNT:-12}
VIEWS=${VIEWS:-20}
TRAJECTORY=${TRAJECTORY:-forward}
overlaps() { [ "$1" -le 203 ] && [ "$2" -ge 201 ]; }
if overlaps "$TRAIN_FIRST" $((TRAIN_FIRST + TRAIN_COUNT - 1)) || overlaps "$VAL_FIRST" $((VAL_FIRST + VAL_COUNT - 1)); then
  echo "error: seeds 201-203 are the test scenes: choose train / val ranges without them" >&2
  exit 2
fi
mkdir -p "$DATA"
render() {  # SPLIT SEED
  local d=$DATA/$1_$2
  [ -f "$d/transforms.json" ] || "$BIN" render --procedural "$2" --trajectory "$TRAJECTORY" --views "$VIEWS" \
    --test-every 8 --quiet --out "$d" --force
  echo "$d/transforms.json"
}
: > "$DATA/val.txt.tmp"
for seed in $(seq "$VAL_FIRST" $((VAL_FIRST + VAL_COUNT - 1))); do render val "$seed" >> "$DATA/val.txt.tmp"; done
mv "$DATA/val.txt.tmp" "$DATA/val.txt"
: > "$DATA/train.txt.tmp"
for seed in $(seq "$TRAIN_FIRST" $((TRAIN_FIRST + TRAIN_COUNT - 1))); do render train "$seed" >> "$DATA/train.txt.tmp"; done
mv "$DATA/train.txt.tmp" "$DATA/train.txt"
echo "$(wc -l < "$DATA/train.txt") train scenes, $(wc -l < "$DATA/val.txt") validation scenes in $DATA"
