#!/usr/bin/env bash
# The exe/ layout rule (docs/architecture.md): exe/ only parses flags, calls one library function
# and prints, so no file there is over 300 lines and no function over 80. Functions are found by a
# brace-counting heuristic: a line that opens a brace at namespace level and holds a "(" starts a
# function, which ends where its braces close. Exits 1 listing every breach.
set -euo pipefail
dir="${1:-$(cd "$(dirname "$0")/.." && pwd)/src/nerfreg/exe}"
max_file_lines="${MAX_FILE_LINES:-300}"
max_function_lines="${MAX_FUNCTION_LINES:-80}"
python3 - "$dir" "$max_file_lines" "$max_function_lines" <<'PY'
import pathlib, re, sys

folder, max_file, max_fn = pathlib.Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
if not folder.is_dir():
    sys.exit(f"error: {folder}: expected a folder")

def strip(line, in_comment):
    """The line without comments, string and character literals; whether a /* */ comment stays open."""
    out, i = [], 0
    while i < len(line):
        if in_comment:
            end = line.find("*/", i)
            if end < 0:
                return "".join(out), True
            in_comment, i = False, end + 2
        elif line.startswith("//", i):
            break
        elif line.startswith("/*", i):
            in_comment, i = True, i + 2
        elif line[i] in "\"'":
            quote, i = line[i], i + 1
            while i < len(line) and line[i] != quote:
                i += 2 if line[i] == "\\" else 1
            i += 1
        else:
            out.append(line[i])
            i += 1
    return "".join(out), in_comment

breaches = []
for path in sorted(list(folder.glob("*.cc")) + list(folder.glob("*.h"))):
    lines = path.read_text().splitlines()
    if len(lines) > max_file:
        breaches.append(f"{path}: {len(lines)} lines (at most {max_file})")
    # Depth counts only braces inside functions; namespace and extern blocks are transparent.
    depth, start, name, in_comment, pending, signature_start = 0, None, "", False, "", 1
    for number, raw in enumerate(lines, 1):
        code, in_comment = strip(raw, in_comment)
        if depth == 0 and start is None:
            stripped = code.strip()
            if re.match(r"^(namespace\b|extern\b)", stripped) or stripped.startswith("}"):
                pending = ""
                continue
            pending = (pending + " " + stripped) if pending or stripped else ""
            if "{" in code and "(" in pending and not re.match(r"^(struct|class|enum|union)\b", pending.strip()):
                # The signature may have begun on earlier lines.
                head = pending.split("(")[0].split()
                start, name = signature_start, head[-1] if head else "?"
            elif "{" in code or stripped.endswith(";"):
                pending = ""
            if not pending.strip():
                signature_start = number + 1
            elif pending.strip() == stripped:
                signature_start = number
            if start is None:
                continue
        for ch in code:
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
        if start is not None and depth == 0:
            length = number - start + 1
            if length > max_fn:
                breaches.append(f"{path}:{start}: function {name} is {length} lines (at most {max_fn})")
            start, pending = None, ""
            signature_start = number + 1
for b in breaches:
    print(b)
sys.exit(1 if breaches else 0)
PY
