#!/usr/bin/env python3
"""What `reg register --method auto`'s choice rule changes (issue 23): every candidate of every
pair is scored against the ground truth, then two rules pick one per pair from the same refined
candidates:

  common samples (today's rule): the highest agreement (soft Dice of the two occupancies) on ONE
    sample set drawn around both blocks' occupied points (pipeline/register_blocks.h, Score);
  own samples (the rule before commit 0a83572): the lowest final cost of each candidate's own field
    refinement, whose samples are drawn around the points that method registered (the grid masks
    for dreg and ransac-grid, the occupied points for ransac), so costs of different methods are
    measured on different samples.

Both rules read what T.json records (candidate agreement, field.final_cost, field.samples), so one
`reg register` run per pair gives both. "best" is the candidate nearest the truth: the ceiling of
any rule over these candidates.

Usage: bench/auto_choice.py PAIRS_JSON... (real pairs of `reg make-data`, e.g. data/reg/test_nerf_proc4/pairs.json)
  NERFREG (binary), WORK (folder for T.json files, reused: a pair whose T.json exists is not re-run),
  OUT_MD, OUT_JSON (default results/auto_choice.md / .json), EXTRA (more reg register arguments).
Standard library only.
"""
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NERFREG = os.environ.get("NERFREG", os.path.join(ROOT, "build", "nerfreg"))
WORK = os.environ.get("WORK", "/tmp/auto_choice")
OUT_MD = os.environ.get("OUT_MD", os.path.join(ROOT, "results", "auto_choice.md"))
OUT_JSON = os.environ.get("OUT_JSON", os.path.join(ROOT, "results", "auto_choice.json"))
EXTRA = os.environ.get("EXTRA", "").split()


def real_pairs(path):
    base = os.path.dirname(os.path.abspath(path))
    for p in json.load(open(path))["pairs"]:
        if p.get("kind") != "nerf":
            continue
        src = os.path.join(base, p["source"])
        tgt = os.path.join(base, p["target"])
        yield {
            "set": os.path.basename(base),
            "name": p["name"],
            "source": src[: -len(".grid")] + ".ckpt",
            "target": tgt[: -len(".grid")] + ".ckpt",
            "ground_truth": os.path.join(os.path.dirname(src), "data", "ground_truth.json"),
            "source_block": p["source_block"],
            "target_block": p["target_block"],
            "overlap": p.get("overlap"),
        }


def evaluate(pose_json, pair, path):
    """reg eval --pair on one pose: the project's own error and success test."""
    with open(path, "w") as f:
        json.dump(pose_json, f)
    out = path + ".eval"
    subprocess.run([NERFREG, "reg", "eval", "--pair", path, "--ground-truth", pair["ground_truth"], "--source",
                    str(pair["source_block"]), "--target", str(pair["target_block"]), "--out", out, "--force",
                    "--quiet"], check=True, stdout=subprocess.DEVNULL)
    return json.load(open(out))


def old_cost(c):
    # The rule as it was written: candidates whose refinement had fewer than 10 samples never win.
    f = c.get("field")
    return f["final_cost"] if isinstance(f, dict) and f.get("samples", 0) >= 10 else 1e9


def run_pair(pair):
    tag = (pair["set"] + "_" + pair["name"]).replace("/", "_")
    out = os.path.join(WORK, tag + ".json")
    if not os.path.exists(out):
        # Exit 5: an untrusted result (T.json written with its status), kept like any other.
        rc = subprocess.run([NERFREG, "reg", "register", pair["source"], pair["target"], "--method", "auto", "--refine",
                             "field", "--out", out, "--force", "--quiet"] + EXTRA, stdout=subprocess.DEVNULL).returncode
        if rc not in (0, 5):
            raise subprocess.CalledProcessError(rc, "reg register")
    t = json.load(open(out))
    cands = [{k: t.get(k) for k in ("method", "target_from_source", "agreement", "field")}] + t.get("not_chosen", [])
    rows = []
    for k, c in enumerate(cands):
        e = evaluate({"target_from_source": c["target_from_source"], "method": c["method"]}, pair,
                     os.path.join(WORK, "%s_c%d.pose.json" % (tag, k)))
        rows.append({"method": c["method"], "confidence": c["agreement"]["confidence"], "own_cost": old_cost(c),
                     "own_samples": (c.get("field") or {}).get("samples", 0),
                     "rotation_deg": e["rotation_error_deg"], "translation_fraction": e["translation_error_fraction"],
                     "success": e["success"]})
    common = max(range(len(rows)), key=lambda k: (rows[k]["confidence"], -k))  # first on ties, as ChooseCandidate
    own = min(range(len(rows)), key=lambda k: (rows[k]["own_cost"], k))
    best = min(range(len(rows)), key=lambda k: (not rows[k]["success"], rows[k]["rotation_deg"]))
    assert common == 0, "T.json's kept candidate should be the highest agreement: " + out
    return {"set": pair["set"], "pair": pair["name"], "overlap": pair["overlap"], "candidates": rows,
            "common_samples": common, "own_samples": own, "best": best}


