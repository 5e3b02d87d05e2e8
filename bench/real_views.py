"""Novel views of held-out real photos: the shipped generalizable renderer against its per-scene
finetune (bench/real_views.sh says what and how)."""
import argparse
import datetime
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import real_poses as rp  # noqa: E402  (the ViSP sets and their preparation)

HOLD_OUT_EVERY = 6  # every 6th image (the 6th, 12th, ...) is a held-out test view


def run(cmd, logf):
    rp.log(" ".join(cmd))
    t0 = time.time()
    with open(logf, "w") as f:
        rc = subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT)
    if rc != 0:
        raise SystemExit("error: %s: exit %d (log %s)" % (cmd[0], rc, logf))
    return time.time() - t0


def scenes_with_split(posed, dataset, cameras):
    """From the posed images' transforms.json, with every HOLD_OUT_EVERY-th frame marked test and each
    frame's near and far those of the whole scene: `cameras`, the file as dbarf poses wrote it (its
    view graph and depth range, what finetune and eval --cameras read), and `dataset`, the same
    frames without the posing record (dbarf eval scores against a dataset, not a posing output)."""
    t = json.load(open(posed))
    base = os.path.dirname(os.path.abspath(posed))
    near, far = t["dbarf_poses"]["near"], t["dbarf_poses"]["far"]
    for k, f in enumerate(t["frames"]):
        f["file_path"] = os.path.normpath(os.path.join(base, f["file_path"]))
        f["split"] = "test" if k % HOLD_OUT_EVERY == HOLD_OUT_EVERY - 1 else "train"
        f["near"], f["far"] = near, far
    plain = {k: v for k, v in t.items() if k not in ("dbarf_poses", "view_graph", "confidence_doc", "low_confidence",
                                                     "not_posed")}
    for path, content in ((cameras, t), (dataset, plain)):
        json.dump(content, open(path + ".tmp", "w"), indent=1)
        os.replace(path + ".tmp", path)
    return sum(f["split"] == "test" for f in t["frames"]), len(t["frames"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--nerfreg", required=True)
    ap.add_argument("--out-prefix", required=True)
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--command", default="")
    a = ap.parse_args()
    start = time.time()
    mach = rp.machine()
    os.makedirs(a.work, exist_ok=True)
    info = rp.prepare_visp("cube", rp.SETS["cube"], a.work, a.nerfreg)
    d = os.path.join(a.work, "cube")
    secs = {}
    secs["poses"] = run([a.nerfreg, "dbarf", "poses", info["images_dir"], "--method", "classical", "--out",
                         os.path.join(d, "poses"), "--force"], os.path.join(d, "poses.log"))
    scene, cameras = os.path.join(d, "scene.json"), os.path.join(d, "cameras.json")
    n_test, n = scenes_with_split(os.path.join(d, "poses", "transforms.json"), scene, cameras)
    width = ["--max-width", str(a.width)]
    env_one = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))
    rows = []
    for name, weights in (("shipped", None), ("finetuned", os.path.join(d, "finetuned.pt"))):
        if weights:
            cmd = [a.nerfreg, "dbarf", "finetune", cameras, "--schedule", "nerf", "--nerf-poses", "cameras", "--steps",
                   str(a.steps), "--out", weights, "--force"] + width
            rp.log(" ".join(cmd))
            t0 = time.time()
            with open(os.path.join(d, "finetune.log"), "w") as f:
                if subprocess.call(cmd, stdout=f, stderr=subprocess.STDOUT, env=env_one) != 0:
                    raise SystemExit("error: dbarf finetune failed (log %s)" % os.path.join(d, "finetune.log"))
            secs["finetune"] = time.time() - t0
        out = os.path.join(d, "eval_" + name)
        cmd = [a.nerfreg, "dbarf", "eval", scene, "--cameras", cameras, "--out", out, "--force"] + width
        if weights:
            cmd += ["--weights", weights]
        secs["eval_" + name] = run(cmd, out + ".log")
        e = json.load(open(os.path.join(out, "eval.json")))
        rows.append({"weights": name, "psnr_mean": e["psnr_mean"], "ssim_mean": e["ssim_mean"],
                     "views": [{k: v[k] for k in ("name", "psnr", "ssim", "sources")} for v in e["views"]
                               if v.get("rendered")],
                     "weights_file": e["weights"], "compare_png": os.path.join(out, "compare.png")})
    poses = json.load(open(os.path.join(d, "poses", "transforms.json")))
    res = {"command": a.command, "date": datetime.datetime.now().isoformat(timespec="seconds"), "machine": mach,
           "nerfreg": a.nerfreg, "set": {k: info[k] for k in ("what", "source", "frames", "images", "size")},
           "hold_out_every": HOLD_OUT_EVERY, "test_views": n_test, "images": n, "width": a.width,
           "finetune_steps": a.steps, "focal_px": poses.get("fl_x"), "k1": poses.get("k1"), "k2": poses.get("k2"),
           "seconds": secs, "bench_wall_s": time.time() - start, "rows": rows}
    json.dump(res, open(a.out_prefix + ".json.tmp", "w"), indent=1)
    os.replace(a.out_prefix + ".json.tmp", a.out_prefix + ".json")
    write_md(res, a.out_prefix + ".md")
    rp.log("wrote %s.json, %s.md" % (a.out_prefix, a.out_prefix))


def write_md(r, path):
    m = r["machine"]
    L = ["# Novel views of held-out real photos (`bench/real_views.sh`)", "",
         "Written by `bench/real_views.py` from `real_views.json`: `%s` (%s; %s, %d cores; the whole bench %.0f s; "
         "load average %s at the start)." % (r["command"], r["date"], m["cpu"], m["cores"], r["bench_wall_s"],
                                              " ".join(m["loadavg_start"])),
         "",
         "Set: ViSP's `cube` sequence (%s; %s, frames %s, %d images), posed by `dbarf poses --method classical` "
         "without a calibration file (self-calibrated: focal %.1f px, k1 %.4f, k2 %.4f). Every %dth image is held out "
         "(%d test views): rendered at its classical camera at %d px wide by `dbarf eval --cameras` from its view-graph "
         "neighbours among the other images, with the shipped weights and after `dbarf finetune --schedule nerf "
         "--nerf-poses cameras --steps %d` on the other images (the renderer alone, the cameras fixed; the held-out "
         "images are neither targets nor sources). The renderer models no lens distortion. Issue 45's target: >= 22 dB."
         % (r["set"]["what"], r["set"]["source"], r["set"]["frames"], r["images"], r["focal_px"] or 0,
            r["k1"] or 0, r["k2"] or 0, r["hold_out_every"], r["test_views"], r["width"], r["finetune_steps"]),
         "",
         "| weights | PSNR dB (mean) | SSIM (mean) | per view: PSNR / SSIM | seconds |",
         "|---|---|---|---|---|"]
    for row in r["rows"]:
        per = ", ".join("%s %.2f / %.3f" % (v["name"], v["psnr"], v["ssim"]) for v in row["views"])
        sec = r["seconds"].get("eval_" + row["weights"], 0) + (r["seconds"].get("finetune", 0)
                                                               if row["weights"] == "finetuned" else 0)
        L.append("| %s | %.2f | %.4f | %s | %.0f |" % (row["weights"], row["psnr_mean"], row["ssim_mean"], per, sec))
    L += ["", "Seconds: the finetuned row's include its finetune (one thread, `OMP_NUM_THREADS=1`)."]
    open(path + ".tmp", "w").write("\n".join(L) + "\n")
    os.replace(path + ".tmp", path)


if __name__ == "__main__":
    main()
