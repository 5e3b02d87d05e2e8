#!/usr/bin/env python3
"""Driver of bench/dbarf_poses_bench.sh (see there): renders the sets, runs every method, scores
them, writes the table and its raw JSON. Standard library only."""
import datetime
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NERFREG = os.environ.get("NERFREG", os.path.join(ROOT, "build", "nerfreg"))
WORK = sys.argv[1] if len(sys.argv) > 1 else "/tmp/dbarf_poses_bench"
OUT_MD = os.environ.get("OUT_MD", os.path.join(ROOT, "results", "dbarf_poses.md"))
OUT_JSON = os.environ.get("OUT_JSON", os.path.join(ROOT, "results", "dbarf_poses.json"))
METHODS = os.environ.get("METHODS", "network network+finetune auto classical colmap").split()
# network+finetune: the renderer and the cameras, with the test views held out (`dbarf poses`
# keeps --intrinsics' splits), rates halved every FINETUNE_DECAY_STEPS (chosen on validation
# scenes, docs/poses_and_views.md "Camera refinement"), then the depth BA (the finetune's default
# last stage). network+finetune-rgb: the same without the depth BA (--depth-ba-rounds 0); listed
# before network+finetune, its training is reused and only the depth BA runs again.
FINETUNE_STEPS = int(os.environ.get("FINETUNE_STEPS", "400"))
FINETUNE_SCHEDULE = os.environ.get("FINETUNE_SCHEDULE", "nerf")
FINETUNE_DECAY_STEPS = int(os.environ.get("FINETUNE_DECAY_STEPS", "50"))
FINETUNE_STAGE_STEPS = int(os.environ.get("FINETUNE_STAGE_STEPS", "50"))  # with FINETUNE_SCHEDULE=dbarf
FINETUNE_DEPTH_BA_STEPS = os.environ.get("FINETUNE_DEPTH_BA_STEPS", "")  # --depth-ba-steps ("": the default)
FINETUNE_DEPTH_BA_SOURCES = os.environ.get("FINETUNE_DEPTH_BA_SOURCES", "")  # --depth-ba-sources ("": the default)
FINETUNE_DEPTH_BA_VIEW_RANGE = os.environ.get("FINETUNE_DEPTH_BA_VIEW_RANGE", "")  # --depth-ba-view-range ("": the default)
NOVEL_TEST_EVERY = 5  # 20-view sets: every 5th view is also rendered, at each method's camera for it (row c)
# `dbarf poses --two-view` for the network, auto and classical runs ("": the binary's default estimator).
TWO_VIEW = os.environ.get("TWO_VIEW", "")
REDUCED = os.environ.get("REDUCED", "")  # a sentence for the .md when the configuration is cut down


def env_list(name, default):
    return os.environ.get(name, default).split()


# Sets: (row, seed, views, size, material, spread). Seeds 5000+: never used by training (2001-2300),
# validation (3001-3012), tests or the held-out test scenes (201-203).
def make_sets():
    sets = []
    for size in env_list("SIZES20", "128x96 320x240"):
        for seed in env_list("SEEDS20", "5001 5002 5003"):
            sets.append(("20 views " + size, int(seed), 20, size, "textured", 0.0))
    n_sparse = int(os.environ.get("SPARSE_SETS", "10"))
    spread = float(os.environ.get("SPARSE_SPREAD", "0.7"))
    for v in env_list("SPARSE_VIEWS", "3 4 5"):
        for k in range(n_sparse):
            sets.append(("sparse %s views (spread %g)" % (v, spread), 5100 + 20 * int(v) + k, int(v), "128x96", "textured", spread))
    n_hard = int(os.environ.get("HARD_SETS", "5"))
    hard_views = int(os.environ.get("HARD_VIEWS", "10"))
    for material in env_list("HARD_MATERIALS", "low-texture repetitive"):
        for k in range(n_hard):
            sets.append(("%s %d views" % (material, hard_views), 5400 + (100 if material == "repetitive" else 0) + k,
                         hard_views, "128x96", material, 0.0))
    return sets


def run(cmd, log=None):
    t0 = time.time()
    with open(log or os.devnull, "w") as f:
        rc = subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT)
    return rc, time.time() - t0


