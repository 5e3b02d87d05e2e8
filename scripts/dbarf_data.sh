#!/usr/bin/env bash
# Renders the DBARF pose-network data: procedural forward-facing scenes (20 views, 128x96, every 8th
# a test view), with ground-truth cameras (and per-frame near / far) in each transforms.json.
#   SETS   space-separated SPLIT:FIRST:COUNT:MATERIAL:SPREAD[:VIEWS] entries, SPLIT train, val or
#          val_extra (validation scenes kept apart from val.txt, in DATA/val_extra.txt, so the
#          validation sets of earlier runs keep their meaning), MATERIAL textured, low-texture or
#          repetitive (render --material), SPREAD the camera spiral's half-extent (render --spread;
#          0.35 is the default, wider baselines above), VIEWS the views on that spiral (default
#          $VIEWS; fewer views, wider baselines between neighbours). Default:
#            train 2001-2300 textured, 2301-2400 low-texture, 2401-2500 repetitive, 2501-2600
#            textured at spread 0.7, 2601-2750 low-texture and 2751-2800 textured with 10 views
#            (added 2026-11-26: low-texture sets of 10 views were the pose network's weakest);
#            val 3001-3012 textured (choose models and settings on these), 3013-3016 low-texture,
#            3017-3020 repetitive, 3021-3024 spread 0.7; val_extra 3025-3030 low-texture, 10 views.
#   TRAJECTORY  forward (default: look-at views, the shipped weights' data), llff (hand-held,
#          nearly parallel axes, layered depth: render --trajectory llff; SPREAD 0 keeps its own
#          default, 0.25) or room (a walk through a room; SPREAD is not used, give 0).
#   Seeds 201-203 are the held-out test scenes (bench/dbarf_novel_views.sh) and 5000 and above the
#   benches' (bench/dbarf_poses_bench.sh): never rendered here, never trained or chosen on.
# Writes DATA/SPLIT_SEED/ and the lists DATA/train.txt, DATA/val.txt (one transforms.json a line;
# DATA/val_textured.txt the textured validation scenes alone). Scenes already rendered are kept, so
# re-running extends or resumes.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
DATA=${DATA:-data/dbarf_poses}
VIEWS=${VIEWS:-20}
TRAJECTORY=${TRAJECTORY:-forward}
SETS=${SETS:-"train:2001:300:textured:0.35 train:2301:100:low-texture:0.35 train:2401:100:repetitive:0.35 train:2501:100:textured:0.7 train:2601:150:low-texture:0.35:10 train:2751:50:textured:0.35:10 val:3001:12:textured:0.35 val:3013:4:low-texture:0.35 val:3017:4:repetitive:0.35 val:3021:4:textured:0.7 val_extra:3025:6:low-texture:0.35:10"}
mkdir -p "$DATA"
for s in $SETS; do
  IFS=: read -r split first count material spread views <<< "$s"
  last=$((first + count - 1))
  if [ "$first" -le 203 ] && [ "$last" -ge 201 ] || [ "$last" -ge 5000 ]; then
    echo "error: SETS: $s: expected seeds outside the test scenes 201-203 and the benches' 5000+" >&2
    exit 2
  fi
  case "$split" in train|val|val_extra) ;; *) echo "error: SETS: $s: expected SPLIT train, val or val_extra" >&2; exit 2 ;; esac
done
: > "$DATA/train.txt.tmp"
: > "$DATA/val.txt.tmp"
: > "$DATA/val_textured.txt.tmp"
: > "$DATA/val_extra.txt.tmp"
for s in $SETS; do
  IFS=: read -r split first count material spread views <<< "$s"
  for seed in $(seq "$first" $((first + count - 1))); do
    d=$DATA/${split}_${seed}
    [ -f "$d/transforms.json" ] || "$BIN" render --procedural "$seed" --trajectory "$TRAJECTORY" --views "${views:-$VIEWS}" \
      --material "$material" --spread "$spread" --test-every 8 --quiet --out "$d" --force
    echo "$d/transforms.json" >> "$DATA/$split.txt.tmp"
    if [ "$split" = val ] && [ "$material" = textured ] && [ "$spread" = 0.35 ]; then
      echo "$d/transforms.json" >> "$DATA/val_textured.txt.tmp"
    fi
  done
done
mv "$DATA/train.txt.tmp" "$DATA/train.txt"
mv "$DATA/val.txt.tmp" "$DATA/val.txt"
mv "$DATA/val_textured.txt.tmp" "$DATA/val_textured.txt"
mv "$DATA/val_extra.txt.tmp" "$DATA/val_extra.txt"
echo "$(wc -l < "$DATA/train.txt") train scenes, $(wc -l < "$DATA/val.txt") validation scenes in $DATA"
