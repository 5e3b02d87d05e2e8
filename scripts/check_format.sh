#!/usr/bin/env bash
# The C++ sources are formatted by .clang-format (clang-format 14, Debian's): exits 1 naming every
# file that differs. Run with --fix to rewrite them in place.
set -euo pipefail
cd "$(dirname "$0")/.."
CLANG_FORMAT=${CLANG_FORMAT:-clang-format}
command -v "${CLANG_FORMAT}" >/dev/null || { echo "error: ${CLANG_FORMAT}: expected on PATH (scripts/setup.sh installs clang-format)" >&2; exit 2; }
mapfile -t files < <(git ls-files '*.cc' '*.h' '*.cu' 2>/dev/null || find src bench tests fuzz -name '*.cc' -o -name '*.h' -o -name '*.cu')
if [ "${1:-}" = --fix ]; then
  "${CLANG_FORMAT}" -i --style=file "${files[@]}"
  exit 0
fi
bad=()
for f in "${files[@]}"; do
  "${CLANG_FORMAT}" --style=file --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
done
if [ ${#bad[@]} -gt 0 ]; then
  printf 'error: %s: expected clang-format output (scripts/check_format.sh --fix)\n' "${bad[@]}" >&2
  exit 1
fi
echo "check_format: ${#files[@]} files formatted"
