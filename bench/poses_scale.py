#!/usr/bin/env python3
"""Driver of bench/poses_scale.sh (see there): how posing time grows with the number of photos.
Photo-like orbits of spider.obj rendered by nerfreg (radial distortion, noise, JPEG 90; intrinsics
given), at each size: `nerfreg dbarf poses --method classical`, COLMAP 3.8 (feature_extractor,
exhaustive_matcher, mapper) and COLMAP 4's global mapper (pycolmap), one after another, each with
the intrinsics kept. The renders, the COLMAP drivers and the scoring against the truth are
bench/real_poses.py's (imported); this file adds the sizes, peak memory, per-pair costs and the
growth exponents (and, with --two-view-bench, bench/two_view_bench.cc's per-pair table at the
smallest size), and writes results/poses_scale.{md,json}.

  poses_scale.py run --work DIR --sizes "24 48 96" --nerfreg build/nerfreg --out-prefix results/poses_scale
  poses_scale.py report JSON MD   (rewrite the tables from a JSON)
"""
import argparse
import datetime
import json
import math
import os
import re
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import real_poses as rp  # noqa: E402  (the shared renders, COLMAP drivers and scoring)

METHODS = {"nerfreg": "nerfreg classical", "colmap38": "COLMAP 3.8", "colmap4": "COLMAP 4 global"}


def nerfreg_pairs(logf):
    """(pairs matched, pairs possible) from nerfreg's log line `pairs: ...: X of Y pairs`."""
    for line in open(logf, errors="replace"):
        m = re.search(r"pairs: .*: (\d+) of (\d+) pairs", line)
        if m:
            return int(m.group(1)), int(m.group(2))
    return None, None


# Trajectories (--trajectories): the set's name, the render's scene and path arguments, and what it is.
TRAJECTORIES = {
    "orbit": ("spider", ["--mesh", rp.SPIDER, "--trajectory", "orbit"], "spider.obj on an orbit"),
    "forward": ("forward", ["--procedural", "5000", "--trajectory", "forward"],
                "procedural scene 5000 (held out), forward-facing look-at views"),
}


