#!/usr/bin/env bash
# `nerfreg dbarf poses --method network` (the pose network from the identity, every edge averaged)
# with and without the photometric bundle adjustment (--bundle-adjust 1), on 20-view 128x96
# procedural scenes with ground truth. Per scene and variant: median rotation error (deg) and
# median centre error (% of the widest ground-truth baseline) after aligning rotations then centres
# (`dbarf eval-poses --align rotations`), and over all camera pairs the median relative-rotation and
# relative-translation-direction errors (deg; no alignment needed), and wall time.
# Usage: bench/dbarf_network_ba.sh OUT.json SCENE_DIR...   (each SCENE_DIR has images/ and
#   transforms.json; make them with scripts/dbarf_data.sh: validation data/dbarf_poses/val_30*)
# Env: NERFREG (default build/nerfreg), VARIANTS (default "0 1": --bundle-adjust values), WORK.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
OUT_JSON=$1
shift
WORK=${WORK:-$(mktemp -d /tmp/dbarf_network_ba.XXXXXX)}
VARIANTS=${VARIANTS:-"0 1"}
mkdir -p "$WORK"
rows=$WORK/rows.jsonl
: >"$rows"
for scene in "$@"; do
  name=$(basename "$scene")
  for ba in $VARIANTS; do
    out=$WORK/$name.ba$ba
    t0=$(date +%s.%N)
    "$NERFREG" dbarf poses "$scene/images" --intrinsics "$scene/transforms.json" --method network --bundle-adjust "$ba" \
      --out "$out" --force --quiet >"$out.log" 2>&1 || { echo "$name ba=$ba failed: see $out.log" >&2; continue; }
    t1=$(date +%s.%N)
    eval_json=$("$NERFREG" dbarf eval-poses "$out/transforms.json" --ground-truth "$scene/transforms.json" --align rotations \
      --json 2>/dev/null | grep '^{' | tail -1)
    python3 - "$scene/transforms.json" "$out/transforms.json" "$name" "$ba" "$t0" "$t1" "$eval_json" >>"$rows" <<'EOF'
import json, math, statistics, sys
gt_path, est_path, name, ba, t0, t1, ev = sys.argv[1:]
def load(p):
    j = json.load(open(p))
    return {f["file_path"].split("/")[-1]: f["transform_matrix"] for f in j["frames"]}
gt, est = load(gt_path), load(est_path)
names = sorted(set(gt) & set(est))
def rot(m):  # world_from_cam rotation, rows
    return [row[:3] for row in m[:3]]
def centre(m):
    return [m[r][3] for r in range(3)]
def tmul(a, v):  # a^T v
    return [sum(a[r][c] * v[r] for r in range(3)) for c in range(3)]
def tmat(a, b):  # a^T b
    return [[sum(a[r][i] * b[r][j] for r in range(3)) for j in range(3)] for i in range(3)]
def angle(a, b):
    na, nb = math.sqrt(sum(x * x for x in a)), math.sqrt(sum(x * x for x in b))
    c = sum(x * y for x, y in zip(a, b)) / (na * nb + 1e-300)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))
rots, dirn = [], []
for i in range(len(names)):
    for j in range(i + 1, len(names)):
        a, b = names[i], names[j]
        # world_from_cam (both files in one camera convention, so the axis flip cancels)
        rel_gt, rel_est = tmat(rot(gt[a]), rot(gt[b])), tmat(rot(est[a]), rot(est[b]))
        d = tmat(rel_gt, rel_est)
        rots.append(math.degrees(math.acos(max(-1.0, min(1.0, (d[0][0] + d[1][1] + d[2][2] - 1) / 2)))))
        dg = [x - y for x, y in zip(centre(gt[b]), centre(gt[a]))]
        de = [x - y for x, y in zip(centre(est[b]), centre(est[a]))]
        dirn.append(angle(tmul(rot(gt[a]), dg), tmul(rot(est[a]), de)))
e = json.loads(ev)
print(json.dumps({"scene": name, "bundle_adjust": int(ba), "posed": e["posed"], "rotation_deg_median": e["rotation_deg_median"],
                  "center_percent_median": e["center_percent_median"], "pair_rotation_deg_median": statistics.median(rots),
                  "pair_direction_deg_median": statistics.median(dirn), "seconds": float(t1) - float(t0)}))
EOF
    tail -1 "$rows"
  done
done
python3 - "$rows" "$OUT_JSON" "$NERFREG" "$*" <<'EOF'
import datetime, json, os, platform, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
summary = {}
for ba in sorted({r["bundle_adjust"] for r in rows}):
    rs = [r for r in rows if r["bundle_adjust"] == ba]
    summary[str(ba)] = {k: statistics.mean([r[k] for r in rs]) for k in
                        ["rotation_deg_median", "center_percent_median", "pair_rotation_deg_median",
                         "pair_direction_deg_median", "seconds"]}
    summary[str(ba)]["scenes"] = len(rs)
out = {"command": "bench/dbarf_network_ba.sh " + sys.argv[2] + " " + sys.argv[4],
       "date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"),
       "machine": "%s, %d cores, load %s" % (platform.processor() or platform.machine(), os.cpu_count(),
                                            open("/proc/loadavg").read().split()[0]),
       "rows": rows, "mean_over_scenes": summary}
tmp = sys.argv[2] + ".tmp"
json.dump(out, open(tmp, "w"), indent=1)
os.replace(tmp, sys.argv[2])
print(json.dumps(summary, indent=1))
EOF
