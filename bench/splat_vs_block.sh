#!/usr/bin/env bash
# Splats register like NeRF blocks? (issue 25's target.) Per held-out procedural object (seeds 6000+:
# no registration model was trained or chosen on them): 60 views at 64x64 split into 2 blocks, each
# in its own random frame (`render --blocks 2 --splats`: each block's splats cover what its views
# saw); both blocks trained (`nerf train`, ITERS iterations); then `reg register` (default `auto`,
# field refinement) on the two splat captures, on the two trained blocks and on block 0 trained onto
# block 1's splats (mixed), each scored against the
# truth (`reg eval --pair`: rotation error, translation / extent 2.5, success at 5 deg / 0.05).
# Writes OUT_JSON (default results/splat_vs_block.json) and OUT_MD (results/splat_vs_block.md).
# Usage: bench/splat_vs_block.sh [SEEDS (default "6000 6001 6002 6003 6004 6005 6006 6007")]
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
SEEDS=${1:-"6000 6001 6002 6003 6004 6005 6006 6007"}
ITERS=${ITERS:-400}
WORK=${WORK:-$(mktemp -d /tmp/splat_vs_block.XXXXXX)}
OUT_JSON=${OUT_JSON:-$ROOT/results/splat_vs_block.json}
OUT_MD=${OUT_MD:-$ROOT/results/splat_vs_block.md}
mkdir -p "$WORK"
ROWS=$WORK/rows.txt
: > "$ROWS"
score() {  # kind seed T.json
  local line
  line=$("$NERFREG" reg eval --pair "$3" --ground-truth "$WORK/o$2/ground_truth.json" 2>/dev/null | tail -1)
  echo "$2 $1 $line $(python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print(j['seconds'], j['confidence'])" "$3")" >> "$ROWS"
}
for seed in $SEEDS; do
  d=$WORK/o$seed
  [ -f "$d/ground_truth.json" ] || "$NERFREG" render --procedural "$seed" --blocks 2 --views 60 --size 64 --supersample 1 \
    --test-every 12 --splats --quiet --out "$d" --force
  for k in 0 1; do
    [ -f "$d/b$k.ckpt" ] || "$NERFREG" nerf train "$d/block_$k" --out "$d/b$k.ckpt" --iters "$ITERS" --samples 8192 --quiet \
      > /dev/null
  done
  for kind in splats blocks mixed; do
    case $kind in
      splats) inputs=("$d/block_0/splats.ply" "$d/block_1/splats.ply") ;;
      blocks) inputs=("$d/b0.ckpt" "$d/b1.ckpt") ;;
      mixed) inputs=("$d/b0.ckpt" "$d/block_1/splats.ply") ;;  # a trained block onto a capture's splats
    esac
    # Exit 5: an untrusted result (T.json written with its status), scored like any other.
    "$NERFREG" reg register "${inputs[@]}" --seed 0 --quiet --force --out "$d/$kind.json" > /dev/null || [ $? = 5 ]
    score "$kind" "$seed" "$d/$kind.json"
  done
  echo "object $seed done" >&2
done
python3 - "$ROWS" "$OUT_JSON" "$OUT_MD" "$SEEDS" "$ITERS" <<'PY'
import datetime, json, os, statistics, sys
rows_path, out_json, out_md, seeds, iters = sys.argv[1:6]
rows = []
for line in open(rows_path):
    f = line.split()
    # seed kind method rot trans trans/ext success seconds confidence
    rows.append({"seed": int(f[0]), "kind": f[1], "method": f[2], "rotation_deg": float(f[3]), "translation": float(f[4]),
                 "translation_over_extent": float(f[5]), "success": f[6] == "yes", "seconds": float(f[7]),
                 "confidence": float(f[8])})
summary = {}
kinds = [k for k in ("splats", "blocks", "mixed") if any(x["kind"] == k for x in rows)]
for kind in kinds:
    r = [x for x in rows if x["kind"] == kind]
    summary[kind] = {"pairs": len(r), "success": sum(x["success"] for x in r),
                     "median_rotation_deg": statistics.median(x["rotation_deg"] for x in r),
                     "median_translation_over_extent": statistics.median(x["translation_over_extent"] for x in r),
                     "median_seconds": statistics.median(x["seconds"] for x in r)}
date = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
machine = "%d cores, load %s" % (os.cpu_count(), open("/proc/loadavg").read().split()[0])
command = "bench/splat_vs_block.sh \"%s\" (ITERS=%s)" % (seeds, iters)
json.dump({"date": date, "machine": machine, "command": command, "rows": rows, "summary": summary}, open(out_json, "w"), indent=1)
L = ["# Splat captures against NeRF blocks of the same objects (`bench/splat_vs_block.sh`)", "",
     "Date %s; machine %s; command `%s`; raw: [%s](%s)." % (date, machine, command, os.path.basename(out_json), os.path.basename(out_json)), "",
     "Held-out procedural objects (seeds 6000+, never used to train or choose a registration model), 60 views at "
     "64x64 split into two blocks, each in its own random frame. Per object, `reg register` (default: `auto`, "
     "field refinement, seed 0) on the two blocks' splat captures (`render --splats`: the splats each block's views "
     "saw), on the two blocks trained from the same renders (`nerf train`, %s iterations, 8192 samples), and "
     "mixed: block 0 trained onto block 1's splats; error "
     "against the truth by `reg eval --pair` (success: <= 5 deg and translation <= 5 %% of the extent 2.5)." % iters, "",
     "| input | pairs | success | median rotation (deg) | median translation / extent | median time (s) |", "|---|---|---|---|---|---|"]
for kind in kinds:
    s = summary[kind]
    L.append("| %s | %d | %d | %.3f | %.4f | %.1f |" % (kind, s["pairs"], s["success"], s["median_rotation_deg"],
                                                     s["median_translation_over_extent"], s["median_seconds"]))
L += ["", "| object | input | kept | rotation (deg) | translation / extent | confidence |", "|---|---|---|---|---|---|"]
for r in rows:
    L.append("| %d | %s | %s | %.3f | %.4f | %.2f |" % (r["seed"], r["kind"], r["method"], r["rotation_deg"],
                                                     r["translation_over_extent"], r["confidence"]))
open(out_md, "w").write("\n".join(L) + "\n")
print("\n".join(L))
PY
