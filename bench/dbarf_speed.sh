#!/usr/bin/env bash
# Speed of `nerfreg dbarf poses` at photo sizes against COLMAP 3.8 (CPU: feature_extractor +
# exhaustive_matcher + mapper), on a held-out procedural forward-facing scene rendered photo-like
# (radial distortion, pixel noise, JPEG) at 640x480 and at LLFF's 1008x756. Both get the known
# intrinsics (COLMAP: the OPENCV model with k1, k2) and all of this machine's cores. Each timing is
# run REPEATS times and the minimum reported (the machine may be shared: the load is recorded).
# Accuracy: `dbarf eval-poses --align rotations` (median rotation error, median centre error in %
# of the widest baseline). nerfreg's per-stage seconds come from its transforms.json "timings_s".
# Writes results/dbarf_speed.md and results/dbarf_speed.json.
# Usage: bench/dbarf_speed.sh [WORK_DIR]   (env: SIZES, SEED, VIEWS, REPEATS, METHODS)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
WORK=${1:-$(mktemp -d /tmp/dbarf_speed.XXXXXX)}
SIZES=${SIZES:-"640x480 1008x756"}
SEED=${SEED:-5000}
VIEWS=${VIEWS:-24}
REPEATS=${REPEATS:-2}
# colmap-lo: COLMAP with SIFT's peak threshold lowered to nerfreg's sparse contrast threshold
# (0.005 / 3; nerfreg itself uses 0.01 on these photo-sized images), as in bench/dbarf_vs_colmap.sh:
# with its default COLMAP found no initial pair on these renders.
METHODS=${METHODS:-"classical auto colmap colmap-lo"}
PHOTO="--distortion -0.08,0.02 --noise 0.01 --jpeg 90"
mkdir -p "$WORK" "$ROOT/results"
RAW=$WORK/runs.jsonl
: >"$RAW"
now() { date +%s.%N; }

colmap_params() {  # GT -> fx,fy,cx,cy,k1,k2,p1,p2
  python3 -c '
import json, math, sys
j = json.load(open(sys.argv[1]))
w, h = j["w"], j["h"]
fx = j.get("fl_x") or 0.5 * w / math.tan(0.5 * j["camera_angle_x"])
print(",".join(repr(float(v)) for v in (fx, j.get("fl_y", fx), j.get("cx", w / 2), j.get("cy", h / 2),
      j.get("k1", 0), j.get("k2", 0), j.get("p1", 0), j.get("p2", 0))))' "$1"
}

T() { /usr/bin/time -a -o "$CPU_FILE" -f "%U %S" "$@"; }  # appends user and system CPU seconds

