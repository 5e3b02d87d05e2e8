#!/usr/bin/env bash
# Trains DBARF's pose network to pose images from the identity (--pose-init network, the original's
# start) on the scenes of scripts/dbarf_data.sh, pose stage only (the NeRF of the starting weights
# is kept as it is), with the supervised pose loss (--supervise-poses, a departure: SUPERVISE=0
# trains self-supervised only; SUPERVISE_DEPTH=W adds an SfM loss on the predicted depth with the
# sources placed by the true relative poses, another departure, default 1 since the depth update
# keeps its gradient at the range's bounds). SCENE_CAMERAS=ground-truth (default) trains on the
# datasets' own cameras, views chosen by true camera distance as the original trains (no SfM, so
# low-texture and repetitive scenes are usable); estimated runs the SfM per scene (cached).
# Resumable: RESUME=1 continues OUT from OUT.train; otherwise it refuses to overwrite OUT (FORCE=1
# overwrites). Runs on one core (OMP_NUM_THREADS=1, nice) so it can stay in the background:
#   nohup bash scripts/dbarf_pose_train.sh > runs/dbarf_pose/train.out 2>&1 &
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
DATA=${DATA:-data/dbarf_poses}
OUT=${OUT:-runs/dbarf_pose/dbarf_pose.pt}
STEPS=${STEPS:-100000}
SUPERVISE=${SUPERVISE:-1}
WEIGHTS=${WEIGHTS:-models/dbarf_pose_cpu.pt}   # the NeRF and the starting pose network
SCENE_CAMERAS=${SCENE_CAMERAS:-ground-truth}
ROTATION_SCALE=${ROTATION_SCALE:-1}       # pose heads' rotation scale (the original 0.01 turns too slowly)
LR_POSE=${LR_POSE:-2e-4}
LR_DECAY_STEPS=${LR_DECAY_STEPS:-20000}
SCENES=${SCENES:-0}                       # use the first SCENES training scenes (0: all)
CHECKPOINT_EVERY=${CHECKPOINT_EVERY:-200}
BLUR=${BLUR:-0.25}                        # --augment-blur: the pose network sees a blurred target this often
AUTO_MASK=${AUTO_MASK:-true}              # --auto-mask of the SfM loss (false: stage 5; with it the depth stays at the backdrop)
SFM_CACHE=${SFM_CACHE:-$(dirname "$OUT")/sfm_cache}   # cameras estimated per scene, reused on --resume
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
[ -f "$DATA/train.txt" ] || { echo "error: $DATA/train.txt: expected the scene list of scripts/dbarf_data.sh" >&2; exit 2; }
mkdir -p "$(dirname "$OUT")"
mapfile -t scenes < "$DATA/train.txt"
[ "$SCENES" -gt 0 ] && scenes=("${scenes[@]:0:$SCENES}")
# One stage block longer than the run: the pose stage throughout.
flags=(--pose-init network --stage-steps 1000000000 --steps "$STEPS" --supervise-poses "$SUPERVISE" --supervise-rotation-weight "${ROTATION_WEIGHT:-5}" --supervise-depth "${SUPERVISE_DEPTH:-1}" --augment-blur "$BLUR" --auto-mask "$AUTO_MASK"
       --rotation-scale "$ROTATION_SCALE" --lr-pose "$LR_POSE" --lr-decay-steps "$LR_DECAY_STEPS"
       --checkpoint-every "$CHECKPOINT_EVERY" --sfm-cache "$SFM_CACHE" --scene-cameras "$SCENE_CAMERAS" --out "$OUT")
if [ "${RESUME:-0}" = 1 ]; then
  flags+=(--resume)
else
  flags+=(--weights "$WEIGHTS")
  [ "${FORCE:-0}" = 1 ] && flags+=(--force)
fi
exec nice -n 5 "$BIN" dbarf pretrain "${scenes[@]}" "${flags[@]}"
