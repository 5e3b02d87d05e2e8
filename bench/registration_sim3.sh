#!/usr/bin/env bash
# Captures in different units (issue 43). Per held-out procedural object (seeds 6000+: no
# registration model was trained or chosen on them): 60 views at 64x64 split into 2 blocks, each
# in its own random frame, and the splats each block's views saw (`render --blocks 2 --splats`).
# Block 0's splats are moved by a similarity of scale S (a turn of 0.7 rad and a shift too) with
# `reg apply`, and `reg register` (default `auto`, field refinement, seed 0) registers them onto
# block 1's splats, with `--scale free` (the default) at every S and with `--scale fixed` (rigid, as
# before Sim(3)) at S = 1 and 2. Each result is scored against the truth moved by the same
# similarity (`reg eval --pair`: rotation, translation / extent 2.5) and its scale against the
# true one.
# Then trained NeRF blocks at different scales: per BLOCK_SETS entry OBJECT:SEED, `render --procedural
# OBJECT --blocks 2 --block-scale-range BLOCK_RANGE --seed SEED` (BLOCK_RANGE default 0.5,2, the
# issue's target; SEED 0: no scale range, both blocks at scale 1), each block trained as a user
# would (`nerf train`, its default 2000 iterations; BLOCK_ITERS=400 trains them as the CLI tests do,
# which leaves them too blurred to register reliably), and `reg register` (default auto, field
# refinement) run both ways (block 0 -> 1 and 1 ->
# 0: relative scales s and 1 / s) with `--scale free`; the scale-1 sets one way, with `--scale free`
# and `--scale fixed`; scored against ground_truth.json by `reg eval --pair` (extent 2.5 in the target's units
# times its block scale).
# Writes OUT_JSON (default results/registration_sim3.json) and OUT_MD (results/registration_sim3.md).
# Usage: bench/registration_sim3.sh [SEEDS (default "6000 6001 6002 6003")] [SCALES (default "0.25 0.5 1 2 4")]
#        [BLOCK_SETS (default "6000:1 6001:1 6002:1 6003:1 6000:0 6001:0 6008:2 6009:2 6010:2 6011:4 6012:7
#        6013:5": objects 6000-6003 chose the polish's coarse spread, 6008-6013 were not used to choose)]
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
SEEDS=${1:-"6000 6001 6002 6003"}
SCALES=${2:-"0.25 0.5 1 2 4"}
BLOCK_SETS=${3-"6000:1 6001:1 6002:1 6003:1 6000:0 6001:0 6008:2 6009:2 6010:2 6011:4 6012:7 6013:5"}
export BLOCK_RANGE=${BLOCK_RANGE:-0.5,2}
export BLOCK_ITERS=${BLOCK_ITERS:-2000}
# WORK given again: its renders, checkpoints and results (T.json with its exit code) are reused.
WORK=${WORK:-$(mktemp -d /tmp/registration_sim3.XXXXXX)}
OUT_JSON=${OUT_JSON:-$ROOT/results/registration_sim3.json}
OUT_MD=${OUT_MD:-$ROOT/results/registration_sim3.md}
mkdir -p "$WORK"
# free / fixed: reg register's default chain with --scale free / fixed; baseline: FPFH + RANSAC +
# ICP with scale (--method ransac --refine icp: similarity RANSAC hypotheses, then Open3D's
# point-to-point ICP with_scaling=true before the point-to-plane pass), the issue's comparison, one
# way only (--no-reverse: the classical pipeline as other tools run it).
mode_args() {
  if [ "$1" = baseline ]; then echo "--scale free --method ransac --refine icp --no-reverse"; else echo "--scale $1"; fi
}
# reg eval's table line with its rotation (printed to 3 decimals) replaced by the full value of its
# --out JSON, so the 2 deg target is judged on the pose itself (2.0003 printed as 2.000 passed).
precise_rotation() {
  local rot
  rot=$(python3 -c 'import json, sys; print("%.6f" % json.load(open(sys.argv[1]))["rotation_error_deg"])' "$2")
  echo "$1" | awk -v r="$rot" '{$2 = r; print}'
}
ROWS=$WORK/rows.txt
DREG_ROWS=$WORK/dreg_rows.txt
: > "$ROWS"
: > "$DREG_ROWS"
for seed in $SEEDS; do
  d=$WORK/o$seed
  [ -f "$d/ground_truth.json" ] || "$NERFREG" render --procedural "$seed" --blocks 2 --views 60 --size 64 --supersample 1 \
    --test-every 12 --splats --quiet --out "$d" --force
  for s in $SCALES; do
    python3 "$ROOT/bench/sim3_move.py" "$s" "$d"
    "$NERFREG" reg apply "$d/move_$s.json" "$d/block_0/splats.ply" --out "$d/s0_$s.ply" --quiet --force
    modes="free baseline"
    if [ "$s" = 1 ] || [ "$s" = 2 ]; then modes="free fixed baseline"; fi
    for mode in $modes; do
      out=$d/t_${s}_$mode.json
      rc=0
      # A result already in WORK (a WORK given again) is read back, with its exit code.
      if [ -f "$out" ] && [ -f "$out.rc" ]; then rc=$(cat "$out.rc"); else
        # shellcheck disable=SC2046
        "$NERFREG" reg register "$d/s0_$s.ply" "$d/block_1/splats.ply" $(mode_args "$mode") --seed 0 --quiet --force \
          --out "$out" > /dev/null 2>&1 || rc=$?
        echo "$rc" > "$out.rc"
      fi
      line=$("$NERFREG" reg eval --pair "$out" --ground-truth "$d/gt_$s.json" --out "$out.eval" --force 2>/dev/null |
        tail -1)
      line=$(precise_rotation "$line" "$out.eval")
      echo "$seed $s $mode $rc $line $(python3 - "$out" "$d/gt_$s.json" <<'PY'
