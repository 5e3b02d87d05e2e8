#!/usr/bin/env bash
# The nerfreg commands users run, on one device, end to end (docs/gpu.md): scripts/gpu_check.sh runs
# it with the learned-core build's binary and --device cuda; tests/cli_device_check_test runs it on
# the CPU with the full build's, so its flags are checked on every CI run.
#   bash scripts/cli_device_check.sh NERFREG DATASET WORK DEVICE OUT_JSON [PAIRS_JSON]
# On DATASET (a posed block: transforms.json with test frames) it trains a block on DEVICE in two
# halves (--stop-after, then --resume), evaluates it there and on the CPU (the checkpoint is
# portable: the two PSNRs must agree within 0.05 dB), renders its test cameras, exports points and
# extracts its registration grid; then it pretrains DBARF on DATASET's images and cameras in two
# halves (--resume; --scene-cameras ground-truth: the learned core has no SfM) and finetunes the
# result; then it trains the DReg-NeRF network for a few steps on PAIRS_JSON (pairs of grids, e.g.
# bench/gpu_dreg.cc's pairs_gpu.json), or without it on the block's own grid paired with itself.
# Every command's exit code, seconds and printed JSON go into OUT_JSON; the script fails if any
# command failed.
#   CLI_CHECK_ITERS         block training iterations (default 1000)
#   CLI_CHECK_PRESET        block training preset (default fast)
#   CLI_CHECK_SAMPLES       block training samples per step (default: the preset's)
#   CLI_CHECK_CONFIG        reg train --config (default paper)
#   CLI_CHECK_DBARF_STEPS   dbarf pretrain steps (default 40; finetune: a quarter)
#   CLI_CHECK_DBARF_CONFIG  dbarf pretrain --config (default paper)
set -euo pipefail
if [ $# -lt 5 ]; then
  echo "usage: cli_device_check.sh NERFREG DATASET WORK DEVICE OUT_JSON [PAIRS_JSON]" >&2
  exit 2
fi
NERFREG=$1 DATASET=$2 WORK=$3 DEVICE=$4 OUT=$5 PAIRS=${6:-}
ITERS=${CLI_CHECK_ITERS:-1000}
PRESET=${CLI_CHECK_PRESET:-fast}
SAMPLES=${CLI_CHECK_SAMPLES:-}
PYTHON=${PYTHON:-python3}
[ -x "${NERFREG}" ] || { echo "error: ${NERFREG}: expected the nerfreg binary" >&2; exit 2; }
[ -f "${DATASET}/transforms.json" ] || { echo "error: ${DATASET}: expected a folder with transforms.json" >&2; exit 2; }
# WORK is replaced, but only if this script made it (its steps.jsonl) or it is empty.
if [ -d "${WORK}" ] && [ -n "$(ls -A "${WORK}")" ] && [ ! -f "${WORK}/steps.jsonl" ]; then
  echo "error: ${WORK}: expected an empty folder or one this script wrote (no steps.jsonl in it)" >&2
  exit 2
fi
rm -rf "${WORK}"
mkdir -p "${WORK}"
STEPS=${WORK}/steps.jsonl
: >"${STEPS}"
failed=0

# step NAME COMMAND...: runs it with --quiet, keeps its stdout's last line (the commands print JSON)
# and its stderr, and appends {name, exit_code, seconds, printed} to STEPS.
step() {
  local name=$1
  shift
  local start rc=0
  start=${EPOCHREALTIME}
  "$@" --quiet >"${WORK}/${name}.out" 2>"${WORK}/${name}.err" || rc=$?
  "${PYTHON}" - "${name}" "${rc}" "${start}" "${EPOCHREALTIME}" "${WORK}/${name}.out" "${WORK}/${name}.err" "$*" \
    >>"${STEPS}" <<'PY'
import json, sys
name, rc, start, end, out, err, command = sys.argv[1:8]
seconds = float(end) - float(start)
lines = [l for l in open(out).read().splitlines() if l.strip()]
try:
    printed = json.loads(lines[-1]) if lines else None
except ValueError:
    printed = lines[-1]
error = [l for l in open(err).read().splitlines() if l.strip()][-3:]
print(json.dumps({"name": name, "exit_code": int(rc), "seconds": round(seconds, 2), "printed": printed,
                  "stderr_tail": error if int(rc) else [], "command": command}))
print("cli_device_check: %s: exit %s, %.1f s" % (name, rc, seconds), file=sys.stderr)
PY
  if [ "${rc}" -ne 0 ]; then
    failed=1
    tail -n 5 "${WORK}/${name}.err" >&2
  fi
}

HALF=$((ITERS / 2))
step nerf_train_half "${NERFREG}" nerf train "${DATASET}" --out "${WORK}/block.ckpt" --preset "${PRESET}" \
  --iters "${ITERS}" --stop-after "${HALF}" --device "${DEVICE}" ${SAMPLES:+--samples "${SAMPLES}"}
step nerf_train_resume "${NERFREG}" nerf train "${DATASET}" --out "${WORK}/block.ckpt" --preset "${PRESET}" \
  --iters "${ITERS}" --resume --device "${DEVICE}" ${SAMPLES:+--samples "${SAMPLES}"}
step nerf_eval "${NERFREG}" nerf eval "${WORK}/block.ckpt" "${DATASET}" --device "${DEVICE}"
step nerf_eval_cpu "${NERFREG}" nerf eval "${WORK}/block.ckpt" "${DATASET}" --device cpu
step nerf_render "${NERFREG}" nerf render "${WORK}/block.ckpt" --transforms "${DATASET}/transforms.json" \
  --out "${WORK}/views" --device "${DEVICE}"
step nerf_export "${NERFREG}" nerf export "${WORK}/block.ckpt" --points "${WORK}/points.ply" --device "${DEVICE}"
step reg_extract "${NERFREG}" reg extract "${WORK}/block.ckpt" --out "${WORK}/block.grid" --device "${DEVICE}"
DBARF_STEPS=${CLI_CHECK_DBARF_STEPS:-40}
DBARF_HALF=$((DBARF_STEPS / 2))
# Short stage blocks, so every stage (pose, NeRF, joint) runs in each half.
DBARF_STAGE=$((DBARF_STEPS / 8 > 0 ? DBARF_STEPS / 8 : 1))
step dbarf_pretrain_half "${NERFREG}" dbarf pretrain "${DATASET}" --scene-cameras ground-truth \
  --config "${CLI_CHECK_DBARF_CONFIG:-paper}" --steps "${DBARF_HALF}" --checkpoint-every "${DBARF_HALF}" \
  --stage-steps "${DBARF_STAGE}" --out "${WORK}/dbarf.pt" --device "${DEVICE}" --json
step dbarf_pretrain_resume "${NERFREG}" dbarf pretrain "${DATASET}" --scene-cameras ground-truth \
  --config "${CLI_CHECK_DBARF_CONFIG:-paper}" --steps "${DBARF_STEPS}" --stage-steps "${DBARF_STAGE}" --resume \
  --out "${WORK}/dbarf.pt" --device "${DEVICE}" --json
step dbarf_finetune "${NERFREG}" dbarf finetune "${DATASET}" --scene-cameras ground-truth \
  --weights "${WORK}/dbarf.pt" --steps $((DBARF_STEPS / 4 > 0 ? DBARF_STEPS / 4 : 1)) --stage-steps "${DBARF_STAGE}" \
  --out "${WORK}/dbarf_finetuned.pt" --device "${DEVICE}" --json
# Without PAIRS_JSON, reg train runs on the block's own grid paired with itself: the trainer moves
# the source at random (up to 180 deg), so the pair is a registration task all the same.
if [ -z "${PAIRS}" ] && [ -f "${WORK}/block.grid" ]; then
  PAIRS=${WORK}/self_pair.json
  "${PYTHON}" - "${WORK}/block.grid" "${PAIRS}" <<'PY'
import json, os, sys
grid, out = sys.argv[1:3]
grid = os.path.abspath(grid)  # the trainer reads paths relative to the pairs file
eye = [[1.0 if r == c else 0.0 for c in range(4)] for r in range(4)]
pair = {"name": "self", "object": "self", "kind": "nerf", "split": "train", "source": grid, "target": grid,
        "target_from_source": eye, "overlap": 1.0}
json.dump({"pairs": [pair]}, open(out, "w"), indent=2)
PY
fi
if [ -n "${PAIRS}" ]; then
  step reg_train "${NERFREG}" reg train "${PAIRS}" --out "${WORK}/dreg.pt" --config "${CLI_CHECK_CONFIG:-paper}" \
    --iters 20 --val-every 10 --checkpoint-every 10 --device "${DEVICE}"
fi

"${PYTHON}" - "${STEPS}" "${OUT}" "${DEVICE}" <<'PY'
import json, os, sys
steps_path, out, device = sys.argv[1:4]
steps = [json.loads(l) for l in open(steps_path)]
by = {s["name"]: s for s in steps}
def psnr(name):
    p = by.get(name, {}).get("printed")
    return p.get("psnr") if isinstance(p, dict) else None
on_device, on_cpu = psnr("nerf_eval"), psnr("nerf_eval_cpu")
result = {"device": device, "steps": steps, "psnr_device": on_device, "psnr_cpu": on_cpu,
          "psnr_agree": on_device is not None and on_cpu is not None and abs(on_device - on_cpu) <= 0.05,
          "all_exit_zero": all(s["exit_code"] == 0 for s in steps)}
tmp = out + ".tmp"
with open(tmp, "w") as f:
    json.dump(result, f, indent=2)
    f.write("\n")
os.replace(tmp, out)
print("cli_device_check: psnr %s on %s, %s on the cpu; wrote %s" % (on_device, device, on_cpu, out))
sys.exit(0 if result["all_exit_zero"] and result["psnr_agree"] else 1)
PY
exit "${failed}"
