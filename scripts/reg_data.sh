#!/usr/bin/env bash
# Makes the DReg-NeRF training and held-out evaluation data used for the shipped weights
# (models/dreg_cpu.pt). Resumable: re-running skips finished objects. Only the Debian test meshes
# below and procedural objects are used (docs/data.md).
#   train: procedural objects 1000.. and the Debian test meshes below, pairs synthesised from the
#          meshes (reg_data/synthetic_grids.h);
#   train_nerf: real block pairs of two training meshes (tuning the field refinement);
#   train_nerf_proc: real block pairs of 12 training procedural objects;
#   train_nerf_proc4, train_nerf_proc4b: real block pairs of 4-block splits of 86 more training procedural objects;
#   train2: 100 more procedural objects (2000..), synthesised pairs;
#   val:   held-out objects (spider, the milk truck, procedural 5000..), synthesised pairs (2- and
#          4-block splits) AND pairs of real trained NeRF blocks (2-block split of the two meshes
#          and of procedural 5000-5005; 4-block splits of the spider and of procedural 5000-5005).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/nerfreg}
OUT=${OUT:-data/reg}
RES=${RES:-32}
PROCEDURAL=${PROCEDURAL:-60}
A=/usr/share/assimp/models
S=/usr/share/openscad/testdata
TRAIN_MESHES=(
  $A/OBJ/WusonOBJ.obj $A/OBJ/regr01.obj $A/STL/3DSMaxExport.STL $A/STL/sphereWithHole.stl
  $S/scad/misc/bad-stl-tardis.stl $S/scad/misc/bad-stl-wing.stl $S/scad/misc/bad-stl-pcbvicebar.stl
  $S/stl/adns2610_dev_circuit_inv.stl $S/scad/bugs/issue945e.stl $A/glTF/TwoBoxes/TwoBoxes.gltf
)
VAL_MESHES=($A/OBJ/spider.obj $A/glTF/CesiumMilkTruck/CesiumMilkTruck.gltf)
common=(--grid-resolution "$RES" --quiet)
# Training pairs: 4 per object (synthesised, different random frames).
"$BIN" reg make-data --meshes "${TRAIN_MESHES[@]}" --procedural "$PROCEDURAL" --procedural-seed 1000 \
  --mesh-pairs 4 --split train --out "$OUT/train" "${common[@]}"
# More training pairs: 100 further procedural objects (from the third training stage of the
# shipped weights on, docs/notes/2026-11-24-dreg-stages.md).
"$BIN" reg make-data --procedural 100 --procedural-seed 2000 --mesh-pairs 4 --split train --out "$OUT/train2" "${common[@]}"
# Held-out pairs, synthesised: 2 per object.
"$BIN" reg make-data --meshes "${VAL_MESHES[@]}" --procedural 16 --procedural-seed 5000 --mesh-pairs 2 \
  --split val --out "$OUT/val_mesh" "${common[@]}"
# Held-out pairs, synthesised, adjacent blocks of a 4-block split (lower overlap: 0.70-0.98).
"$BIN" reg make-data --meshes "${VAL_MESHES[@]}" --procedural 16 --procedural-seed 5000 --mesh-pairs 2 --blocks 4 \
  --split val --out "$OUT/val_mesh4" "${common[@]}"
# Sweet Home 3D furniture (models/sh3f_split.json; docs/data.md), synthesised pairs in the frame
# reg register --scale free gives the network (--scale-augment 2), one pair per mesh: train (2- and
# 4-block splits), val (both; the choice between checkpoints) and test (both; bench/dreg_real_shapes.sh,
# reported once). SH3F_TRAIN2_LIMIT / SH3F_TRAIN4_LIMIT: the first N training meshes only (0: all);
# the fine-tune of 2026-11-28 (scripts/dreg_sh3f_train.sh) had 109 and 283 of them.
SH3F_OUT=${SH3F_OUT:-data/reg_sh3f}
sh3f=(--mesh-pairs 1 --scale-augment 2 "${common[@]}")
"$BIN" reg make-data --meshes sh3f:train --sh3f-limit "${SH3F_TRAIN2_LIMIT:-0}" --blocks 2 --out "$SH3F_OUT/train2" "${sh3f[@]}"
"$BIN" reg make-data --meshes sh3f:train --sh3f-limit "${SH3F_TRAIN4_LIMIT:-0}" --blocks 4 --out "$SH3F_OUT/train4" "${sh3f[@]}"
for split in val test; do
  "$BIN" reg make-data --meshes "sh3f:$split" --blocks 2 --out "$SH3F_OUT/${split}2" "${sh3f[@]}"
  "$BIN" reg make-data --meshes "sh3f:$split" --blocks 4 --out "$SH3F_OUT/${split}4" "${sh3f[@]}"