run_once() {  # METHOD IMAGES GT OUT -> "wall_seconds cpu_seconds"
  local method=$1 images=$2 gt=$3 out=$4 t0 t1
  rm -rf "$out"
  CPU_FILE=$out.cpu
  : >"$CPU_FILE"
  t0=$(now)
  case $method in
    classical | auto)
      T "$NERFREG" dbarf poses "$images" --intrinsics "$gt" --method "$method" --out "$out" --force >"$out.log" 2>&1 || true ;;
    colmap | colmap-lo)
      local extra=()
      [ "$method" = colmap-lo ] && extra=(--SiftExtraction.peak_threshold 0.00167)
      mkdir -p "$out/sparse"
      {
        T colmap feature_extractor --database_path "$out/db.db" --image_path "$images" --SiftExtraction.use_gpu 0 \
          --ImageReader.single_camera 1 --ImageReader.camera_model OPENCV --ImageReader.camera_params "$(colmap_params "$gt")" "${extra[@]}" &&
        T colmap exhaustive_matcher --database_path "$out/db.db" --SiftMatching.use_gpu 0 &&
        # The known intrinsics held, as nerfreg holds its --intrinsics (the mapper refines focal and
        # distortion by default: on the 640x480 scene that moved the focal 704 -> 727 px).
        T colmap mapper --database_path "$out/db.db" --image_path "$images" --output_path "$out/sparse" \
          --Mapper.ba_refine_focal_length 0 --Mapper.ba_refine_principal_point 0 --Mapper.ba_refine_extra_params 0
      } >"$out.log" 2>&1 || true ;;
  esac
  t1=$(now)
  if [ "${method#colmap}" != "$method" ]; then  # the largest model, as transforms.json
    local best="" best_n=-1 m n
    for m in "$out"/sparse/*/; do
      [ -f "$m/images.bin" ] || continue
      mkdir -p "$m/txt"
      colmap model_converter --input_path "$m" --output_path "$m/txt" --output_type TXT >/dev/null 2>&1 || continue
      n=$(($(grep -vc '^#' "$m/txt/images.txt") / 2))
      if [ "$n" -gt "$best_n" ]; then best=$m; best_n=$n; fi
    done
    [ -n "$best" ] && "$NERFREG" convert "$best/txt" --to nerf --out "$out/transforms.json" --force --quiet >/dev/null 2>&1 || true
  fi
  python3 -c "import sys; print('%.3f %.3f' % ($t1 - $t0, sum(float(x) for l in open(sys.argv[1]) for x in l.split()[:2] if x.replace('.', '', 1).isdigit())))" "$CPU_FILE"
}

evaluate() {  # ESTIMATE GT -> JSON or {}
  "$NERFREG" dbarf eval-poses "$1" --ground-truth "$2" --align rotations --json 2>/dev/null | grep '^{' | tail -1 || echo '{}'
}

for size in $SIZES; do
  data=$WORK/scene_${SEED}_$size
  [ -f "$data/transforms.json" ] ||
    "$NERFREG" render --procedural "$SEED" --trajectory forward --views "$VIEWS" --size "$size" $PHOTO --quiet --out "$data" --force
  for method in $METHODS; do
    for rep in $(seq "$REPEATS"); do
      out=$WORK/${method}_${size}_$rep
      load=$(cut -d' ' -f1 /proc/loadavg)
      read -r t cpu <<<"$(run_once "$method" "$data/images" "$data/transforms.json" "$out")"
      ev=$(evaluate "$out/transforms.json" "$data/transforms.json")
      timings='{}'
      [ "${method#colmap}" = "$method" ] && [ -f "$out/transforms.json" ] &&
        timings=$(python3 -c 'import json,sys; print(json.dumps(json.load(open(sys.argv[1]))["dbarf_poses"].get("timings_s", {})))' "$out/transforms.json")
      echo "{\"size\": \"$size\", \"method\": \"$method\", \"repeat\": $rep, \"wall_s\": $t, \"cpu_s\": $cpu, \"load_before\": $load, \"eval\": $ev, \"timings_s\": $timings}" >>"$RAW"
      echo "$size $method #$rep: wall ${t} s, cpu ${cpu} s (load $load)" >&2
    done
  done
done

python3 - "$RAW" "$ROOT/results" "$0 $*" "$SEED" "$VIEWS" "$REPEATS" "$PHOTO" <<'PY'
import json, os, subprocess, sys, datetime
raw, out_dir, command, seed, views, repeats, photo = sys.argv[1:8]
runs = [json.loads(l) for l in open(raw) if l.strip()]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
machine = {"nproc": os.cpu_count(), "cpu": cpu, "loadavg_end": open("/proc/loadavg").read().split()[:3]}
best = {}
for r in runs:  # the fastest run of each (size, method)
    k = (r["size"], r["method"])
    if k not in best or r["wall_s"] < best[k]["wall_s"]: best[k] = r
stage_names = []
for r in best.values():
    for s in r["timings_s"]:
        if s != "total" and s not in stage_names: stage_names.append(s)
rows = []
for (size, method), r in best.items():
    e = r["eval"]
    rows.append({"size": size, "method": "nerfreg " + method if not method.startswith("colmap") else method.replace("colmap", "colmap 3.8", 1),
                 "posed": "%s/%s" % (e.get("posed", 0), e.get("images", views)),
                 "rotation_deg_median": e.get("rotation_deg_median"), "center_percent_median": e.get("center_percent_median"),
                 "wall_s_min": r["wall_s"], "cpu_s_min": min(x["cpu_s"] for x in runs if (x["size"], x["method"]) == (size, method)), "wall_s_all": [x["wall_s"] for x in runs if (x["size"], x["method"]) == (size, method)],
                 "load_before": [x["load_before"] for x in runs if (x["size"], x["method"]) == (size, method)],
                 "timings_s": r["timings_s"]})
date = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
doc = {"date": date, "machine": machine, "command": command, "seed": int(seed), "views": int(views), "repeats": int(repeats),
       "render_degradations": photo, "rows": rows}
json.dump(doc, open(os.path.join(out_dir, "dbarf_speed.json"), "w"), indent=1)
fmt = lambda v, f: "-" if v is None else f % v
lines = ["# dbarf poses vs COLMAP at photo sizes", "",
         "%s; %d cores (%s); load average at the end %s (the machine is shared: wall times are the minimum of %s runs, "
         "load before each run in the JSON). Both use all %d cores." % (date, machine["nproc"], cpu, " ".join(machine["loadavg_end"]), repeats, machine["nproc"]),
         "", "Command: `%s`. Data: `nerfreg render --procedural %s --trajectory forward --views %s --size WxH %s`; "
         "accuracy from `nerfreg dbarf eval-poses --align rotations` (Sim(3) after rotations then centres); centre error in %% of "
         "the widest baseline. COLMAP: feature_extractor (OPENCV camera, known parameters) + exhaustive_matcher + mapper with the parameters held (not refined), CPU." % (command, seed, views, photo), "",
         "| size | method | posed | median rot (deg) | centre err (%) | wall (s) | CPU (s) | " + " | ".join(stage_names) + " |",
         "|---|---|---|---|---|---|---|" + "---|" * len(stage_names)]
for r in rows:
    lines.append("| %s | %s | %s | %s | %s | %.2f | %.2f | " % (r["size"], r["method"], r["posed"], fmt(r["rotation_deg_median"], "%.4f"),
                 fmt(r["center_percent_median"], "%.3f"), r["wall_s_min"], r["cpu_s_min"]) +
                 " | ".join(fmt(r["timings_s"].get(s), "%.2f") for s in stage_names) + " |")
lines += ["", "Wall and CPU (user + system, all processes of the method) are each the minimum over the runs; on a loaded "
          "machine CPU seconds are the steadier figure. Stage columns: wall seconds inside nerfreg (its `timings_s`) "
          "of the fastest run; wall includes process start-up.", ""]
open(os.path.join(out_dir, "dbarf_speed.md"), "w").write("\n".join(lines))
print("\n".join(lines))
PY
echo "work dir: $WORK" >&2
