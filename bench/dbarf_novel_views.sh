#!/usr/bin/env bash
# Novel views from unposed images: `nerfreg dbarf eval` on held-out procedural forward-facing scenes
# (20 images, 128x96, every 8th a test view; seeds never used for training or tests). Every image
# is posed from the pixels; each test view is rendered at its ESTIMATED camera from its view-graph
# neighbours among the training views. Rows: the pretrained weights as shipped, and the same after
# `dbarf finetune` on the scene's training views (FINETUNE_STEPS, default 200, in stages of
# FINETUNE_STAGE_STEPS, default 50: pose, NeRF, pose, joint; the original's 10k-step stages would
# leave a short finetune in the pose stage, which does not change the rendering).
# Usage: bench/dbarf_novel_views.sh [WORK_DIR]   (needs build/nerfreg and models/dbarf_cpu.pt)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
WEIGHTS=${WEIGHTS:-$ROOT/models/dbarf_cpu.pt}
WORK=${1:-$(mktemp -d /tmp/dbarf_novel_views.XXXXXX)}
SEEDS=${SEEDS:-"201 202 203"}
FINETUNE_STEPS=${FINETUNE_STEPS:-200}
FINETUNE_STAGE_STEPS=${FINETUNE_STAGE_STEPS:-50}
mkdir -p "$WORK"

row() {  # SCENE LABEL EVAL_JSON SECONDS_EXTRA
  python3 - "$@" <<'PY'
import json, sys
scene, label, path, extra = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
j = json.load(open(path))
print("%-6s %-22s %4d/%-3d %9.4f %8.3f %7.2f %7.4f %8.1f" % (scene, label, j["posed"], j["images"],
      j["rotation_deg_median"], j["center_percent_median"], j["psnr_mean"], j["ssim_mean"], j["seconds"] + extra))
PY
}

printf "%-6s %-22s %8s %9s %8s %7s %7s %8s\n" scene weights posed "rot deg" "ctr %" PSNR SSIM "wall s"
for seed in $SEEDS; do
  data=$WORK/scene_$seed
  [ -f "$data/transforms.json" ] || "$NERFREG" render --procedural "$seed" --trajectory forward --views 20 \
    --test-every 8 --quiet --out "$data" --force
  "$NERFREG" dbarf eval "$data/transforms.json" --weights "$WEIGHTS" --quiet --force --out "$WORK/eval_$seed" >/dev/null
  row "$seed" pretrained "$WORK/eval_$seed/eval.json" 0
  t0=$(date +%s.%N)
  "$NERFREG" dbarf finetune "$data/transforms.json" --weights "$WEIGHTS" --steps "$FINETUNE_STEPS" --stage-steps "$FINETUNE_STAGE_STEPS" --quiet --force \
    --out "$WORK/ft_$seed.pt" >/dev/null
  t1=$(date +%s.%N)
  "$NERFREG" dbarf eval "$data/transforms.json" --weights "$WORK/ft_$seed.pt" --quiet --force --out "$WORK/eval_ft_$seed" >/dev/null
  row "$seed" "finetuned ${FINETUNE_STEPS}" "$WORK/eval_ft_$seed/eval.json" "$(python3 -c "print($t1 - $t0)")"
done
echo "work dir: $WORK; load average: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
