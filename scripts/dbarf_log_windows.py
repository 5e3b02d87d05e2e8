#!/usr/bin/env python3
"""The DBARF trainer's log (OUT.log.jsonl) summarised by windows of steps and stage.

    python3 scripts/dbarf_log_windows.py LOG [--window N] [--markdown]

Each (window, stage) row holds the number of steps and the mean of every numeric column the trainer
logged in it: the training PSNR in NeRF and joint stages, and where the scenes have ground truth
`disparity` (mean normalised target disparity, 0 = the far bound), `rot_err_deg`, `dir_err_deg` and
`t_ratio` (|t| / |t_true|). A falling disparity with flat pose errors is the depth collapse of
docs/notes/2026-11-25-dbarf-pose-from-identity.md. scripts/dbarf_device_train.sh puts the rows into
its JSON; --markdown prints them as a table.
"""
import argparse
import json
import sys

COLUMNS = ["psnr", "sfm_loss", "disparity", "rot_err_deg", "dir_err_deg", "t_ratio"]


def windows(path, window):
    groups = {}
    with open(path) as f:
        for line in f:
            try:
                row = json.loads(line)
            except ValueError:
                continue  # a line cut by a stop
            key = (int(row.get("step", 0)) // window, row.get("stage", ""))
            groups.setdefault(key, []).append(row)
    out = []
    for (w, stage), rows in sorted(groups.items()):
        entry = {"from_step": w * window, "to_step": (w + 1) * window, "stage": stage, "steps": len(rows)}
        for c in COLUMNS:
            values = [r[c] for r in rows if isinstance(r.get(c), (int, float))]
            if values:
                entry[c] = round(sum(values) / len(values), 4)
        out.append(entry)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("log")
    parser.add_argument("--window", type=int, default=300)
    parser.add_argument("--markdown", action="store_true")
    args = parser.parse_args()
    if args.window < 1:
        print("error: --window: expected >= 1", file=sys.stderr)
        return 2
    try:
        rows = windows(args.log, args.window)
    except OSError as e:
        print("error: %s: expected the trainer's log (%s)" % (args.log, e.strerror), file=sys.stderr)
        return 2
    if not args.markdown:
        print(json.dumps(rows))
        return 0
    print("| steps | stage | n | " + " | ".join(COLUMNS) + " |")
    print("|---|---|---|" + "---|" * len(COLUMNS))
    for r in rows:
        cells = [("%.3f" % r[c]) if c in r else "" for c in COLUMNS]
        print("| %d-%d | %s | %d | %s |" % (r["from_step"], r["to_step"], r["stage"], r["steps"], " | ".join(cells)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
