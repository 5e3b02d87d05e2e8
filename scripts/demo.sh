#!/usr/bin/env bash
# The built-in demo: render an object, split its views into two blocks each in its own random
# frame, train a NeRF block on each, register the blocks from their fields alone, print the
# errors against the ground truth and write the pictures and an HTML report.
# Under 10 minutes on a 2-core machine (after set-up and build).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=build/nerfreg
OUT=${DEMO_OUT:-runs/demo}
MESH=${DEMO_MESH:-/usr/share/assimp/models/OBJ/spider.obj}
ITERS=${DEMO_ITERS:-500}

rm -rf "$OUT"
mkdir -p "$OUT"
echo "== 1/4 render $MESH into two blocks"
$BIN render --mesh "$MESH" --blocks 2 --size 100 --seed 7 --out "$OUT/data"

echo "== 2/4 train a NeRF block on each"
for k in 0 1; do
  $BIN nerf train "$OUT/data/block_$k" --out "$OUT/block_$k.ckpt" --preset fast --iters "$ITERS"
done

echo "== 3/4 register block 0 into block 1 (auto: DReg-NeRF and FPFH + RANSAC, each refined on the two fields, the best kept)"
# name:method:refine. auto: every method refined on the fields, the best kept; "ransac_field": FPFH
# + RANSAC with the same field refinement (like with like: what the choice adds); "ransac": the
# classical pipeline alone (FPFH + RANSAC + ICP).
RUNS="ransac_field:ransac:field ransac:ransac:icp"
[ -f models/dreg_cpu.pt ] && RUNS="auto:auto:field $RUNS"
METHODS=""
for run in $RUNS; do
  IFS=: read -r name method refine <<< "$run"
  METHODS="$METHODS $name"
  # Exit 5: a result reg register does not believe in (T.json written, "status": "untrusted"); the
  # demo compares methods, some of which fail on blocks this small, so it goes on.
  rc=0
  $BIN reg register "$OUT/block_0.ckpt" "$OUT/block_1.ckpt" --method "$method" --refine "$refine" \
    --out "$OUT/target_from_source_$name.json" || rc=$?
  [ "$rc" = 0 ] || [ "$rc" = 5 ] || exit "$rc"
done

echo "== 4/4 errors against the ground truth, pictures, report"
for m in $METHODS; do
  $BIN reg eval --pair "$OUT/target_from_source_$m.json" --ground-truth "$OUT/data/ground_truth.json" \
    --source 0 --target 1 --out "$OUT/errors_$m.json"
done
for k in 0 1; do
  $BIN nerf render "$OUT/block_$k.ckpt" --transforms "$OUT/data/block_$k/transforms.json" --out "$OUT/renders_block_$k" --quiet
  # The blocks' occupied points, named as the checkpoints: the report's 3D view of the registration.
  $BIN nerf export "$OUT/block_$k.ckpt" --points "$OUT/block_$k.ply" --quiet
done
$BIN report "$OUT" --out "$OUT/report.html" --force
echo "demo: open $OUT/report.html"