def run_size(n, args, python, trajectory="orbit"):
    name, scene, what = TRAJECTORIES[trajectory]
    info = rp.prepare_spider(name, rp.SETS["spider"], args.work, args.nerfreg, n, scene, args.image_size)
    info["what"] = what
    work = os.path.dirname(info["images_dir"])
    gt = rp.gt_poses(info, "cam_from_world")
    runs = {}
    # Each program is started once, untimed, before the timed runs: after long runs a first start
    # was sometimes slower (nerfreg ~0.7 s more at 24 forward views, 2026-11-29; the cause, likely a
    # cold page cache for its ~340 shared libraries, is not established). Every method alike.
    warm = {"nerfreg": [args.nerfreg, "--help"], "colmap38": ["colmap", "-h"], "colmap4": [python, "-c", "import pycolmap"]}
    for m in args.methods.split():
        subprocess.run(warm[m], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for m in args.methods.split():
        key = METHODS[m]
        if m == "nerfreg":
            r, poses, _ = rp.run_nerfreg(info, os.path.join(work, "nerfreg_classical"), args.nerfreg, "classical", True)
            r["pairs"], r["pairs_possible"] = nerfreg_pairs(r["log"])
            st = r.get("stage_s") or {}
            if r["pairs"]:
                r["per_pair_ms"] = {s: 1000 * st[s] / r["pairs"] for s in ("matching", "geometry") if s in st}
        elif m == "colmap38":
            r, poses, _ = rp.run_colmap38(info, os.path.join(work, "colmap38"), True, refined=False)[0][1]
            r["pairs"] = n * (n - 1) // 2
            st = r.get("stage_s") or {}
            if "exhaustive_matcher" in st:
                r["per_pair_ms"] = {"matching + geometry": 1000 * st["exhaustive_matcher"] / r["pairs"]}
        else:
            r, poses, _ = rp.run_colmap4(info, os.path.join(work, "colmap4"), True, python, refined=False)[0][1]
            r["pairs"] = n * (n - 1) // 2
            st = r.get("stage_s") or {}
            if "match_exhaustive" in st:
                r["per_pair_ms"] = {"matching + geometry": 1000 * st["match_exhaustive"] / r["pairs"]}
        r["peak_rss_mb"] = rp.PEAK_RSS_MB.get(r["log"])
        r["loadavg_after"] = open("/proc/loadavg").read().split()[:3]
        r["truth"] = rp.compare(poses, gt) if poses else {"common": 0}
        r["poses"] = rp.poses_json(poses)
        runs[key] = r
        rp.log("%s N=%d %s: %s, posed %s/%d, %.1f s, peak %s MB" % (
            trajectory, n, key, r.get("status"), r.get("posed", "-"), n, r.get("wall_s", 0),
            rp.fmt(r["peak_rss_mb"], "%.0f")))
    res = {k: v for k, v in info.items() if k not in ("gt_matrices",)}
    res["views"] = n
    res["trajectory"] = trajectory
    res["runs"] = runs
    return res


def two_view(n, args):
    """bench/two_view_bench.cc on the N-view set (every pair, one thread, CPU time): the two-view
    estimators' per-pair cost and edge accuracy on the same matches."""
    d = os.path.join(args.work, "spider%d" % n)
    out = os.path.join(d, "two_view.json")
    cmd = [args.two_view_bench, "--images", os.path.join(d, "images"), "--intrinsics", os.path.join(d, "transforms.json"),
           "--json", out]
    rc, secs = rp.run_timed(cmd, os.path.join(d, "two_view.log"))
    if rc != 0 or not os.path.exists(out):
        return {"command": " ".join(cmd), "error": rp.error_line(os.path.join(d, "two_view.log"))}
    r = json.load(open(out))
    r.update(command=" ".join(cmd), views=n, wall_s=secs)
    return r


def growth(sizes):
    """Per method, the exponent b of wall_s ~ a N^b, least squares in log-log over the sizes it ran."""
    out = {}
    for traj in sorted({s.get("trajectory", "orbit") for s in sizes}):
        of = [s for s in sizes if s.get("trajectory", "orbit") == traj]
        for key in sorted({k for s in of for k in s["runs"]}):
            pts = [(s["views"], s["runs"][key]["wall_s"]) for s in of
                   if key in s["runs"] and s["runs"][key].get("status") == "ok"]
            if len(pts) >= 2:
                x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
                b, a = np.polyfit(x, y, 1)
                out["%s, %s" % (key, traj)] = {"exponent": float(b), "sizes": [p[0] for p in pts]}
    return out


def write_md(j, path):
    fmt = rp.fmt
    L = ["# Posing time against the number of photos: nerfreg `dbarf poses` against COLMAP 3.8 and COLMAP 4 (global)",
         ""]
    m = j["machine"]
    L.append("Written by `bench/poses_scale.py` from `%s`: `%s` (%s; %s, %s cores; the whole bench %.0f s; load average "
             "%s at the start, %s at the end: the bench's own work keeps it near the core count; where the start's first "
             "figure is above 1, other jobs shared the cores and the times are upper bounds)." %
             (os.path.basename(j["json"]), j["command"], j["date"], m["cpu"], m["cores"], j.get("bench_wall_s", 0),
              " ".join(m["loadavg_start"]), " ".join(m.get("loadavg_end", ["?"]))))
    v = j["versions"]
    L.append("nerfreg: `%s` (%s); COLMAP: %s; pycolmap %s." % (v["nerfreg"], rp.nerfreg_version(v),
                                                              v["colmap"][0].strip(), v["pycolmap"]))
    L.append("")
    L.append("Sets: `nerfreg render --mesh spider.obj --trajectory orbit --views N --size %s --distortion -0.05 "
             "--noise 0.01 --jpeg 90 --seed 1` (bench/real_poses.py's photo-like `spider` set at N views; `orbit`) "
             "and the same with `--procedural 5000 --trajectory forward` in place of the mesh and orbit (a held-out "
             "procedural scene seen by forward-facing look-at views, as bench/dbarf_speed.sh's; `forward`). Every "
             "method gets the render's intrinsics and keeps them (nerfreg `--intrinsics`, COLMAP one `OPENCV` camera, "
             "focal and distortion not refined). Runs one after another, each with the machine's default thread "
             "count, timed by the wall clock, each program started once untimed before a set's runs (a warm start "
             "for all); peak memory is GNU time's maximum resident set size (COLMAP 3.8: the "
             "largest of its three commands). Errors against the truth: rotation after the best rotation alignment, "
             "centres after a robust Sim(3) in %% of the widest baseline (bench/real_poses.py `compare`). Per-pair "
             "cost: nerfreg's stage time over the pairs it matched; COLMAP's exhaustive matching stage (matching "
             "and geometric verification) over all N (N - 1) / 2 pairs." % j.get("image_size", "640x480"))
    L.append("")
    L.append("| set | N | method | posed | wall s | peak MB | stages (s) | pairs | per pair ms | rot median deg "
             "| rot max deg | centre median % | centre max % |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for s in j["sizes"]:
        for k, r in s["runs"].items():
            st = r.get("stage_s") or {}
            stages = ", ".join("%s %.1f" % (a, b) for a, b in st.items() if isinstance(b, (int, float)) and a != "total")
            pp = ", ".join("%s %.1f" % (a, b) for a, b in (r.get("per_pair_ms") or {}).items())
            t = r.get("truth", {})
            posed = "%d/%d" % (r["posed"], s["views"]) if r.get("status") == "ok" else "failed: `%s`" % r.get("error", "")
            pairs = "%s of %s" % (r["pairs"], r.get("pairs_possible", r["pairs"])) if r.get("pairs") else "-"
            L.append("| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                s.get("trajectory", "orbit"), s["views"], k, posed, fmt(r.get("wall_s"), "%.1f"), fmt(r.get("peak_rss_mb"), "%.0f"), stages or "-",
                pairs, pp or "-", fmt(t.get("rot_deg_median")), fmt(t.get("rot_deg_max")),
                fmt(t.get("center_pct_median"), "%.2f"), fmt(t.get("center_pct_max"), "%.2f")))
    L.append("")
    tv = j.get("two_view")
    if tv and "variants" in tv:
        L.append("## Two-view geometry pair by pair (N = %d)" % tv["views"])
        L.append("")
        L.append("`%s` (bench/two_view_bench.cc): every pair's putative matches once, then each estimator on them, "
                 "one thread, times in CPU ms (not inflated by other jobs). %d pairs; keypoints median %.0f; putative "
                 "matches median %.0f; matching %.2f ms a pair. Edge errors: the relative rotation and translation "
                 "direction against the truth." % (tv["command"], tv["pairs"], tv["keypoints_median"],
                                                   tv["matches_median"], tv["matching_ms_per_pair"]))
        L.append("")
        L.append("| estimator | ms / pair | ms / edge | ms / other pair | edges | rot err median / max deg | "
                 "direction err median / max deg | edges > 5 deg off | edges unlike the reference's |")
        L.append("|---|---|---|---|---|---|---|---|---|")
        for v in tv["variants"]:
            L.append("| %s | %.1f | %.1f | %.1f | %d | %s / %s | %s / %s | %d | %d |" % (
                v["variant"], v["ms_per_pair"], v["ms_per_edge_pair"], v["ms_per_other_pair"], v["edges"],
                fmt(v["rotation_error_deg_median"]), fmt(v["rotation_error_deg_max"], "%.2f"),
                fmt(v["direction_error_deg_median"], "%.2f"), fmt(v["direction_error_deg_max"], "%.2f"),
                v["edges_over_5deg"], v["edges_differing_from_reference"]))
        L.append("")
    L.append("## Growth of the wall time")
    L.append("")
    L.append("Exponent b of wall s ~ a N^b, least squares on log-log over the sizes run (the issue's target: b <= 1.5).")
    L.append("")
    L.append("| method, set | b | sizes |")
    L.append("|---|---|---|")
    for k, g in j["growth"].items():
        L.append("| %s | %.2f | %s |" % (k, g["exponent"], ", ".join(str(x) for x in g["sizes"])))
    L.append("")
    open(path, "w").write("\n".join(L))


def main():
    ap = argparse.ArgumentParser()
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--work", required=True)
    r.add_argument("--sizes", default="24 48 96")
    r.add_argument("--trajectories", default="orbit", help="orbit and / or forward (TRAJECTORIES)")
    r.add_argument("--methods", default="nerfreg colmap38 colmap4")
    r.add_argument("--nerfreg", required=True)
    r.add_argument("--out-prefix", required=True)
    r.add_argument("--command", default="")
    r.add_argument("--two-view-bench", default="", help="nerfreg_two_view_bench: run on the smallest size")
    r.add_argument("--image-size", default="640x480", help="the renders' WxH (IMAGE_SIZE)")
    rep = sub.add_parser("report")
    rep.add_argument("json")
    rep.add_argument("md")
    args = ap.parse_args()
    if args.cmd == "report":
        j = json.load(open(args.json))
        j["growth"] = growth(j["sizes"])
        json.dump(j, open(args.json, "w"), indent=1)
        return write_md(j, args.md)
    os.makedirs(args.work, exist_ok=True)
    python = sys.executable
    j = {"command": args.command or " ".join(sys.argv), "date": datetime.datetime.now().isoformat(timespec="seconds"),
         "machine": rp.machine(), "versions": rp.versions(args.nerfreg, python), "work": args.work,
         "json": args.out_prefix + ".json", "image_size": args.image_size, "sizes": []}
    t0 = time.time()
    sizes = [int(x) for x in args.sizes.split()]
    trajectories = args.trajectories.split()
    for traj, n in [(t, n) for t in trajectories for n in sizes]:
        rp.log("%s, N = %d" % (traj, n))
        j["sizes"].append(run_size(n, args, python, traj))
        j["growth"] = growth(j["sizes"])
        if (traj == "orbit" and n == min(sizes) and args.image_size == "640x480" and args.two_view_bench and
                os.path.exists(args.two_view_bench)):
            rp.log("two-view bench, N = %d" % n)
            j["two_view"] = two_view(n, args)
        j["machine"]["loadavg_end"] = open("/proc/loadavg").read().split()[:3]
        j["bench_wall_s"] = time.time() - t0
        os.makedirs(os.path.dirname(os.path.abspath(args.out_prefix)), exist_ok=True)
        json.dump(j, open(args.out_prefix + ".json", "w"), indent=1)
        write_md(j, args.out_prefix + ".md")
    rp.log("wrote %s.json, %s.md in %.0f s" % (args.out_prefix, args.out_prefix, time.time() - t0))


if __name__ == "__main__":
    main()