import json, sys
t, gt = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
det = lambda m: (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                 + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
b = [x["block_from_world"] for x in gt["blocks"]]
truth = (det(b[1]) / det(b[0])) ** (1 / 3)
print(t["scale"], truth, t["seconds"], t["confidence"], t["status"], t["agreeing_candidates"] if t["agreeing_candidates"] is not None else -1)
PY
)" >> "$ROWS"
    done
    # The network alone (no refinement, no other candidate) on the same pair: whether its answer
    # depends on S once each input is normalised (the shipped weights were trained rigid).
    out=$d/dreg_$s.json
    [ -f "$out" ] || "$NERFREG" reg register "$d/s0_$s.ply" "$d/block_1/splats.ply" --method dreg --refine none \
      --seed 0 --quiet --force --out "$out" > /dev/null 2>&1 || true
    echo "$seed $s $("$NERFREG" reg eval --pair "$out" --ground-truth "$d/gt_$s.json" 2>/dev/null | tail -1)" \
      >> "$DREG_ROWS"
  done
  echo "object $seed done" >&2
done
BLOCK_ROWS=$WORK/block_rows.txt
: > "$BLOCK_ROWS"
for set in $BLOCK_SETS; do
  object=${set%%:*}
  seed=${set##*:}
  d=$WORK/blocks_${object}_$seed
  range="--block-scale-range $BLOCK_RANGE"
  if [ "$seed" = 0 ]; then range=""; fi
  # shellcheck disable=SC2086
  [ -f "$d/data/ground_truth.json" ] || "$NERFREG" render --procedural "$object" --blocks 2 --views 60 --size 64 \
    --supersample 1 --test-every 12 $range --seed "$seed" --quiet --out "$d/data" --force
  for k in 0 1; do
    [ -f "$d/b$k.ckpt" ] || "$NERFREG" nerf train "$d/data/block_$k" --out "$d/b$k.ckpt" --iters "$BLOCK_ITERS" \
      --samples 8192 --quiet
  done
  # Scaled sets both ways (s and 1 / s); the scale-1 sets one way, free against fixed.
  modes="free baseline"
  dirs=("0 1" "1 0")
  if [ "$seed" = 0 ]; then modes="free fixed baseline"; dirs=("0 1"); fi
  for dir in "${dirs[@]}"; do
    read -r a b <<< "$dir"
    for mode in $modes; do
      out=$d/t_${a}${b}_$mode.json
      rc=0
      if [ -f "$out" ] && [ -f "$out.rc" ]; then rc=$(cat "$out.rc"); else
        # shellcheck disable=SC2046
        "$NERFREG" reg register "$d/b$a.ckpt" "$d/b$b.ckpt" $(mode_args "$mode") --seed 0 --quiet --force \
          --out "$out" > /dev/null 2>&1 || rc=$?
        echo "$rc" > "$out.rc"
      fi
      # Scored against the truth of this direction (block a -> block b), not reg eval's default 0 -> 1.
      line=$("$NERFREG" reg eval --pair "$out" --ground-truth "$d/data/ground_truth.json" --source "$a" --target "$b" \
        --out "$out.eval" --force 2>/dev/null | tail -1)
      line=$(precise_rotation "$line" "$out.eval")
      echo "$object:$seed $a$b $mode $rc $line $(python3 - "$out" "$d/data/ground_truth.json" "$a" "$b" <<'PY'
import json, sys
t, gt, a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), int(sys.argv[3]), int(sys.argv[4])
det = lambda m: (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                 + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
s = [det(x["block_from_world"]) ** (1 / 3) for x in gt["blocks"]]
print(t["scale"], s[b] / s[a], s[b], t["seconds"], t["confidence"], t["status"],
      t["agreeing_candidates"] if t["agreeing_candidates"] is not None else -1)
PY
)" >> "$BLOCK_ROWS"
    done
  done
  echo "blocks $set done" >&2