done
# Held-out pairs of real NeRF blocks (the slow part: ~3 min a block on 2 cores).
[ "${SKIP_NERF:-0}" = 1 ] && exit 0
# Real block pairs of two training meshes: the tuning set of the field refinement
# (reg/field_alignment.h; docs/notes/2026-11-23-grids-icp-half-turn.md, "Field refinement tuning").
"$BIN" reg make-data --meshes "$A/OBJ/WusonOBJ.obj" "$A/OBJ/regr01.obj" --mesh-pairs 0 --nerf-objects 2 --split train \
  --out "$OUT/train_nerf" "${common[@]}"
# Real block pairs of 12 training procedural objects (1000-1011, the first of train): training pairs
# from real fields (added in the fifth stage of the shipped weights, docs/notes/2026-11-24-dreg-stages.md).
"$BIN" reg make-data --procedural 12 --procedural-seed 1000 --mesh-pairs 0 --nerf-objects 12 --split train \
  --out "$OUT/train_nerf_proc" "${common[@]}"
# Real block pairs of 4-block splits of 86 more training procedural objects (1012-1090 and
# 1200-1206; all 6 pairs of the 4 blocks, overlap 0.41-0.99): the low-overlap real training pairs of
# the sixth stage (the first 20), the seventh and eighth (the first 40), the ninth (the first 51) and
# stage 12c, shipped (all 86) (docs/notes/2026-11-24-dreg-stages.md; minutes an object, docs/data.md;
# the two folders can be made side by side with OMP_NUM_THREADS=1 each).
"$BIN" reg make-data --procedural 79 --procedural-seed 1012 --mesh-pairs 0 --nerf-objects 79 --blocks 4 --split train \
  --out "$OUT/train_nerf_proc4" "${common[@]}"
"$BIN" reg make-data --procedural 7 --procedural-seed 1200 --mesh-pairs 0 --nerf-objects 7 --blocks 4 --split train \
  --out "$OUT/train_nerf_proc4b" "${common[@]}"
"$BIN" reg make-data --meshes "${VAL_MESHES[@]}" --mesh-pairs 0 --nerf-objects 100 --split val \
  --out "$OUT/val_nerf" "${common[@]}"
# Real block pairs of 6 held-out procedural objects (the first 6 of the synthesised held-out set).
"$BIN" reg make-data --procedural 6 --procedural-seed 5000 --mesh-pairs 0 --nerf-objects 6 --split val \
  --out "$OUT/val_nerf_proc" "${common[@]}"
# Lower overlap: pairs of a 4-block split.
"$BIN" reg make-data --meshes "$A/OBJ/spider.obj" --mesh-pairs 0 --nerf-objects 100 --blocks 4 --split val \
  --out "$OUT/val_nerf4" "${common[@]}"
"$BIN" reg make-data --procedural 6 --procedural-seed 5000 --mesh-pairs 0 --nerf-objects 6 --blocks 4 --split val \
  --out "$OUT/val_nerf_proc4" "${common[@]}"
# A fresh held-out test set, made after every choice above was taken on val_nerf_proc4: 4-block
# splits of procedural objects 6000-6003 (24 pairs, overlap 0.51-0.90; 24 min beside training).
"$BIN" reg make-data --procedural 4 --procedural-seed 6000 --mesh-pairs 0 --nerf-objects 4 --blocks 4 --split val \
  --out "$OUT/test_nerf_proc4" "${common[@]}"
