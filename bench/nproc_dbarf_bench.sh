#!/usr/bin/env bash
# Data-parallel `dbarf pretrain --nproc` throughput (docs/distributed.md), the pose network's
# training as scripts/dbarf_pose_train.sh runs it (pose stage, from the identity, supervised poses,
# ground-truth cameras) on 4 procedural scenes (seeds 5900-5903: bench seeds), one thread per process:
#   one   : 1 process,  --batch 1
#   two   : 2 processes (--nproc 2), --batch 2, one target each
#   one_b2: 1 process,  --batch 2 (the same step as two)
# Reports steps/s and targets/s from each run's OUT.json (the training loop only) and the load
# average around each run. Writes OUT_JSON (default results/nproc_dbarf.json) and prints the rows.
# Usage: bench/nproc_dbarf_bench.sh [STEPS (default 100)]
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
STEPS=${1:-100}
WORK=${WORK:-$(mktemp -d /tmp/nproc_dbarf_bench.XXXXXX)}
OUT_JSON=${OUT_JSON:-$ROOT/results/nproc_dbarf.json}
export OMP_NUM_THREADS=1
scenes=()
for seed in 5900 5901 5902 5903; do
  [ -f "$WORK/s$seed/transforms.json" ] || "$NERFREG" render --procedural "$seed" --trajectory forward --views 20 \
    --test-every 8 --quiet --out "$WORK/s$seed" --force
  scenes+=("$WORK/s$seed/transforms.json")
done
COMMON="dbarf pretrain ${scenes[*]} --scene-cameras ground-truth --pose-init network --supervise-poses 1
  --stage-steps 1000000000 --steps $STEPS --checkpoint-every $STEPS --quiet --force"
RUNS=()
run() {  # name, extra arguments
  local name=$1; shift
  local before after
  before=$(cut -d' ' -f1-3 /proc/loadavg)
  "$NERFREG" $COMMON --out "$WORK/$name.pt" "$@" > /dev/null
  after=$(cut -d' ' -f1-3 /proc/loadavg)
  RUNS+=("$name|$*|$before|$after")
}
run one --batch 1
run two --batch 2 --nproc 2
run one_b2 --batch 2
python3 - "$WORK" "$OUT_JSON" "$STEPS" "$NERFREG $COMMON" "${RUNS[@]}" <<'PY'
import datetime, json, os, sys
work, out, steps, common = sys.argv[1], sys.argv[2], int(sys.argv[3]), " ".join(sys.argv[4].split())
rows = []
for r in sys.argv[5:]:
    name, args, before, after = r.split("|")
    s = json.load(open(os.path.join(work, name + ".pt.json")))
    batch = 2 if "--batch 2" in args else 1
    steps_s = s["steps"] / s["seconds"]
    rows.append({"run": name, "args": args, "processes": s["processes"], "batch": batch, "steps": s["steps"],
                 "seconds": s["seconds"], "steps_per_s": steps_s, "targets_per_s": steps_s * batch,
                 "load_before": before, "load_after": after})
by = {r["run"]: r for r in rows}
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
result = {"date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), "machine": f"{os.cpu_count()} cores, {cpu}",
          "command": "bench/nproc_dbarf_bench.sh " + str(steps), "train_command": common, "omp_num_threads": 1,
          "runs": rows, "two_vs_one_b2_steps": by["two"]["steps_per_s"] / by["one_b2"]["steps_per_s"],
          "two_vs_one_targets": by["two"]["targets_per_s"] / by["one"]["targets_per_s"]}
json.dump(result, open(out, "w"), indent=1)
for r in rows:
    print("| %s | %d | %d | %.2f | %.2f | %s | %s |" % (r["run"], r["processes"], r["batch"], r["steps_per_s"],
                                                       r["targets_per_s"], r["load_before"], r["load_after"]))
print("two / one targets/s: %.2fx; two / one_b2 steps/s: %.2fx" % (result["two_vs_one_targets"], result["two_vs_one_b2_steps"]))
PY