done
python3 - "$ROWS" "$OUT_JSON" "$OUT_MD" "$SEEDS" "$SCALES" "$BLOCK_ROWS" "$BLOCK_SETS" "$DREG_ROWS" <<'PY'
import datetime, json, os, statistics, sys
rows_path, out_json, out_md, seeds, scales, block_rows_path, block_sets, dreg_rows_path = sys.argv[1:9]
# object S | method rot trans trans/ext success
dreg_rows = [{"seed": int(f[0]), "relative_scale": float(f[1]), "rotation_deg": float(f[3]),
              "translation_over_extent": float(f[5])} for f in (l.split() for l in open(dreg_rows_path)) if len(f) >= 6]
rows = []
for line in open(rows_path):
    f = line.split()
    # seed S mode rc | method rot trans trans/ext success | scale truth seconds confidence status agreeing
    r = {"seed": int(f[0]), "relative_scale": float(f[1]), "mode": f[2], "exit_code": int(f[3]), "method": f[4],
         "rotation_deg": float(f[5]), "translation_over_extent": float(f[7]), "scale": float(f[9]),
         "true_scale": float(f[10]), "seconds": float(f[11]), "confidence": float(f[12]), "status": f[13],
         "agreeing_candidates": int(f[14])}
    r["scale_error"] = abs(r["scale"] / r["true_scale"] - 1)
    r["success"] = r["rotation_deg"] <= 2 and r["translation_over_extent"] <= 0.02 and r["scale_error"] <= 0.01
    rows.append(r)
block_rows = []
for line in open(block_rows_path):
    f = line.split()
    # object:seed direction mode rc | method rot trans trans/ext success | scale truth target_block_scale seconds
    # confidence status agreeing
    r = {"set": f[0], "direction": f[1], "mode": f[2], "exit_code": int(f[3]), "method": f[4],
         "rotation_deg": float(f[5]), "translation": float(f[6]), "scale": float(f[9]), "true_scale": float(f[10]),
         "target_block_scale": float(f[11]), "seconds": float(f[12]), "confidence": float(f[13]), "status": f[14],
         "agreeing_candidates": int(f[15])}
    # The object's extent (2.5) in the target block's units.
    r["translation_over_extent"] = r["translation"] / (2.5 * r["target_block_scale"])
    r["scale_error"] = abs(r["scale"] / r["true_scale"] - 1)
    # The issue's target for NeRF blocks: rotation <= 2 deg, scale within 2 %.
    r["success"] = r["rotation_deg"] <= 2 and r["scale_error"] <= 0.02
    block_rows.append(r)
groups = []
for r in rows:
    if (r["relative_scale"], r["mode"]) not in groups: groups.append((r["relative_scale"], r["mode"]))
summary = []
for s, mode in groups:
    g = [r for r in rows if r["relative_scale"] == s and r["mode"] == mode]
    summary.append({"relative_scale": s, "mode": mode, "pairs": len(g), "success": sum(r["success"] for r in g),
                    "untrusted": sum(r["status"] == "untrusted" for r in g),
                    "median_rotation_deg": statistics.median(r["rotation_deg"] for r in g),
                    "median_translation_over_extent": statistics.median(r["translation_over_extent"] for r in g),
                    "median_scale_error": statistics.median(r["scale_error"] for r in g),
                    "median_seconds": statistics.median(r["seconds"] for r in g)})
date = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
machine = "%d cores, load %s" % (os.cpu_count(), open("/proc/loadavg").read().split()[0])
block_range, block_iters = os.environ["BLOCK_RANGE"], os.environ["BLOCK_ITERS"]
command = "BLOCK_RANGE=%s BLOCK_ITERS=%s bench/registration_sim3.sh \"%s\" \"%s\" \"%s\"" % (
    block_range, block_iters, seeds, scales, block_sets)
json.dump({"date": date, "machine": machine, "command": command, "rows": rows, "summary": summary,
           "block_rows": block_rows, "dreg_rows": dreg_rows}, open(out_json, "w"), indent=1)
