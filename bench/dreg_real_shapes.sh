#!/usr/bin/env bash
# DReg-NeRF's network on real shapes (issue 46): the Sweet Home 3D furniture of the split file's
# TEST meshes (models/sh3f_split.json; no weights were trained or chosen on them), one synthesised
# pair per mesh of a 2-block and of a 4-block split (adjacent blocks: lower overlap), made by
# `reg make-data --scale-augment 2`: each block in the frame `reg register --scale free` gives the
# network (normalised by its own seen extent), the truth carrying the residual scale between the two.
# Three methods per pair with `reg eval --pairs` (the chain reg register runs, rigid rows): the
# network alone (dreg), the network + ICP on the grids (dreg+icp), FPFH + RANSAC + ICP (ransac+icp;
# it does not depend on the weights and is run once). Per weights file in WEIGHTS ("name=path ...";
# default: the stage-12c weights from git, `git show 27469a5:models/dreg_cpu.pt`, and the current
# models/dreg_cpu.pt). Success: within 5 deg and 0.05 of the extent 2.5 (reg/registration_success.h).
# SETS="val2 val4" gives the validation figures the weights were chosen on (OUT_MD / OUT_JSON then
# name another file); RANSAC=0 leaves out FPFH + RANSAC + ICP, REFINE=none the network + ICP.
# Writes OUT_JSON (default results/dreg_real_shapes.json) and OUT_MD (results/dreg_real_shapes.md).
# Usage: bench/dreg_real_shapes.sh   (env: NERFREG, DATA, SETS, WEIGHTS, WORK, OUT_JSON, OUT_MD, MAX_PAIRS)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
cd "$ROOT"
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
DATA=${DATA:-$ROOT/data/reg_sh3f}
SETS=${SETS:-"test2 test4"}
WORK=${WORK:-$(mktemp -d /tmp/dreg_real_shapes.XXXXXX)}
OUT_JSON=${OUT_JSON:-$ROOT/results/dreg_real_shapes.json}
OUT_MD=${OUT_MD:-$ROOT/results/dreg_real_shapes.md}
MAX_PAIRS=${MAX_PAIRS:-0}
RANSAC=${RANSAC:-1}
REFINE=${REFINE:-none,icp}
mkdir -p "$WORK"
if [ -z "${WEIGHTS:-}" ]; then
  [ -f "$WORK/dreg_cpu_12c.pt" ] || git -C "$ROOT" show 27469a5:models/dreg_cpu.pt > "$WORK/dreg_cpu_12c.pt"
  WEIGHTS="12c=$WORK/dreg_cpu_12c.pt current=$ROOT/models/dreg_cpu.pt"
fi
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
# The pairs (resumable; one pair per mesh and split, the split's own seed).
for set in $SETS; do
  split=${set%[0-9]}
  blocks=${set#"$split"}
  [ -f "$DATA/$set/pairs.json" ] && [ "$(python3 -c "import json,sys; j=json.load(open(sys.argv[1])); \
print(int(j['options'].get('scale_augment', 0) == 2))" "$DATA/$set/pairs.json")" = 1 ] ||
    "$NERFREG" reg make-data --meshes "sh3f:$split" --mesh-pairs 1 --blocks "$blocks" --scale-augment 2 \
      --grid-resolution 32 --quiet --out "$DATA/$set"
done
runs=()
for set in $SETS; do
  # FPFH + RANSAC + ICP once per set.
  out=$WORK/${set}_ransac.json
  if [ "$RANSAC" = 1 ]; then
    [ -f "$out" ] || "$NERFREG" reg eval --pairs "$DATA/$set/pairs.json" --split all --max-pairs "$MAX_PAIRS" \
      --methods ransac --refine icp --out "$out" --quiet > /dev/null
    runs+=("$set" "-" "$out")
  fi
  for w in $WEIGHTS; do
    name=${w%%=*}
    out=$WORK/${set}_dreg_${name}_${REFINE/,/_}.json
    [ -f "$out" ] || "$NERFREG" reg eval --pairs "$DATA/$set/pairs.json" --split all --max-pairs "$MAX_PAIRS" \
      --methods dreg --refine "$REFINE" --weights "${w#*=}" --out "$out" --quiet > /dev/null
    runs+=("$set" "$name" "$out")
  done
done
python3 - "$OUT_JSON" "$OUT_MD" "$WEIGHTS" "${runs[@]}" <<'PY'
import json, statistics, sys
out_json, out_md, weights, rest = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
EXTENT = 2.5
table, by_set = [], {}
for k in range(0, len(rest), 3):
    set_, wname, path = rest[k:k + 3]
    rows = json.load(open(path))["rows"]
    for method in sorted({r["method"] for r in rows}):
        rs = [r for r in rows if r["method"] == method]
        rot = [r["rotation_error_deg"] for r in rs]
        tr = [r["translation_error"] / EXTENT for r in rs]
        ok = [a <= 5 and b <= 0.05 for a, b in zip(rot, tr)]
        row = {"set": set_, "weights": wname if method.startswith("dreg") else "-", "method": method,
               "pairs": len(rs), "median_rotation_deg": statistics.median(rot), "mean_rotation_deg": statistics.mean(rot),
               "median_translation_fraction": statistics.median(tr), "mean_translation_fraction": statistics.mean(tr),
               "success_5deg_0.05": sum(ok) / len(ok), "within_5deg": sum(a <= 5 for a in rot) / len(rot),
               "median_seconds": statistics.median(r["seconds"] for r in rs),
               "pairs_detail": [{"pair": r["pair"], "rotation_error_deg": r["rotation_error_deg"],
                                 "translation_fraction": r["translation_error"] / EXTENT, "overlap": r["overlap"]}
                                for r in rs]}
        table.append(row)
json.dump({"weights": weights, "rows": table}, open(out_json, "w"), indent=1)
names = {"test2": "test meshes, 2-block pairs", "test4": "test meshes, 4-block pairs (adjacent)",
         "val2": "validation meshes, 2-block pairs", "val4": "validation meshes, 4-block pairs (adjacent)"}
lines = []
for set_ in dict.fromkeys(r["set"] for r in table):
    lines += ["", "### " + names.get(set_, set_), "",
              "| method | weights | pairs | median rot (deg) | mean rot (deg) | median trans / extent | mean trans / extent "
              "| success 5 deg / 0.05 | within 5 deg | median s |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in [r for r in table if r["set"] == set_]:
        lines.append("| {method} | {weights} | {pairs} | {median_rotation_deg:.2f} | {mean_rotation_deg:.2f} | "
                     "{median_translation_fraction:.4f} | {mean_translation_fraction:.4f} | {s:.0f} % | {w:.0f} % | "
                     "{median_seconds:.2f} |".format(s=100 * r["success_5deg_0.05"], w=100 * r["within_5deg"], **r))
import datetime, os
head = ["# DReg-NeRF's network on real shapes (Sweet Home 3D furniture)", "",
        "Made by `" + os.environ.get("COMMAND", "bench/dreg_real_shapes.sh") + "` on " +
        datetime.date.today().isoformat() + " (what the pairs are and how each method runs: the script's header).",
        "Weights: " + ", ".join("`%s` = %s" % tuple(w.split("=", 1)) for w in weights.split()) + ".",
        "Success: within 5 deg and 0.05 of the extent 2.5; `within 5 deg`: the rotation alone."]
open(out_md, "w").write("\n".join(head + lines) + "\n")
PY
echo "wrote $OUT_MD and $OUT_JSON (work: $WORK)"
