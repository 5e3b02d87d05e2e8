#!/usr/bin/env bash
# `nerfreg reg register` as a user runs it (checkpoints in, pose out: grids or occupied points
# extracted inside, timed end to end) on the real NeRF block pairs of `reg make-data` pairs.json
# files, against their ground truth. One row per pair and configuration, then per configuration
# the median rotation error, median translation / extent (2.5), success at 5 deg / 0.05 and the
# median wall time of the command.
# Usage: bench/reg_register_real.sh PAIRS_JSON... (default: data/reg/val_nerf and val_nerf4)
#   CONFIGS="auto:--refine field|ransac:--method ransac --refine icp" (name:arguments, | separated)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
WORK=${WORK:-$(mktemp -d /tmp/reg_register_real.XXXXXX)}
CONFIGS=${CONFIGS:-"ransac+icp:--method ransac --refine icp|ransac+icp+field:--method ransac --refine field|auto+field:--method auto --refine field"}
PAIRS=("$@")
[ ${#PAIRS[@]} -eq 0 ] && PAIRS=("$ROOT/data/reg/val_nerf/pairs.json" "$ROOT/data/reg/val_nerf4/pairs.json")
mkdir -p "$WORK"
ROWS="$WORK/rows.txt"
: > "$ROWS"
printf "%-28s %-20s %10s %10s %9s %s\n" pair config "rot (deg)" trans/ext "time (s)" chosen
for pairs in "${PAIRS[@]}"; do
  # name, source checkpoint, target checkpoint, ground truth, block indices of the real pairs
  python3 - "$pairs" <<'EOF' > "$WORK/list.txt"
import json, os, sys
path = sys.argv[1]
base = os.path.dirname(os.path.abspath(path))
for p in json.load(open(path))["pairs"]:
    if p.get("kind") != "nerf":
        continue
    src = os.path.join(base, p["source"]); tgt = os.path.join(base, p["target"])
    d = os.path.dirname(src)
    print(p["name"], src[:-len(".grid")] + ".ckpt", tgt[:-len(".grid")] + ".ckpt",
          os.path.join(d, "data", "ground_truth.json"), p["source_block"], p["target_block"])
EOF
  while read -r name src tgt gt sb tb; do
    IFS='|' read -ra cfgs <<< "$CONFIGS"
    for cfg in "${cfgs[@]}"; do
      label=${cfg%%:*}
      args=${cfg#*:}
      # The set's folder in the name: val_nerf and val_nerf4 both have a spider/nerf_0_1.
      out="$WORK/$(basename "$(dirname "$pairs")")_$(echo "$name" | tr '/' '_')_${label}.json"
      t0=$(date +%s.%N)
      # shellcheck disable=SC2086
      # Exit 5: an untrusted result (T.json written with its status), scored like any other.
      "$NERFREG" reg register "$src" "$tgt" $args --out "$out" --force --quiet > /dev/null || [ $? = 5 ]
      t1=$(date +%s.%N)
      "$NERFREG" reg eval --pair "$out" --ground-truth "$gt" --source "$sb" --target "$tb" --out "$out.eval" --force --quiet > /dev/null
      python3 - "$out" "$out.eval" "$name" "$label" "$t0" "$t1" <<'EOF' | tee -a "$ROWS"
import json, sys
r, e = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
print("%-28s %-20s %10.3f %10.4f %9.2f %s" % (sys.argv[3], sys.argv[4], e["rotation_error_deg"],
      e["translation_error_fraction"], float(sys.argv[6]) - float(sys.argv[5]), r["method"]))
EOF
    done
  done < "$WORK/list.txt"
done
echo
python3 - "$ROWS" <<'EOF'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
print("%-20s %6s %10s %12s %10s %10s" % ("config", "pairs", "med rot", "med trans/ext", "succ 5/.05", "med time"))
for label in dict.fromkeys(r[1] for r in rows):
    sel = [r for r in rows if r[1] == label]
    rot = [float(r[2]) for r in sel]; tr = [float(r[3]) for r in sel]; t = [float(r[4]) for r in sel]
    ok = sum(1 for a, b in zip(rot, tr) if a <= 5 and b <= 0.05)
    print("%-20s %6d %10.3f %12.4f %9.0f%% %10.2f" % (label, len(sel), statistics.median(rot), statistics.median(tr),
          100.0 * ok / len(sel), statistics.median(t)))
EOF