L = ["# Captures at different scales (`bench/registration_sim3.sh`)", "",
     "Date %s; machine %s; command `%s`; raw: [%s](%s)." % (date, machine, command, os.path.basename(out_json),
                                                            os.path.basename(out_json)), "",
     "Held-out procedural objects (seeds 6000+), 60 views at 64x64 split into two blocks, each in its own random "
     "frame; block 0's splat capture moved by a similarity of relative scale S (and a turn and shift) with `reg "
     "apply`, then `reg register` (default `auto`, field refinement, seed 0) onto block 1's capture. Success (the "
     "issue's target): rotation <= 2 deg, translation <= 2 % of the extent 2.5 (target units), scale within 1 %. "
     "`fixed` is `--scale fixed`, the rigid registration as before; `baseline` is FPFH + RANSAC + ICP with scale "
     "(`--method ransac --refine icp`: similarity RANSAC hypotheses, Open3D's point-to-point ICP with_scaling=true, "
     "then point-to-plane), the issue's comparison.", "",
     "| S | --scale | pairs | success | untrusted | median rotation (deg) | median translation / extent | "
     "median scale error | median time (s) |", "|---|---|---|---|---|---|---|---|---|"]
for s in summary:
    L.append("| %g | %s | %d | %d | %d | %.3f | %.4f | %.4f | %.1f |" % (
        s["relative_scale"], s["mode"], s["pairs"], s["success"], s["untrusted"], s["median_rotation_deg"],
        s["median_translation_over_extent"], s["median_scale_error"], s["median_seconds"]))
L += ["", "| object | S | --scale | kept | rotation (deg) | translation / extent | scale | true scale | confidence | "
      "agreeing | status (exit) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
for r in rows:
    L.append("| %d | %g | %s | %s | %.3f | %.4f | %.4f | %.4f | %.2f | %d | %s (%d) |" % (
        r["seed"], r["relative_scale"], r["mode"], r["method"], r["rotation_deg"], r["translation_over_extent"],
        r["scale"], r["true_scale"], r["confidence"], r["agreeing_candidates"], r["status"], r["exit_code"]))
L += ["", "The network alone (`--method dreg --refine none`: no refinement, no other candidate) on the same pairs. "
      "Each input is normalised by its own extent first, so the shipped weights (trained rigid, without scale "
      "augmentation) should answer the same at every S; rotation error (deg) per object:", "",
      "| S | " + " | ".join(seeds.split()) + " | median |", "|---|" + "---|" * (len(seeds.split()) + 1)]
for s in sorted({r["relative_scale"] for r in dreg_rows}):
    g = {r["seed"]: r["rotation_deg"] for r in dreg_rows if r["relative_scale"] == s}
    L.append("| %g | " % s + " | ".join("%.1f" % g[int(o)] if int(o) in g else "-" for o in seeds.split()) +
             " | %.1f |" % statistics.median(g.values()))
L += ["", "## Trained NeRF blocks at different scales", "",
      "Procedural objects (seeds 6000+, held out), 60 views at 64x64 rendered into two blocks with `--block-scale-range "
      "%s` (seed 0: both at scale 1), each block trained for %s iterations (`nerf train --iters %s`); `reg register` "
      "(default `auto`, field refinement, seed 0; `baseline`: FPFH + RANSAC + ICP with scale, as above) both ways. "
      "Target (the issue's for blocks): rotation <= 2 deg, scale "
      "within 2 %%. Translation over the object's extent in the target block's units (2.5 times its block scale). "
      "Success here is that target; `reg eval`'s own (5 deg) is not used." % (block_range, block_iters, block_iters),
      "",
      "; ".join("`%s`: %d of %d registrations meet the target, %d untrusted (exit 5)" % (
          m, sum(r["success"] for r in block_rows if r["mode"] == m), sum(r["mode"] == m for r in block_rows),
          sum(r["status"] == "untrusted" for r in block_rows if r["mode"] == m))
                for m in ("free", "fixed", "baseline") if any(r["mode"] == m for r in block_rows)) + ".",
      "",
      "| object:seed | source -> target | true scale | --scale | kept | rotation (deg) | translation / extent | scale | "
      "scale error | confidence | agreeing | status (exit) | time (s) | success |",
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
for r in block_rows:
    L.append("| %s | %s -> %s | %.4f | %s | %s | %.3f | %.4f | %.4f | %.4f | %.2f | %d | %s (%d) | %.0f | %s |" % (
        r["set"], r["direction"][0], r["direction"][1], r["true_scale"], r["mode"], r["method"], r["rotation_deg"],
        r["translation_over_extent"], r["scale"], r["scale_error"], r["confidence"], r["agreeing_candidates"],
        r["status"], r["exit_code"], r["seconds"], "yes" if r["success"] else "no"))
open(out_md, "w").write("\n".join(L) + "\n")
print("\n".join(L))
PY
