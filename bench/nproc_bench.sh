#!/usr/bin/env bash
# Data-parallel `reg train --nproc` throughput (docs/distributed.md): the `cpu` config on small
# procedural pairs (seeds 5000+), each run one thread per process.
#   one   : 1 process,  --batch 1
#   one_b2: 1 process,  --batch 2 (the same step as two)
#   two   : 2 processes (--nproc 2), --batch 2, one pair each
# Reports steps/s and pairs/s from each run's OUT.json (training loop only) and the machine's load
# average before and after each run. Writes results/nproc.json and prints the table rows.
# Usage: bench/nproc_bench.sh [ITERS (default 150)]
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
ITERS=${1:-150}
WORK=${WORK:-$(mktemp -d /tmp/nproc_bench.XXXXXX)}
OUT_JSON=${OUT_JSON:-$ROOT/results/nproc.json}
export OMP_NUM_THREADS=1
"$NERFREG" reg make-data --procedural 4 --procedural-seed 5000 --mesh-pairs 2 --grid-resolution 32 --quiet \
  --out "$WORK/data" > /dev/null
COMMON="reg train $WORK/data/pairs.json --iters $ITERS --val-every 0 --checkpoint-every 0 --quiet --force"
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
python3 - "$WORK" "$OUT_JSON" "$ITERS" "$NERFREG $COMMON" "${RUNS[@]}" <<'PY'
import datetime, json, os, platform, subprocess, sys
work, out, iters, common = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
rows = []
for r in sys.argv[5:]:
    name, args, before, after = r.split("|")
    s = json.load(open(os.path.join(work, name + ".pt.json")))
    batch = s["options"]["batch"] or s["processes"]
    steps_s = s["iterations"] / s["seconds"]
    rows.append({"run": name, "args": args, "processes": s["processes"], "batch": batch, "iterations": s["iterations"],
                 "seconds": s["seconds"], "steps_per_s": steps_s, "pairs_per_s": steps_s * batch,
                 "load_before": before, "load_after": after})
by = {r["run"]: r for r in rows}
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
result = {"date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), "machine": f"{os.cpu_count()} cores, {cpu}",
          "command": "bench/nproc_bench.sh " + str(iters), "train_command": common, "omp_num_threads": 1, "runs": rows,
          "two_vs_one_b2_steps": by["two"]["steps_per_s"] / by["one_b2"]["steps_per_s"],
          "two_vs_one_pairs": by["two"]["pairs_per_s"] / by["one"]["pairs_per_s"]}
json.dump(result, open(out, "w"), indent=1)
print(f"{result['date']}  {result['machine']}")
print("| run | processes | batch | steps/s | pairs/s | load before | load after |")
print("|---|---|---|---|---|---|---|")
for r in rows:
    print(f"| {r['run']} | {r['processes']} | {r['batch']} | {r['steps_per_s']:.2f} | {r['pairs_per_s']:.2f} | {r['load_before']} | {r['load_after']} |")
print(f"two / one_b2 (steps/s, same batch): {result['two_vs_one_b2_steps']:.2f}x; two / one (pairs/s): {result['two_vs_one_pairs']:.2f}x")
PY
