#!/usr/bin/env bash
# Poses of real photos: `nerfreg dbarf poses` (--method classical, the default auto, network, and without
# intrinsics) against COLMAP 3.8 (Debian `colmap`: feature_extractor, exhaustive_matcher, mapper;
# with the intrinsics and without) and COLMAP 4's global mapper (pycolmap 4.2.1: extract_features,
# match_exhaustive, global_mapping), in one run, one method after another, each timed.
# Sets (fixed in bench/real_poses.py): ViSP's real sequence cube/ (uncalibrated), the rendered
# Castle-simu (ground-truth poses) and a photo-like nerfreg render of spider.obj (radial distortion,
# noise, JPEG; ground truth); SETS=mbt_cube / mire2 add ViSP's mbt/cube and mire-2, left out by
# default because their camera stands still while a hand moves the object (no rigid scene). Writes $OUT.json (every number, command line, version,
# the machine) and $OUT.md (the tables).
#
# Usage: bench/real_poses.sh [--quick] [--views 24|48|96]
#   --quick: the Castle-simu set only (SETS= names the sets otherwise)
#   --views: views of the spider render (default 24)
# Environment: NERFREG (default build/nerfreg), SETS (default "cube castle spider"),
#   METHODS (default "nerfreg colmap38 colmap4"), WORK (default /tmp/real_poses), OUT (default
#   results/real_poses), VENV (default .bench-venv: made here with pinned numpy, pillow, pycolmap),
#   TWO_VIEW (ransac|usac: nerfreg's `--two-view`; default the binary's own), SEEDS (default
#   "1 2 3 4": nerfreg's uncalibrated run, and its classical run on the sets with a truth, again with
#   `--seed S`; "" for none).
# Needs colmap 3.8 on PATH, python3 with venv, PyPI (first run only); installs visp-images-data
# (scripts/setup.sh) where it is missing.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
VENV=${VENV:-$ROOT/.bench-venv}
WORK=${WORK:-/tmp/real_poses}
OUT=${OUT:-$ROOT/results/real_poses}
SETS=${SETS:-"cube castle spider"}
METHODS=${METHODS:-"nerfreg colmap38 colmap4"}
SEEDS=${SEEDS-"1 2 3 4"}
VIEWS=24
ARGS="$*"
while [ $# -gt 0 ]; do
  case $1 in
    --quick) SETS=castle ;;
    --views) VIEWS=$2; shift ;;
    *) echo "usage: $0 [--quick] [--views N]" >&2; exit 2 ;;
  esac
  shift
done
# ViSP's image sets (cube, Castle-simu), which only this bench reads.
bash "$ROOT/scripts/setup.sh" visp-images-data
command -v colmap >/dev/null || { echo "error: colmap (3.8) not on PATH" >&2; exit 2; }
[ -x "$NERFREG" ] || { echo "error: $NERFREG: not an executable (set NERFREG)" >&2; exit 2; }

# The virtualenv, every package pinned.
PINS="numpy==2.4.6 pillow==11.3.0 pycolmap==4.2.1"
if ! "$VENV/bin/python" -c 'import numpy, PIL, pycolmap; assert pycolmap.__version__ == "4.2.1"' 2>/dev/null; then
  python3 -m venv "$VENV"
  # shellcheck disable=SC2086
  "$VENV/bin/pip" install --quiet $PINS
fi

exec "$VENV/bin/python" "$ROOT/bench/real_poses.py" run --work "$WORK" --sets "$SETS" --methods "$METHODS" \
  --spider-views "$VIEWS" --seeds "$SEEDS" --nerfreg "$NERFREG" --out-prefix "$OUT" \
  --command "SETS=\"$SETS\" METHODS=\"$METHODS\" SEEDS=\"$SEEDS\"${TWO_VIEW:+ TWO_VIEW=$TWO_VIEW} NERFREG=$NERFREG OUT=$OUT bench/real_poses.sh $ARGS"
