#!/usr/bin/env bash
# Issue 3's target: a block of an assimp-testmodels mesh, orbit at 100x100 (~57 train views),
# fast preset on 2 CPU cores: test-view PSNR >= 28 dB within 120 s wall. Renders the two
# DReg-NeRF blocks of the mesh, trains each with --iters (default 500) and prints a table.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
OUT=${1:-/tmp/nerf_block_target}
MESH=${MESH:-/usr/share/assimp/models/OBJ/spider.obj}
ITERS=${ITERS:-500}
rm -rf "$OUT"
$BIN render --mesh "$MESH" --blocks 2 --size 100 --seed 7 --out "$OUT/data" --quiet >/dev/null
printf "%-8s %6s %8s %12s %10s %12s\n" block views iters "seconds" "test PSNR" "peak RSS MB"
for k in 0 1; do
  /usr/bin/time -f "%M" -o "$OUT/rss_$k" $BIN nerf train "$OUT/data/block_$k" --out "$OUT/block_$k.ckpt" --preset fast \
    --iters "$ITERS" --quiet >/dev/null
  views=$(grep -c '"split": "train"' "$OUT/data/block_$k/transforms.json" || true)
  python3 - "$OUT/block_$k.ckpt.json" "$k" "$views" "$ITERS" "$(cat "$OUT/rss_$k")" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print("%-8s %6s %8s %12.1f %10.2f %12.0f" % (sys.argv[2], sys.argv[3], sys.argv[4], j["seconds"], j["psnr_test"], int(sys.argv[5]) / 1024))
PY
done
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) cores"
