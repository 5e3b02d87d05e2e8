#!/usr/bin/env bash
# Pairs of different objects, which no registration should call registered (issue 43: "an unrelated
# pair exits non-zero with status set"), with an untrusted result registered the other way too
# (RegisterEitherWay): does a second way ever register what the first called untrusted? Reads the
# captures and trained blocks of a bench/registration_sim3.sh WORK folder: block 0's splats of each
# of objects 6000-6003 onto block 1's splats of each other one (12 pairs), and block 0 of 5 block
# sets onto block 1 of 4 others (20 pairs); `reg register --seed 0`, the default (auto, field
# refinement, scale free). One line per pair: name, exit code, status, confidence, kept method,
# the other way (kept, its status and confidence), seconds. No results file: the lines are the
# output (docs/registration.md, "The other way").
# Usage: WORK=<registration_sim3 WORK> bench/unrelated_pairs.sh [reg register flags...]
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
NERFREG=${NERFREG:-$ROOT/build/nerfreg}
: "${WORK:?WORK: a bench/registration_sim3.sh work folder (its o6000-o6003 and blocks_* sets)}"
OUT=${OUT:-$(mktemp -d /tmp/unrelated_pairs.XXXXXX)}
mkdir -p "$OUT"
pairs=()
for a in 6000 6001 6002 6003; do
  for b in 6000 6001 6002 6003; do
    [ "$a" = "$b" ] || pairs+=("$WORK/o$a/block_0/splats.ply:$WORK/o$b/block_1/splats.ply:captures_${a}_$b")
  done
done
for a in 6000_1 6001_1 6008_2 6011_4 6012_7; do
  for b in 6002_1 6003_1 6009_2 6013_5; do
    pairs+=("$WORK/blocks_$a/b0.ckpt:$WORK/blocks_$b/b1.ckpt:blocks_${a}_$b")
  done
done
for p in "${pairs[@]}"; do
  IFS=: read -r source target name <<< "$p"
  rc=0
  "$NERFREG" reg register "$source" "$target" --seed 0 --quiet --force --out "$OUT/$name.json" "$@" > /dev/null \
    2> "$OUT/$name.err" || rc=$?
  python3 - "$OUT/$name.json" "$name" "$rc" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))
r = t.get("reverse")
other = "-" if r is None else "%s %s %.3f" % ("kept" if r["kept"] else "not-kept", r["other_way"]["status"],
                                             r["other_way"]["confidence"])
print(sys.argv[2], sys.argv[3], t["status"], "%.3f" % t["confidence"], t["method"], other, "%.1f" % t["seconds"])
PY
done