def summary(results, rule):
    picked = [r["candidates"][r[rule]] for r in results]
    rot = [c["rotation_deg"] for c in picked]
    tr = [c["translation_fraction"] for c in picked]
    return {"pairs": len(picked), "success": sum(c["success"] for c in picked), "median_rotation_deg":
            statistics.median(rot), "median_translation_fraction": statistics.median(tr),
            "gross_over_30deg": sum(r > 30 for r in rot)}


def main():
    pairs_files = sys.argv[1:]
    if not pairs_files:
        sys.exit("usage: bench/auto_choice.py PAIRS_JSON...")
    os.makedirs(WORK, exist_ok=True)
    results = []
    pairs = [p for f in pairs_files for p in real_pairs(f)]
    for i, p in enumerate(pairs):
        r = run_pair(p)
        results.append(r)
        c, o = r["candidates"][r["common_samples"]], r["candidates"][r["own_samples"]]
        print("[%d/%d] %s %s: common %s %.2f deg, own %s %.2f deg" % (i + 1, len(pairs), p["set"], p["name"],
              c["method"], c["rotation_deg"], o["method"], o["rotation_deg"]), flush=True)
    sets = list(dict.fromkeys(r["set"] for r in results))
    rules = [("common_samples", "common samples (today's rule: highest agreement)"),
             ("own_samples", "own samples (before: lowest own field cost)"),
             ("best", "the candidate nearest the truth (ceiling)")]
    out = {"date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), "machine": "%s, %d cores" % (
        platform.machine(), os.cpu_count()), "command": "bench/auto_choice.py " + " ".join(pairs_files),
        "sets": {}, "pairs": results}
    md = ["# auto's choice: candidates compared on common samples or on their own", "",
          "Command: `%s` (each pair registered once by `reg register --method auto --refine field`; both "
          "rules pick from the same refined candidates that T.json records; errors by `reg eval --pair`). %s, %s. "
          "Success: 5 deg and 0.05 of the object extent." % (out["command"], out["date"], out["machine"]), ""]
    for s in sets + (["all"] if len(sets) > 1 else []):
        sel = [r for r in results if s == "all" or r["set"] == s]
        out["sets"][s] = {rule: summary(sel, rule) for rule, _ in rules}
        differ = [r for r in sel if r["common_samples"] != r["own_samples"]]
        out["sets"][s]["choices_differ"] = len(differ)
        md += ["## %s (%d pairs; the two rules choose differently on %d)" % (s, len(sel), len(differ)), "",
               "| rule | success | median rotation (deg) | median translation / extent | over 30 deg |",
               "|---|---|---|---|---|"]
        for rule, label in rules:
            m = out["sets"][s][rule]
            md.append("| %s | %d / %d | %.2f | %.4f | %d |" % (label, m["success"], m["pairs"],
                      m["median_rotation_deg"], m["median_translation_fraction"], m["gross_over_30deg"]))
        md.append("")
        if differ:
            md += ["Pairs where the rules differ (candidate: rotation error; agreement / own cost / own samples):", "",
                   "| pair | common samples keeps | own samples kept |", "|---|---|---|"]
            for r in differ:
                c, o = r["candidates"][r["common_samples"]], r["candidates"][r["own_samples"]]
                fmt = lambda x: "%s: %.2f deg (%.3f / %.4f / %d)" % (x["method"], x["rotation_deg"], x["confidence"],
                                                                     x["own_cost"], x["own_samples"])
                md.append("| %s | %s | %s |" % (r["pair"], fmt(c), fmt(o)))
            md.append("")
    with open(OUT_JSON + ".tmp", "w") as f:
        json.dump(out, f, indent=1)
    os.replace(OUT_JSON + ".tmp", OUT_JSON)
    with open(OUT_MD + ".tmp", "w") as f:
        f.write("\n".join(md))
    os.replace(OUT_MD + ".tmp", OUT_MD)
    print("\n".join(md))


if __name__ == "__main__":
    main()
