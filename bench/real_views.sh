#!/usr/bin/env bash
# Novel views of held-out real photos (issue 45 item 3): ViSP's real cube sequence (the frames of
# bench/real_poses.sh's `cube` set), posed by `nerfreg dbarf poses` (self-calibrated: the set has no
# calibration file), every 6th image held out. The held-out images are rendered at their classical
# cameras by the generalizable renderer (`dbarf eval --cameras`), once with the shipped weights and
# once after the paper's per-scene finetune of the renderer on the other images (`dbarf finetune
# --schedule nerf --nerf-poses cameras`, which never sees the held-out images). PSNR / SSIM per view.
# Writes $OUT.json and $OUT.md.
#
# Usage: bench/real_views.sh
# Environment: NERFREG (default build/nerfreg), WORK (default /tmp/real_views), OUT (default
#   results/real_views), STEPS (finetune steps, default 400), WIDTH (render width, default 160),
#   VENV (default .bench-venv, made as bench/real_poses.sh does).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
VENV=${VENV:-$ROOT/.bench-venv}
WORK=${WORK:-/tmp/real_views}
OUT=${OUT:-$ROOT/results/real_views}
STEPS=${STEPS:-400}
WIDTH=${WIDTH:-160}
bash "$ROOT/scripts/setup.sh" visp-images-data
[ -x "$NERFREG" ] || { echo "error: $NERFREG: not an executable (set NERFREG)" >&2; exit 2; }
PINS="numpy==2.4.6 pillow==11.3.0 pycolmap==4.2.1"
if ! "$VENV/bin/python" -c 'import numpy, PIL, pycolmap; assert pycolmap.__version__ == "4.2.1"' 2>/dev/null; then
  python3 -m venv "$VENV"
  # shellcheck disable=SC2086
  "$VENV/bin/pip" install --quiet $PINS
fi
exec "$VENV/bin/python" "$ROOT/bench/real_views.py" --work "$WORK" --nerfreg "$NERFREG" --out-prefix "$OUT" \
  --steps "$STEPS" --width "$WIDTH" \
  --command "NERFREG=$NERFREG STEPS=$STEPS WIDTH=$WIDTH OUT=$OUT bench/real_views.sh"
