#!/usr/bin/env bash
# DBARF's pose network trained self-supervised from the identity on one scene (the paper's per-scene
# finetune: the SfM loss alone, no pose or depth labels, --pose-init network), on held-out LLFF-like
# renders (hand-held motion, layered depth: render --trajectory llff, 20 views at 128x96). Each
# variant starts from WEIGHTS and trains STEPS steps on the scene, then `dbarf eval-net` scores its
# relative poses on that scene's pairs against the render's cameras (the truth is used for scoring
# only). Variants:
#   whole       WEIGHTS as they are (the original's finetune from pretrained weights)
#   fresh       --fresh-pose-heads: WEIGHTS' encoders, heads and update blocks drawn afresh (the
#               original starts from ImageNet encoders and fresh heads)
#   whole_pyr, fresh_pyr   the same with --sfm-levels 4 (the photometric term over a 4-level pyramid)
# Settings were chosen on dev scenes 2001, 3001, 3002 (docs/notes/2026-11-30-dbarf-fresh-heads-pyramid.md);
# the default SEEDS are scenes never used for that.
# Writes OUT.md and OUT.json. Runs JOBS trainings at a time, each on one thread.
# Usage: bench/dbarf_self_supervised.sh [WORK_DIR]
#   (env: NERFREG, OUT, SEEDS, STEPS, WEIGHTS, VARIANTS, JOBS, LR)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
WORK=${1:-$(mktemp -d /tmp/dbarf_self_supervised.XXXXXX)}
OUT=${OUT:-$ROOT/results/dbarf_self_supervised}
SEEDS=${SEEDS:-"5301 5302 5303 5304"}
STEPS=${STEPS:-800}
WEIGHTS=${WEIGHTS:-$ROOT/models/dbarf_pose_cpu.pt}
VARIANTS=${VARIANTS:-"whole fresh whole_pyr fresh_pyr"}
JOBS=${JOBS:-2}
LR=${LR:-2e-4}
mkdir -p "$WORK" "$(dirname "$OUT")"
start=$(date +%s)

for s in $SEEDS; do
  [ -f "$WORK/scene_$s/transforms.json" ] && continue
  "$NERFREG" render --procedural "$s" --trajectory llff --views 20 --material textured --spread 0 --test-every 8 \
    --out "$WORK/scene_$s" --force >/dev/null
done

run_one() {  # VARIANT SEED
  local v=$1 s=$2 d="$WORK/$1_$2" flags=()
  case "$v" in
    whole) ;;
    fresh) flags=(--fresh-pose-heads) ;;
    whole_pyr) flags=(--sfm-levels 4) ;;
    fresh_pyr) flags=(--fresh-pose-heads --sfm-levels 4) ;;
    *) echo "error: VARIANTS: $v: expected whole, fresh, whole_pyr or fresh_pyr" >&2; return 2 ;;
  esac
  mkdir -p "$d"
  local t0; t0=$(date +%s)
  OMP_NUM_THREADS=1 "$NERFREG" dbarf pretrain "$WORK/scene_$s/transforms.json" --config cpu --pose-init network \
    --weights "$WEIGHTS" --stage-steps 1000000000 --steps "$STEPS" --supervise-poses 0 --supervise-depth 0 \
    --augment-blur 0 --auto-mask true --rotation-scale 1 --lr-pose "$LR" --lr-decay-steps 20000 \
    --checkpoint-every 200 --scene-cameras ground-truth --out "$d/pose.pt" --force "${flags[@]}" >"$d/train.log" 2>&1
  echo $(( $(date +%s) - t0 )) >"$d/seconds"
  OMP_NUM_THREADS=1 "$NERFREG" dbarf eval-net "$WORK/scene_$s/transforms.json" --weights "$d/pose.pt" \
    --scene-cameras ground-truth >"$d/eval.txt" 2>&1
}

# The starting weights on each scene (the identity's errors are in every eval-net line).
for s in $SEEDS; do
  OMP_NUM_THREADS=1 "$NERFREG" dbarf eval-net "$WORK/scene_$s/transforms.json" --weights "$WEIGHTS" \
    --scene-cameras ground-truth >"$WORK/start_$s.txt" 2>&1
done
total=0
for v in $VARIANTS; do for s in $SEEDS; do total=$((total + 1)); done; done
done_count=0
for v in $VARIANTS; do
  for s in $SEEDS; do
    while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do sleep 2; done
    run_one "$v" "$s" &
    done_count=$((done_count + 1))
    elapsed=$(( $(date +%s) - start ))
    echo "started $done_count/$total ($v, scene $s); elapsed ${elapsed}s" >&2
  done