def render(seed, views, size, material, spread, out):
    if os.path.exists(os.path.join(out, "transforms.json")):
        return
    cmd = [NERFREG, "render", "--procedural", str(seed), "--trajectory", "forward", "--views", str(views), "--size", size,
           "--material", material, "--test-every", str(NOVEL_TEST_EVERY if views >= 20 else 0), "--quiet", "--force",
           "--out", out]
    if spread > 0:
        cmd += ["--spread", str(spread)]
    if subprocess.call(cmd) != 0:
        raise SystemExit("render failed: " + " ".join(cmd))


def colmap(images, gt, out):
    j = json.load(open(gt))
    w, h = j["w"], j["h"]
    fx = j.get("fl_x") or 0.5 * w / math.tan(0.5 * j["camera_angle_x"])
    params = "%r,%r,%r,%r" % (fx, j.get("fl_y", fx), j.get("cx", w / 2), j.get("cy", h / 2))
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "sparse"))
    db = os.path.join(out, "db.db")
    t0 = time.time()
    log = open(os.path.join(out, "colmap.log"), "w")
    # SIFT's peak threshold lowered to nerfreg's contrast threshold: COLMAP's default finds 15-30
    # features on these renders and fails on most sets (results/poses.md).
    ok = subprocess.call(["colmap", "feature_extractor", "--database_path", db, "--image_path", images,
                          "--SiftExtraction.use_gpu", "0", "--ImageReader.single_camera", "1", "--ImageReader.camera_model",
                          "PINHOLE", "--ImageReader.camera_params", params, "--SiftExtraction.peak_threshold", "0.00167"],
                         stdout=log, stderr=log) == 0
    ok = ok and subprocess.call(["colmap", "exhaustive_matcher", "--database_path", db, "--SiftMatching.use_gpu", "0"],
                                stdout=log, stderr=log) == 0
    ok = ok and subprocess.call(["colmap", "mapper", "--database_path", db, "--image_path", images, "--output_path",
                                 os.path.join(out, "sparse")], stdout=log, stderr=log) == 0
    seconds = time.time() - t0
    best, best_n = None, -1
    for m in sorted(os.listdir(os.path.join(out, "sparse"))):
        path = os.path.join(out, "sparse", m)
        if not os.path.exists(os.path.join(path, "images.bin")):
            continue
        txt = os.path.join(path, "txt")
        os.makedirs(txt, exist_ok=True)
        if subprocess.call(["colmap", "model_converter", "--input_path", path, "--output_path", txt, "--output_type", "TXT"],
                           stdout=log, stderr=log) != 0:
            continue
        n = len([l for l in open(os.path.join(txt, "images.txt")) if not l.startswith("#")]) // 2
        if n > best_n:
            best, best_n = txt, n
    if best:
        subprocess.call([NERFREG, "convert", best, "--to", "nerf", "--out", os.path.join(out, "transforms.json"), "--force",
                         "--quiet"], stdout=log, stderr=log)
    return seconds


def frames_by_name(path):
    j = json.load(open(path))
    return {os.path.basename(f["file_path"]): f for f in j["frames"]}


