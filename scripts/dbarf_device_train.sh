#!/usr/bin/env bash
# DBARF pretraining on one device for a fixed wall time, resumable across calls (docs/gpu.md):
# scripts/gpu_check.sh runs it with GPU_DBARF_DATA, the learned-core binary and --device cuda, to
# train the `paper` configuration on a lease. The scenes are DATA/train.txt's (scripts/dbarf_data.sh;
# rendered here, as the GPU machine has no renderer), trained with their own cameras
# (--scene-cameras ground-truth: the learned core has no SfM, and the original pretrains so).
#   bash scripts/dbarf_device_train.sh NERFREG DATA WORK DEVICE OUT_JSON
# The run stops after DBARF_TRAIN_SECONDS; its last checkpoint (every DBARF_TRAIN_CHECKPOINT steps)
# stays in WORK, and a later call with the same WORK resumes it. Then, with DATA/val.txt, the pose
# network of WORK/dbarf.pt is scored on those scenes by `dbarf eval-net` (from the identity, its own
# cameras choosing the views), there: the paper weights (96 MB) are more than a device call returns.
# OUT_JSON: the steps reached, this call's seconds and steps, whether it resumed or was stopped by
# the time limit, the training log's last row and its means by windows of steps ("log_windows"),
# and the evaluation ("eval_net").
#   DBARF_TRAIN_SECONDS     wall time of this call's training (default 300)
#   DBARF_TRAIN_STEPS       total steps of the schedule (default 20000)
#   DBARF_TRAIN_CONFIG      --config (default paper)
#   DBARF_TRAIN_STAGE       --stage-steps (default 1000)
#   DBARF_TRAIN_CHECKPOINT  --checkpoint-every (default 100)
#   DBARF_TRAIN_WINDOW      steps per row of OUT_JSON's log_windows (default 300)
#   DBARF_TRAIN_ARGS        more dbarf pretrain flags (default --pose-init network: the original's
#                           pose network, from the identity, which eval-net then scores)
set -euo pipefail
if [ $# -lt 5 ]; then
  echo "usage: dbarf_device_train.sh NERFREG DATA WORK DEVICE OUT_JSON" >&2
  exit 2
fi
NERFREG=$1 DATA=$2 WORK=$3 DEVICE=$4 OUT=$5
SECONDS_LIMIT=${DBARF_TRAIN_SECONDS:-300}
PYTHON=${PYTHON:-python3}
[ -x "${NERFREG}" ] || { echo "error: ${NERFREG}: expected the nerfreg binary" >&2; exit 2; }
[ -s "${DATA}/train.txt" ] || { echo "error: ${DATA}/train.txt: expected the scene list of scripts/dbarf_data.sh" >&2; exit 2; }
mkdir -p "${WORK}"
WEIGHTS=${WORK}/dbarf.pt
mapfile -t scenes <"${DATA}/train.txt"
flags=(--scene-cameras ground-truth --config "${DBARF_TRAIN_CONFIG:-paper}" --steps "${DBARF_TRAIN_STEPS:-20000}"
  --stage-steps "${DBARF_TRAIN_STAGE:-1000}" --checkpoint-every "${DBARF_TRAIN_CHECKPOINT:-100}"
  --out "${WEIGHTS}" --device "${DEVICE}" --json)
# shellcheck disable=SC2206  # a list of flags
flags+=(${DBARF_TRAIN_ARGS:---pose-init network})
resumed=false
if [ -f "${WEIGHTS}.train" ]; then
  flags+=(--resume)
  resumed=true
fi
start=${EPOCHREALTIME}
rc=0
# SIGINT first (the trainer's checkpoints are written atomically, so a stop loses at most the steps
# since the last one), SIGKILL 30 s later.
timeout --signal=INT --kill-after=30 "${SECONDS_LIMIT}" "${NERFREG}" dbarf pretrain "${scenes[@]}" "${flags[@]}" \
  >"${WORK}/train.out" 2>"${WORK}/train.err" || rc=$?
end=${EPOCHREALTIME}
eval_rc=-1
if [ -s "${DATA}/val.txt" ] && [ -f "${WEIGHTS}" ]; then
  mapfile -t val <"${DATA}/val.txt"
  eval_rc=0
  "${NERFREG}" dbarf eval-net "${val[@]}" --weights "${WEIGHTS}" --scene-cameras ground-truth --device "${DEVICE}" \
    --json-out "${WORK}/eval_net.json" --force --quiet >"${WORK}/eval_net.out" 2>"${WORK}/eval_net.err" || eval_rc=$?
fi
# The log by windows of steps and stage (scripts/dbarf_log_windows.py): whether the depth collapses.
windows=$("${PYTHON}" "$(dirname "$0")/dbarf_log_windows.py" "${WEIGHTS}.log.jsonl" --window "${DBARF_TRAIN_WINDOW:-300}" 2>/dev/null || echo null)
"${PYTHON}" - "${OUT}" "${WEIGHTS}" "${rc}" "${start}" "${end}" "${resumed}" "${DEVICE}" "${WORK}/train.err" "${eval_rc}" "${WORK}/eval_net.json" "${windows}" <<'PY'
import json, os, re, sys
out, weights, rc, start, end, resumed, device, err, eval_rc, eval_json, windows = sys.argv[1:12]
rc, eval_rc = int(rc), int(eval_rc)
# The step this call started from, as the trainer says it ("resuming OUT at step N"): a stopped
# call's log can run past its last checkpoint, and the trainer rewinds it to there.
before = 0
for line in open(err):
    m = re.search(r"resuming .* at step (\d+)", line)
    if m:
        before = int(m.group(1))
rows = []
if os.path.exists(weights + ".log.jsonl"):
    for line in open(weights + ".log.jsonl"):
        try:
            rows.append(json.loads(line))
        except ValueError:
            pass
last = rows[-1] if rows else {}
result = {"device": device, "exit_code": rc, "stopped_by_time_limit": rc in (124, 130, 137),
          "resumed": resumed == "true", "seconds": round(float(end) - float(start), 2),
          "step_before": int(before), "step_reached": last.get("step", 0), "log_last": last,
          "weights": weights, "checkpoint": os.path.exists(weights + ".train"),
          "stderr_tail": [l for l in open(err).read().splitlines() if l.strip()][-3:] if rc else []}
result["log_windows"] = json.loads(windows)
steps = result["step_reached"] - result["step_before"]
result["steps_this_call"] = steps
result["steps_per_second"] = round(steps / result["seconds"], 3) if result["seconds"] > 0 else None
if eval_rc >= 0:
    try:
        evaluation = json.load(open(eval_json)) if eval_rc == 0 else {}
    except (OSError, ValueError) as e:
        evaluation = {"error": str(e)}
    evaluation.pop("rows", None)
    result["eval_net"] = dict(evaluation, exit_code=eval_rc)
tmp = out + ".tmp"
with open(tmp, "w") as f:
    json.dump(result, f, indent=2)
    f.write("\n")
os.replace(tmp, out)
print("dbarf_device_train: step %d -> %d in %.0f s on %s (exit %d); wrote %s"
      % (result["step_before"], result["step_reached"], result["seconds"], device, rc, out))
trained = rc == 0 or (result["stopped_by_time_limit"] and result["checkpoint"])
sys.exit(0 if trained and eval_rc <= 0 else 1)
PY
