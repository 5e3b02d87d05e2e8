#!/usr/bin/env bash
# How posing time grows with the number of photos: photo-like 640x480 orbits of spider.obj and
# forward-facing views of a held-out procedural scene (radial distortion, noise, JPEG 90;
# intrinsics given) at N views, `nerfreg dbarf poses --method classical`
# against COLMAP 3.8 (Debian `colmap`) and COLMAP 4's global mapper (pycolmap 4.2.1), in one run:
# images posed, rotation and centre errors against the truth, stage timings, per-pair cost, wall
# time, peak memory (GNU time), and the growth exponent of each method's wall time. The renders,
# the COLMAP drivers, the virtualenv and the scoring are bench/real_poses.{sh,py}'s.
# Writes $OUT.json (every number, command lines, versions, the machine) and $OUT.md.
#
# Usage: bench/poses_scale.sh
# Environment: SIZES (default "24 48 96"; "24 48 96 192" for the largest too), TRAJECTORIES (default
#   "orbit forward": spider.obj on an orbit, and procedural scene 5000's forward-facing views), METHODS (default
#   "nerfreg colmap38 colmap4"), NERFREG (default build/nerfreg), WORK (default /tmp/poses_scale),
#   OUT (default results/poses_scale), VENV (default .bench-venv, made as bench/real_poses.sh does),
#   TWO_VIEW_BENCH (default build/bench/nerfreg_two_view_bench: the two-view estimators pair by pair
#   at the smallest size, when built), TWO_VIEW (ransac|usac: nerfreg's `--two-view`; default the
#   binary's own), IMAGE_SIZE (default 640x480: the renders' WxH; e.g. 1008x756 for issue 44's memory check).
# Run it with nice on a shared machine: the times are wall-clock.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
VENV=${VENV:-$ROOT/.bench-venv}
WORK=${WORK:-/tmp/poses_scale}
OUT=${OUT:-$ROOT/results/poses_scale}
SIZES=${SIZES:-"24 48 96"}
TRAJECTORIES=${TRAJECTORIES:-"orbit forward"}
METHODS=${METHODS:-"nerfreg colmap38 colmap4"}
IMAGE_SIZE=${IMAGE_SIZE:-640x480}
SIZE_ARG=""
[ "$IMAGE_SIZE" = 640x480 ] || SIZE_ARG="IMAGE_SIZE=$IMAGE_SIZE "
TWO_VIEW_BENCH=${TWO_VIEW_BENCH:-$ROOT/build/bench/nerfreg_two_view_bench}
[ $# -eq 0 ] || { echo "usage: $0 (set SIZES, METHODS, NERFREG, WORK, OUT, VENV in the environment)" >&2; exit 2; }
command -v colmap >/dev/null || { echo "error: colmap (3.8) not on PATH" >&2; exit 2; }
[ -x "$NERFREG" ] || { echo "error: $NERFREG: not an executable (set NERFREG)" >&2; exit 2; }
[ -x /usr/bin/time ] || echo "warning: /usr/bin/time missing: no peak memory" >&2

# The virtualenv, pinned as bench/real_poses.sh pins it.
PINS="numpy==2.4.6 pillow==11.3.0 pycolmap==4.2.1"
if ! "$VENV/bin/python" -c 'import numpy, PIL, pycolmap; assert pycolmap.__version__ == "4.2.1"' 2>/dev/null; then
  python3 -m venv "$VENV"
  # shellcheck disable=SC2086
  "$VENV/bin/pip" install --quiet $PINS
fi

exec "$VENV/bin/python" "$ROOT/bench/poses_scale.py" run --work "$WORK" --sizes "$SIZES" --trajectories "$TRAJECTORIES" --methods "$METHODS" \
  --nerfreg "$NERFREG" --out-prefix "$OUT" --two-view-bench "$TWO_VIEW_BENCH" \
  --image-size "$IMAGE_SIZE" --command "${SIZE_ARG}SIZES=\"$SIZES\" TRAJECTORIES=\"$TRAJECTORIES\" METHODS=\"$METHODS\"${TWO_VIEW:+ TWO_VIEW=$TWO_VIEW} NERFREG=$NERFREG OUT=$OUT bench/poses_scale.sh"