def direction_error_deg(est_path, gt_path):
    """Median over posed image pairs (i, j) of the angle between the estimated and true directions of
    camera j's centre seen from camera i (in i's frame): free of any alignment and scale."""
    est, gt = frames_by_name(est_path), frames_by_name(gt_path)
    names = sorted(set(est) & set(gt))

    def centre_and_rot(f):
        m = f["transform_matrix"]
        return [m[0][3], m[1][3], m[2][3]], [[m[r][c] for c in range(3)] for r in range(3)]

    errors = []
    for a in names:
        for b in names:
            if a == b:
                continue
            dirs = []
            for frames in (est, gt):
                ca, ra = centre_and_rot(frames[a])
                cb, _ = centre_and_rot(frames[b])
                d = [cb[k] - ca[k] for k in range(3)]
                dirs.append([sum(ra[r][c] * d[r] for r in range(3)) for c in range(3)])  # R^T d
            u, v = dirs
            nu, nv = math.sqrt(sum(x * x for x in u)), math.sqrt(sum(x * x for x in v))
            if nu == 0 or nv == 0:
                errors.append(180.0)
                continue
            c = max(-1.0, min(1.0, sum(x * y for x, y in zip(u, v)) / (nu * nv)))
            errors.append(math.degrees(math.acos(c)))
    errors.sort()
    return errors[len(errors) // 2] if errors else None


def evaluate(est, gt, images):
    r = {"images": images, "posed": 0, "rotation_deg": None, "direction_deg": None, "centre_percent": None}
    if not os.path.exists(est):
        return r
    try:
        r["posed"] = len(frames_by_name(est))
    except (ValueError, KeyError):
        return r
    out = subprocess.run([NERFREG, "dbarf", "eval-poses", est, "--ground-truth", gt, "--align", "rotations", "--json"],
                         capture_output=True, text=True).stdout
    lines = [l for l in out.splitlines() if l.startswith("{")]
    if lines:
        j = json.loads(lines[-1])
        r["rotation_deg"] = j["rotation_deg_median"]
        r["centre_percent"] = j["center_percent_median"]
    r["direction_deg"] = direction_error_deg(est, gt)
    by = {}
    try:
        for f in json.load(open(est))["frames"]:
            by[f.get("posed_by", "")] = by.get(f.get("posed_by", ""), 0) + 1
        r["posed_by"] = by
        r["low_confidence"] = len(json.load(open(est)).get("low_confidence", []))
    except (ValueError, KeyError):
        pass
    return r


def two_view_flags():
    return ["--two-view", TWO_VIEW] if TWO_VIEW else []


def run_method(method, data, work):
    images, gt = os.path.join(data, "images"), os.path.join(data, "transforms.json")
    os.makedirs(work, exist_ok=True)
    out = os.path.join(work, method.replace("+", "_"))
    if method == "colmap":
        seconds = colmap(images, gt, out)
        return evaluate(os.path.join(out, "transforms.json"), gt, len(os.listdir(images))), seconds
    if method in ("network+finetune", "network+finetune-rgb"):
        net = os.path.join(work, "network")
        if not os.path.exists(os.path.join(net, "transforms.json")):
            run([NERFREG, "dbarf", "poses", images, "--intrinsics", gt, "--method", "network", "--out", net, "--force", "--quiet"]
                + two_view_flags())
        seconds_net = json.load(open(os.path.join(net, "transforms.json")))["dbarf_poses"]["seconds"]
        rgb_only = method == "network+finetune-rgb"
        tag = "_rgb" if rgb_only else ""
        cams, weights = os.path.join(work, "finetuned%s_cameras.json" % tag), os.path.join(work, "finetuned%s.pt" % tag)
        if os.path.exists(cams):
            os.remove(cams)
        flags = ["--nerf-poses", "cameras", "--refine-cameras", cams, "--steps", str(FINETUNE_STEPS), "--schedule",
                 FINETUNE_SCHEDULE, "--stage-steps", str(FINETUNE_STAGE_STEPS), "--lr-decay-steps", str(FINETUNE_DECAY_STEPS),
                 "--out", weights, "--force", "--quiet"]
        rgb = os.path.join(work, "finetuned_rgb.pt")
        seconds_before = 0.0
        if FINETUNE_DEPTH_BA_STEPS:
            flags += ["--depth-ba-steps", FINETUNE_DEPTH_BA_STEPS]
        if FINETUNE_DEPTH_BA_SOURCES:
            flags += ["--depth-ba-sources", FINETUNE_DEPTH_BA_SOURCES]
        if FINETUNE_DEPTH_BA_VIEW_RANGE:
            flags += ["--depth-ba-view-range", FINETUNE_DEPTH_BA_VIEW_RANGE]
        if rgb_only:
            flags += ["--depth-ba-rounds", "0"]
        elif os.path.exists(rgb + ".train") and os.path.exists(rgb + ".json"):
            # network+finetune-rgb ran first: the same training, resumed with no more steps, adds the
            # depth BA alone (its time is the RGB run's plus this).
            for ext in ("", ".train", ".json", ".log.jsonl"):
                if os.path.exists(rgb + ext):
                    shutil.copyfile(rgb + ext, weights + ext)
            seconds_before = json.load(open(rgb + ".json"))["seconds"]
            flags += ["--resume"]
        rc, seconds = run([NERFREG, "dbarf", "finetune", os.path.join(net, "transforms.json")] + flags,
                          os.path.join(work, "finetune%s.log" % tag))
        return evaluate(cams, gt, len(os.listdir(images))), seconds + seconds_net + seconds_before
    rc, seconds = run([NERFREG, "dbarf", "poses", images, "--intrinsics", gt, "--method", method, "--out", out, "--force",
                       "--quiet"] + two_view_flags(), out + ".log")
    return evaluate(os.path.join(out, "transforms.json"), gt, len(os.listdir(images))), seconds


# Row (c): the test views of a 20-view set rendered at the method's cameras for them, from the
# training views at their cameras (`dbarf eval --cameras`: one protocol for every method), with
# the shipped DBARF weights, or the finetuned ones for network+finetune. COLMAP's cameras have no
# view graph or depth range to render from, so it has no row here.
def novel_views(method, data, work):
    if method == "colmap":
        return {}
    gt = os.path.join(data, "transforms.json")
    if method in ("network+finetune", "network+finetune-rgb"):
        tag = "_rgb" if method == "network+finetune-rgb" else ""
        cams, weights = os.path.join(work, "finetuned%s_cameras.json" % tag), os.path.join(work, "finetuned%s.pt" % tag)
    else:
        cams, weights = os.path.join(work, method, "transforms.json"), None
    if not os.path.exists(cams):
        return {}
    cmd = [NERFREG, "dbarf", "eval", gt, "--cameras", cams, "--out", os.path.join(work, "eval_" + method.replace("+", "_")),
           "--force", "--quiet"]
    if weights:
        cmd += ["--weights", weights]
    rc, _ = run(cmd, os.path.join(work, "eval_" + method.replace("+", "_") + ".log"))
    if rc != 0:
        return {}
    j = json.load(open(os.path.join(work, "eval_" + method.replace("+", "_"), "eval.json")))
    return {"psnr": j["psnr_mean"], "ssim": j["ssim_mean"], "novel_views": j["rendered"]}


def median(xs):
    xs = sorted(x for x in xs if x is not None)
    return xs[len(xs) // 2] if xs else None


# A set whose images were posed but that `dbarf eval-poses` cannot score (cameras collapsed onto a
# point or a line) counts as a failure, not as a missing value, in the error medians.
def errors_of(rs, key):
    return [float("inf") if r[key] is None else r[key] for r in rs if r["posed"] > 0]


def fmt(x, spec):
    return "-" if x is None else "fail" if x == float("inf") else spec % x


def main():
    os.makedirs(WORK, exist_ok=True)
    records = []
    sets = make_sets()
    t_start = time.time()
    if os.environ.get("REPORT_FROM_JSON"):  # rewrite the table from an earlier run's raw figures
        records, sets = json.load(open(os.environ["REPORT_FROM_JSON"]))["sets"], []
    for k, (row, seed, views, size, material, spread) in enumerate(sets):
        data = os.path.join(WORK, "set_%d_%d_%s_%s_%g" % (seed, views, size, material, spread))
        render(seed, views, size, material, spread, data)
        for method in METHODS:
            result, seconds = run_method(method, data, data + ".runs")
            if views >= 20:
                result.update(novel_views(method, data, data + ".runs"))
            result.update({"row": row, "seed": seed, "views": views, "size": size, "material": material, "spread": spread,
                           "method": method, "seconds": seconds})
            records.append(result)
        done = k + 1
        rate = done / (time.time() - t_start)
        print("[%d/%d sets] %s seed %d done; %.2f sets/min, ETA %.0f s" % (done, len(sets), row, seed, 60 * rate,
                                                                          (len(sets) - done) / rate), file=sys.stderr)
    rows = []
    for row in dict.fromkeys(r["row"] for r in records):
        for method in METHODS:
            rs = [r for r in records if r["row"] == row and r["method"] == method]
            complete = [r for r in rs if r["posed"] == r["images"]]
            ok = [r for r in complete if r["rotation_deg"] is not None and r["rotation_deg"] <= 2.0]
            rows.append({"row": row, "method": method, "sets": len(rs), "images": sum(r["images"] for r in rs),
                         "posed": sum(r["posed"] for r in rs), "sets_all_posed": len(complete),
                         "sets_all_posed_within_2deg": len(ok),
                         "rotation_deg_median": median(errors_of(rs, "rotation_deg")),
                         "direction_deg_median": median(errors_of(rs, "direction_deg")),
                         "centre_percent_median": median(errors_of(rs, "centre_percent")),
                         "seconds_median": median([r["seconds"] for r in rs]),
                         "psnr_median": median([r.get("psnr") for r in rs]),
                         "ssim_median": median([r.get("ssim") for r in rs])})
    command = "bash bench/dbarf_poses_bench.sh " + WORK
    knobs = {k: os.environ[k] for k in ("SIZES20", "SEEDS20", "SPARSE_VIEWS", "SPARSE_SETS", "SPARSE_SPREAD", "HARD_MATERIALS",
                                         "HARD_SETS", "HARD_VIEWS", "METHODS", "FINETUNE_STEPS", "FINETUNE_SCHEDULE",
                                         "FINETUNE_DECAY_STEPS", "FINETUNE_STAGE_STEPS", "FINETUNE_DEPTH_BA_STEPS",
                                         "FINETUNE_DEPTH_BA_SOURCES", "FINETUNE_DEPTH_BA_VIEW_RANGE", "TWO_VIEW")
             if k in os.environ}
    if knobs:
        command = " ".join("%s=%s" % (k, json.dumps(v) if " " in v else v) for k, v in knobs.items()) + " " + command
    machine = "%s, %d cores, load %s" % (platform.machine(), os.cpu_count(), open("/proc/loadavg").read().split()[0])
    date = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
    if os.environ.get("REPORT_FROM_JSON"):  # the figures' own date and machine
        earlier = json.load(open(os.environ["REPORT_FROM_JSON"]))
        date, machine = earlier["date"], earlier["machine"]
    os.makedirs(os.path.dirname(OUT_JSON), exist_ok=True)
    with open(OUT_JSON, "w") as f:
        json_rows = [{k: "fail" if v == float("inf") else v for k, v in r.items()} for r in rows]
        json.dump({"date": date, "machine": machine, "command": command, "reduced": REDUCED, "rows": json_rows,
                   "sets": records}, f, indent=1)
    lines = ["# Poses of unposed images by method (`bench/dbarf_poses_bench.sh`)", "",
             "Date %s; machine %s; command `%s`; raw per-set figures in `%s`." % (date, machine, command,
                                                                                  os.path.relpath(OUT_JSON, ROOT)), ""]
    if REDUCED:
        lines += ["Reduced configuration: " + REDUCED, ""]
    lines += ["Procedural forward-facing scenes rendered from seeds 5000+ (never used in training, validation, tests or the "
              "held-out test split). Per row and method, over its sets: images posed; sets with every image posed; of those, "
              "sets whose median rotation error is <= 2 deg; medians over sets of the per-set medians of the rotation error "
              "(deg, after aligning rotations then centres: `dbarf eval-poses --align rotations`), the translation-direction "
              "error (deg, over image pairs, alignment-free) and the centre error (%% of the widest baseline); median wall "
              "time per set (s, the whole command; network+finetune: `dbarf poses --method network` plus `dbarf finetune "
              "--refine-cameras --schedule %s`, %d steps, rates halved every %d, the test views held out). COLMAP 3.8 (CPU) with SIFT's peak threshold lowered to "
              "0.00167 (its default finds 15-30 features on these renders). Novel views (20-view rows): every 5th view "
              "rendered at the method's camera for it from the other views at theirs (`dbarf eval --cameras`), mean PSNR / "
              "SSIM per set, median over sets; `models/dbarf_cpu.pt`, or the finetuned weights for network+finetune; "
              "none for COLMAP (its output has no view graph or depth range to render from)." %
              (FINETUNE_SCHEDULE, FINETUNE_STEPS, FINETUNE_DECAY_STEPS), "",
              "| set | method | sets | posed | all posed | all posed, <= 2 deg | rotation (deg) | direction (deg) | centre (%) | wall (s) | novel PSNR (dB) | novel SSIM |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append("| %s | %s | %d | %d/%d | %d/%d | %d/%d | %s | %s | %s | %s | %s | %s |" % (
            r["row"], r["method"], r["sets"], r["posed"], r["images"], r["sets_all_posed"], r["sets"],
            r["sets_all_posed_within_2deg"], r["sets"], fmt(r["rotation_deg_median"], "%.3f"),
            fmt(r["direction_deg_median"], "%.2f"), fmt(r["centre_percent_median"], "%.2f"), fmt(r["seconds_median"], "%.1f"),
            fmt(r.get("psnr_median"), "%.2f"), fmt(r.get("ssim_median"), "%.4f")))
    with open(OUT_MD, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
