#!/usr/bin/env bash
# Scores DBARF pose-network weights from the identity (`dbarf eval-net`, 5 sources, 85 pairs a
# scene) on the validation scenes of scripts/dbarf_data.sh (choose on these) and, with TEST=1, on
# held-out test scenes (report these, never choose on them):
#   validation textured  seeds 3001-3012; sources by the SfM's view graph (as dbarf poses has them)
#   validation hard      seeds 3013-3024 (low-texture, repetitive, spread 0.7); sources by the true
#                        cameras (--scene-cameras ground-truth): the SfM cannot pose these
#   test textured        seeds 201-203 (as validation textured)
#   test hard            seeds 4101-4106: 4101-4102 low-texture, 4103-4104 repetitive, 4105-4106
#                        spread 0.7 (as validation hard); rendered here when missing
# Usage: [TEST=1] bash scripts/dbarf_pose_eval.sh WEIGHTS...   (label: the file name)
# TABLE_ONLY=1 rewrites the table from the JSON an earlier run left in WORK.
# Writes OUT_MD / OUT_JSON (default results/dbarf_pose_network.md / .json): per weights and set,
# the mean rotation and translation-direction errors over the pairs, and the identity's.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
DATA=${DATA:-data/dbarf_poses}
TEST_DATA=${TEST_DATA:-data/dbarf_pose_test}
WORK=${WORK:-runs/eval}
OUT_MD=${OUT_MD:-results/dbarf_pose_network.md}
OUT_JSON=${OUT_JSON:-results/dbarf_pose_network.json}
[ $# -ge 1 ] || { echo "error: expected WEIGHTS... (DBARF weights files)" >&2; exit 2; }
[ -f "$DATA/val_textured.txt" ] || { echo "error: $DATA/val_textured.txt: expected the lists of scripts/dbarf_data.sh" >&2; exit 2; }
mkdir -p "$WORK"
mapfile -t val_textured < "$DATA/val_textured.txt"
mapfile -t val_hard < <(grep -v -x -f "$DATA/val_textured.txt" "$DATA/val.txt")
sets=("validation textured" "validation hard")
# EXTRA=1: also DATA/val_extra.txt (low-texture scenes of 10 views, scripts/dbarf_data.sh), sources
# by the true cameras as the hard sets.
if [ "${EXTRA:-0}" = 1 ]; then
  mapfile -t val_extra < "$DATA/val_extra.txt"
  sets+=("validation extra")
fi
if [ "${TEST:-0}" = 1 ]; then
  test_textured=() test_hard=()
  for s in 201:textured:0.35 202:textured:0.35 203:textured:0.35 4101:low-texture:0.35 4102:low-texture:0.35 \
           4103:repetitive:0.35 4104:repetitive:0.35 4105:textured:0.7 4106:textured:0.7; do
    IFS=: read -r seed material spread <<< "$s"
    d=$TEST_DATA/test_$seed
    [ -f "$d/transforms.json" ] || "$BIN" render --procedural "$seed" --trajectory forward --views 20 \
      --material "$material" --spread "$spread" --test-every 8 --quiet --out "$d" --force
    if [ "$seed" -le 203 ]; then test_textured+=("$d/transforms.json"); else test_hard+=("$d/transforms.json"); fi
  done
  sets+=("test textured" "test hard")
fi
for w in "$@"; do
  [ -f "$w" ] || { echo "error: $w: expected a DBARF weights file" >&2; exit 2; }
  label=$(basename "$w" .pt)
  for set in "${sets[@]}"; do
    key=${set// /_}
    case "$set" in
      "validation textured") files=("${val_textured[@]}"); flags=(--sfm-cache "$WORK/sfm_cache_val") ;;
      "validation hard") files=("${val_hard[@]}"); flags=(--scene-cameras ground-truth) ;;
      "validation extra") files=("${val_extra[@]}"); flags=(--scene-cameras ground-truth) ;;
      "test textured") files=("${test_textured[@]}"); flags=(--sfm-cache "$WORK/sfm_cache_test") ;;
      "test hard") files=("${test_hard[@]}"); flags=(--scene-cameras ground-truth) ;;
    esac
    [ "${TABLE_ONLY:-0}" = 1 ] && continue
    echo "$label: $set (${#files[@]} scenes)" >&2
    OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} nice -n 5 "$BIN" dbarf eval-net "${files[@]}" --weights "$w" "${flags[@]}" \
      --json-out "$WORK/${label}_${key}.json" --force --quiet > /dev/null
  done
done
python3 - "$OUT_MD" "$OUT_JSON" "$WORK" "${sets[@]/#/set:}" -- "$@" <<'EOF'
import datetime, json, os, platform, sys
out_md, out_json, work = sys.argv[1:4]
rest = sys.argv[4:]
sets = [a[4:] for a in rest[:rest.index("--")]]
weights = rest[rest.index("--") + 1:]
rows = []
for w in weights:
    label = os.path.basename(w)[:-3] if w.endswith(".pt") else os.path.basename(w)
    for s in sets:
        j = json.load(open(os.path.join(work, "%s_%s.json" % (label, s.replace(" ", "_")))))
        rows.append({"weights": w, "set": s, "scenes": len(j["rows"]), "pairs": sum(r["pairs"] for r in j["rows"]),
                     "identity_rotation_deg": j["start_rotation_deg"], "rotation_deg": j["rotation_deg"],
                     "translation_direction_deg": j["translation_direction_deg"],
                     "per_scene": [{k: r[k] for k in ("dataset", "pairs", "rotation_deg", "translation_direction_deg")}
                                   for r in j["rows"]]})
date = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
machine = "%s, %d cores, load %s" % (platform.machine(), os.cpu_count(), open("/proc/loadavg").read().split()[0])
command = ("TEST=1 " if any(s.startswith("test") for s in sets) else "") + \
    ("EXTRA=1 " if "validation extra" in sets else "") + "bash scripts/dbarf_pose_eval.sh " + " ".join(weights)
json.dump({"date": date, "machine": machine, "command": command, "rows": rows}, open(out_json, "w"), indent=1)
lines = ["# The pose network from the identity (`scripts/dbarf_pose_eval.sh`)", "",
         "Date %s; machine %s; command `%s`; raw per-scene figures in `%s`." % (date, machine, command, out_json), "",
         "`dbarf eval-net`: every training view of a scene as target, its 5 best neighbours as sources, the network "
         "started from the identity; mean over the pairs of the rotation error and of the translation-direction error "
         "(scale-free), next to the identity's rotation error (its direction error is 90 deg). Textured sets take their "
         "sources from the SfM's view graph, as `dbarf poses` has them; the hard sets (low-texture, repetitive, spread "
         "0.7), which the SfM cannot pose, from the true cameras' nearest views. Validation scenes choose the weights; "
         "test scenes are reported, never chosen on.", "",
         "| weights | set | scenes | pairs | identity rotation (deg) | rotation (deg) | direction (deg) |",
         "|---|---|---|---|---|---|---|"]
for r in rows:
    lines.append("| `%s` | %s | %d | %d | %.3f | %.3f | %.2f |" % (r["weights"], r["set"], r["scenes"], r["pairs"],
                                                               r["identity_rotation_deg"], r["rotation_deg"],
                                                               r["translation_direction_deg"]))
open(out_md, "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
EOF
