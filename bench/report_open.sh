#!/usr/bin/env bash
# How fast a report opens: headless Chromium (software WebGL) loads the page RUNS times; prints
# the page size, the page's own time to its load event (scripts parsed, 3D views drawn; the
# data-load-ms the page records) and the wall time of the whole browser run (start-up included).
# Usage: bench/report_open.sh [REPORT_HTML]   (default runs/demo/report.html, from `make demo`)
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
REPORT=${1:-$ROOT/runs/demo/report.html}
RUNS=${RUNS:-5}
[ -f "$REPORT" ] || { echo "error: $REPORT: report: expected a file (make demo writes runs/demo/report.html)" >&2; exit 2; }
REPORT=$(cd "$(dirname "$REPORT")" && pwd)/$(basename "$REPORT")
echo "report: $REPORT ($(du -k "$REPORT" | cut -f1) KiB)"
printf "%4s %12s %10s %14s\n" run load_ms wall_s drawn_pixels
for i in $(seq 1 "$RUNS"); do
  start=$(date +%s.%N)
  dom=$(timeout 120 chromium --headless --no-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader \
        --dump-dom "file://$REPORT" 2>/dev/null)
  end=$(date +%s.%N)
  load=$(grep -o 'data-load-ms="[0-9]*"' <<< "$dom" | grep -o '[0-9]*' || echo "?")
  drawn=$(grep -o 'data-drawn-pixels="[0-9]*"' <<< "$dom" | grep -o '[0-9]*' | paste -sd, || true)
  printf "%4d %12s %10.2f %14s\n" "$i" "$load" "$(echo "$end - $start" | bc)" "${drawn:--}"
done
echo "machine: $(nproc) cores, $(chromium --version 2>/dev/null | head -1), $(date -u +%FT%TZ)"