done
wait

python3 - "$WORK" "$OUT" "$SEEDS" "$VARIANTS" "$STEPS" "$WEIGHTS" "$LR" "$(( $(date +%s) - start ))" <<'EOF'
import json, os, sys, statistics, datetime
work, out, seeds, variants, steps, weights, lr, seconds = sys.argv[1:]
seeds, variants = seeds.split(), variants.split()

def mean_row(path):
    # eval-net's last line: mean  start_rot net_rot start_dir net_dir disparity |t|/|t*|
    for line in open(path):
        if line.startswith("mean"):
            f = line.split()[1:]
            return dict(zip(["identity_rot", "rot", "identity_dir", "dir", "disparity", "t_ratio"], map(float, f)))
    raise SystemExit(f"error: {path}: expected a 'mean' line from dbarf eval-net")

rows = []
for s in seeds:
    st = mean_row(f"{work}/start_{s}.txt")
    rows.append({"scene": s, "variant": "identity", "rot": st["identity_rot"], "dir": st["identity_dir"]})
    rows.append({"scene": s, "variant": "start", **{k: st[k] for k in ("rot", "dir", "disparity", "t_ratio")}})
    for v in variants:
        d = f"{work}/{v}_{s}"
        r = mean_row(f"{d}/eval.txt")
        rows.append({"scene": s, "variant": v, "seconds": int(open(f"{d}/seconds").read()),
                     **{k: r[k] for k in ("rot", "dir", "disparity", "t_ratio")}})
cmd = (f"NERFREG={os.environ.get('NERFREG', 'build/nerfreg')} SEEDS=\"{' '.join(seeds)}\" STEPS={steps} "
       f"VARIANTS=\"{' '.join(variants)}\" bench/dbarf_self_supervised.sh")
json.dump({"command": cmd, "weights": weights, "steps": int(steps), "lr_pose": lr, "seconds": int(seconds),
           "date": datetime.datetime.now().isoformat(timespec="seconds"), "rows": rows},
          open(out + ".json.tmp", "w"), indent=1)
os.replace(out + ".json.tmp", out + ".json")
names = {"identity": "identity (no network)", "start": "`" + os.path.basename(weights) + "` from the identity, untrained for the scene",
         "whole": "whole: finetuned as it is", "fresh": "fresh: `--fresh-pose-heads`",
         "whole_pyr": "whole, `--sfm-levels 4`", "fresh_pyr": "fresh, `--sfm-levels 4`"}
order = ["identity", "start"] + variants
md = [f"# DBARF's pose network self-supervised on one scene, from the identity", "",
      f"Written by `{cmd}` ({datetime.date.today()}; the whole bench {seconds} s on this machine, "
      f"{os.cpu_count()} cores, two trainings at a time on one thread each). Each run: {steps} steps of "
      f"`dbarf pretrain --pose-init network --supervise-poses 0 --supervise-depth 0 --lr-pose {lr}` on the scene alone "
      f"(the SfM loss, no labels) from `{os.path.basename(weights)}`; then `dbarf eval-net` on the same scene's pairs "
      "(the render's cameras used for scoring only). Scenes: held-out LLFF-like renders (`render --trajectory llff`, "
      "20 views, 128x96), never used to choose the settings.", "",
      "Mean over each scene's pairs: rotation error (deg), translation direction error (deg; 90 is chance), mean "
      "normalised disparity (0: the far bound), sum |t| / sum |t_true|.", "",
      "| variant | " + " | ".join(f"scene {s}: rot / dir" for s in seeds) + " | median rot | median dir | disparity | \\|t\\| ratio |",
      "|---|" + "---|" * (len(seeds) + 4)]
for v in order:
    rs = [r for r in rows if r["variant"] == v]
    if not rs: continue
    cells = [f"{r['rot']:.3f} / {r['dir']:.1f}" for r in rs]
    disp = f"{statistics.median(r['disparity'] for r in rs):.3f}" if "disparity" in rs[0] else "-"
    tr = f"{statistics.median(r['t_ratio'] for r in rs):.3f}" if "t_ratio" in rs[0] else "-"
    md.append(f"| {names.get(v, v)} | " + " | ".join(cells) +
              f" | {statistics.median(r['rot'] for r in rs):.3f} | {statistics.median(r['dir'] for r in rs):.1f} | {disp} | {tr} |")
open(out + ".md.tmp", "w").write("\n".join(md) + "\n")
os.replace(out + ".md.tmp", out + ".md")
print("\n".join(md))
EOF
