#!/usr/bin/env python3
"""The headline figures: every figure the README claims, measured side by side in one run on this
machine, written to docs/headline.md and into the README between its `<!-- headline -->` markers.
Run through bench/headline.sh, which builds what this needs first.

  /usr/bin/python3 bench/headline.py --build build/headline [--frames 1000] [--reps 3] [--no-readme]

The runs, one after the other (never together, so that they do not share the cores):
  SLAM        bench/slam_vs_open3d.sh: `edgefusion run --threads 1` on the 7-Scenes frames at
              320x240 (the sum of the medians of its preprocess, track, fuse and predict stages) and
              Open3D's frame-to-frame RGB-D odometry on the same frames (median of the call), both on
              one thread; the ATE of both trajectories against the reference poses.
  CNN         bench_nn_conv --model M for each shipped network (the real-camera DeepLabv3-MobileNetV2
              and the synthetic-room EdgeSegNet): its convolutions, one frame, our kernels against
              XNNPACK's int8 operators (thread CPU time, one thread); bench_nn_model --model M: the
              whole forward pass at the best ISA this CPU runs.
  agreement   edgefusion_models.agreement: the real-camera model's int8 labels against the float
              reference of its TFLite file on every 10th 7-Scenes frame (needs ../shared/models).
  pipeline    `edgefusion run` with the CNN every 10th frame (the defaults: the real-camera network
              beside the mapper), one and two threads
              back to back, --reps times (bench/pipeline_hz.py's runs): frames per second over the
              whole run and the peak resident memory (stats.json), medians.
  crf         bench_crf --checkpoint on the map of the first two-thread pipeline run (real, labels
              fused): 10 mean-field iterations over its confident surfels, one thread, median of 3;
              and `edgefusion plan --crf-final` for the 7-Scenes source at the default pool and budget.
  drift       bench/reference_consistency.py --far 300 on the SLAM run's trajectory and the reference
              poses: frame pairs 300 or more frames apart that view the same surface, registered
              directly depth to depth (no map, no trajectory beyond the start); each trajectory's
              relative pose against that registration, median translation and rotation.
  growth      bench/slam_growth.sh: the four SLAM stages per 1,000 frames of a 10,000-frame synthetic
              robot path, the last window's median sum against the second's, and the surfels.
"""
import argparse
import datetime
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "bench"))
import pipeline_hz  # noqa: E402  (the end-to-end runs and their RSS sampling)

BEGIN, END = "<!-- headline: bench/headline.sh -->\n", "<!-- /headline -->"


def log(msg):
    print(f"headline: {msg}", file=sys.stderr, flush=True)


def run(cmd, **kw):
    log("$ " + " ".join(cmd))
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if p.returncode != 0:
        sys.exit(f"headline: {' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
    return p.stdout


def metric(path, key):
    with open(path) as f:
        for line in f:
            parts = line.split()
            if len(parts) == 2 and parts[0] == key:
                return float(parts[1])
    return float("nan")


def machine():
    model = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    mem_gb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return f"{model}, {os.cpu_count()} cores, {mem_gb:.0f} GiB, {platform.system()} {platform.machine()}"


def slam(args, work):
    out = os.path.join(work, "slam")
    run(["bash", os.path.join(REPO, "bench", "slam_vs_open3d.sh"), "--frames", str(args.frames), "--edgefusion",
         args.edgefusion, "--out", out, "--data", args.data])
    with open(os.path.join(out, "ours", "stats.json")) as f:
        ours = json.load(f)
    with open(os.path.join(out, "open3d", "stats.json")) as f:
        o3d = json.load(f)
    stages = {s: ours["stages"][s]["median_ms"] for s in ("preprocess", "track", "fuse", "predict") if s in ours["stages"]}
    ours_ms = sum(stages.values())
    return {
        "frames": ours["frames"],
        "stages": stages,
        "ours_ms": ours_ms,
        "o3d_ms": o3d["odometry_median_ms"],
        "o3d_version": o3d.get("open3d_version", "?"),
        "ratio": o3d["odometry_median_ms"] / ours_ms,
        "ours_ate_cm": 100 * metric(os.path.join(out, "ours.ate"), "ate_rmse_m"),
        "o3d_ate_cm": 100 * metric(os.path.join(out, "open3d.ate"), "ate_rmse_m"),
        "lost": ours["counters"].get("lost_frames", 0),
        "surfels": ours.get("surfels", 0),
    }


def drift(args, work):
    """bench/reference_consistency.py --far 300 on the SLAM run: each trajectory's relative poses between
    frames far apart against direct registration of their depth images."""
    out = os.path.join(work, "slam")
    table = run(["/usr/bin/python3", os.path.join(REPO, "bench", "reference_consistency.py"),
                 os.path.join(out, "reference", "groundtruth.txt"), os.path.join(out, "ours", "trajectory.txt"),
                 "--far", "300", "--data", args.data])
    head = re.search(r"(\d+) registered to one answer from every start \(gaps (\d+)-(\d+) frames\)", table)
    rows = dict((m[0], (float(m[1]), float(m[2]))) for m in
                re.findall(r"^\| (\w+) \| ([\d.]+) \| [\d.]+ \| ([\d.]+) \|", table, re.M))
    if not head or "ours" not in rows or "reference" not in rows:
        sys.exit("headline: bench/reference_consistency.py --far printed no table:\n" + table)
    return {"pairs": int(head.group(1)), "gap_min": int(head.group(2)), "gap_max": int(head.group(3)),
            "ours_mm": rows["ours"][0], "ours_deg": rows["ours"][1],
            "ref_mm": rows["reference"][0], "ref_deg": rows["reference"][1]}


def cnn(args, model_file):
    model = os.path.join(REPO, "models", model_file)
    conv = run([os.path.join(args.build, "bench", "bench_nn_conv"), "--model", model, "--reps", "9"])
    m = re.search(r"model convolutions, one frame \((\d+) layers\): XNNPACK ([\d.]+) ms(?:, XNNPACK@avx2 ([\d.]+) ms)?;"
                  r" (?:avx2|neon) path ([\d.]+) ms \(([\d.]+)x\), best path ([\d.]+) ms \(([\d.]+)x\)", conv)
    if not m:
        sys.exit("headline: no 'model convolutions' line in bench_nn_conv's output:\n" + conv)
    res = {"layers": int(m.group(1)), "xnn_ms": float(m.group(2)),
           "xnn_avx2_ms": float(m.group(3)) if m.group(3) else None, "avx2_ms": float(m.group(4)),
           "avx2_ratio": float(m.group(5)), "best_ms": float(m.group(6)), "best_ratio": float(m.group(7))}
    g = re.search(r"goal >= 1.0x: \S+ path on (\d+) of (\d+) shapes, best path on (\d+) of (\d+) shapes", conv)
    res["shapes"] = (int(g.group(3)), int(g.group(4))) if g else None
    whole = run([os.path.join(args.build, "bench", "bench_nn_model"), "--model", model, "--reps", "9"])
    rows = re.findall(r"^\s+(\w+)\s+([\d.]+)\s+[\d.]+%\s+([\d.]+)\s+([\d.]+)\s", whole, re.M)
    if not rows:
        sys.exit("headline: no ISA rows in bench_nn_model's output:\n" + whole)
    best = rows[-1]
    res["forward_isa"], res["forward_ms"], res["mmac"] = best[0], float(best[1]), float(best[2])
    res["scalar_ms"] = float(rows[0][1])
    return res


def agreement(args):
    """The real-camera model's int8 argmax agreement with the float reference of its TFLite file."""
    tflite = os.path.join(args.shared, "models", "deeplabv3-mnv2-ade20k", "deeplabv3-mnv2-ade20k.tflite")
    with tempfile.TemporaryDirectory(prefix="edgefusion-agreement-") as tmp:
        out = os.path.join(tmp, "a.json")
        env = dict(os.environ, PYTHONPATH=os.path.join(REPO, "models"))
        subprocess.run(["/usr/bin/python3", "-m", "edgefusion_models.agreement", "--tflite", tflite, "--model",
                        os.path.join(REPO, "models", "deeplabv3-mnv2-nyu13.efm"), "--source", f"7scenes:{args.data}",
                        "--every", "10", "--edgefusion", args.edgefusion, "--json", out], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        with open(out) as f:
            return json.load(f)


def pipeline(args, work):
    source = f"7scenes:{args.data}"
    fps = {1: [], 2: []}
    peak = {1: [], 2: []}
    lost = 0
    for rep in range(args.reps):
        for threads in (1, 2):
            out = os.path.join(work, f"pipeline-t{threads}-r{rep}")
            stats, _ = pipeline_hz.one_run(args.edgefusion, source, args.frames, threads, out, [])
            fps[threads].append(stats["fps"])
            peak[threads].append(stats["peak_rss_bytes"] / 1e6)
            lost = stats["counters"]["lost_frames"]
            log(f"pipeline rep {rep + 1}/{args.reps}, {threads} thread(s): {stats['fps']:.1f} Hz, "
                f"peak RSS {peak[threads][-1]:.1f} MB")
    ratios = [b / a for a, b in zip(fps[1], fps[2])]
    return {"hz1": statistics.median(fps[1]), "hz2": statistics.median(fps[2]), "ratio": statistics.median(ratios),
            "rss1": statistics.median(peak[1]), "rss2": statistics.median(peak[2]), "lost": lost,
            "all_hz2": fps[2]}


def crf(args, work):
    """The dense CRF over the real map of the first two-thread pipeline run, and its plan."""
    folder = os.path.join(work, "pipeline-t2-r0")
    with open(os.path.join(folder, "stats.json")) as f:
        surfels = json.load(f)["surfels"]
    bench = os.path.join(args.build, "bench", "bench_crf")
    # Lattices sized as `run` sizes them (1.25 vertices per node; here per surfel of the whole map).
    out = run([bench, "--checkpoint", folder, "--reps", "3", "--max-vertices", str((5 * surfels + 3) // 4)])
    nodes = re.search(r"nodes: (\d+) of (\d+) surfels", out)
    ms = re.search(r"run\(\), 10 iterations\s+([\d.]+) ms", out)
    plan = run([args.edgefusion, "plan", "--source", f"7scenes:{args.data}", "--crf-final", "--out",
                os.path.join(work, "plan")])
    part = re.search(r"^dense crf\s+(\d+)\s+[\d.]+\s+(\d+) surfels", plan, re.M)
    total = re.search(r"^total\s+(\d+)", plan, re.M)
    budget = re.search(r"^budget\s+(\d+)", plan, re.M)
    return {"nodes": int(nodes.group(1)), "surfels": int(nodes.group(2)), "ms": float(ms.group(1)),
            "plan_nodes": int(part.group(2)), "plan_mb": int(total.group(1)) / 1e6, "budget_mb": int(budget.group(1)) / 1e6}


def growth(args):
    """bench/slam_growth.sh's table: the SLAM stages per 1,000 frames of a 10,000-frame synthetic run."""
    out = run(["bash", os.path.join(REPO, "bench", "slam_growth.sh"), "--bench",
               os.path.join(args.build, "bench", "bench_slam_stages")])
    windows = re.findall(r"^\s+(\d+)-(\d+)\s+(\d+)\s+[\d.]+\s+[\d.]+\s+[\d.]+\s+[\d.]+\s+([\d.]+)\s+(\d+)%", out, re.M)
    if len(windows) < 3:
        sys.exit("headline: bench/slam_growth.sh printed fewer than 3 windows:\n" + out)
    rows = [{"surfels": int(w[2]), "sum": float(w[3]), "blocks": int(w[4])} for w in windows]
    return {"frames": int(windows[-1][1]) + 1, "second": rows[1], "last": rows[-1],
            "ratio": rows[-1]["sum"] / rows[1]["sum"], "sums": [r["sum"] for r in rows]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(REPO, "build", "headline"))
    ap.add_argument("--frames", type=int, default=1000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--data", default=os.path.join(os.environ.get("EF_SHARED_DATA", os.path.join(REPO, "..", "shared", "data")),
                                                   "7scenes-redkitchen"))
    ap.add_argument("--shared", default=os.path.abspath(os.path.join(REPO, "..", "shared")),
                    help="the shared folder (the TFLite file of the real-camera network)")
    ap.add_argument("--no-readme", action="store_true")
    ap.add_argument("--setup-seconds", type=float, default=0)
    args = ap.parse_args()
    args.build = os.path.abspath(args.build)
    args.data = os.path.abspath(args.data)
    args.edgefusion = os.path.join(args.build, "firmware_app", "edgefusion")
    t0 = time.monotonic()
    load_before = os.getloadavg()[0]
    commit = subprocess.run(["git", "-C", REPO, "describe", "--always", "--dirty"], capture_output=True,
                            text=True).stdout.strip() or "unknown"
    with tempfile.TemporaryDirectory(prefix="edgefusion-headline-") as work:
        s = slam(args, work)
        d = drift(args, work)
        c = cnn(args, "edgefusion-seg.efm")
        dl = cnn(args, "deeplabv3-mnv2-nyu13.efm")
        a = agreement(args)
        p = pipeline(args, work)
        k = crf(args, work)
        g = growth(args)
    load_after = os.getloadavg()[0]
    minutes = (time.monotonic() - t0 + args.setup_seconds) / 60

    kitchen = f"real: 7-Scenes kitchen, {args.frames} Kinect frames"
    rows = [
        ("SLAM per frame (preprocess + track + fuse + predict, medians), one thread", f"{s['ours_ms']:.1f} ms",
         f"{kitchen}, 320x240", "bench/slam_vs_open3d.sh"),
        (f"Open3D {s['o3d_version']} RGB-D odometry per frame (frame to frame), one thread, same frames",
         f"{s['o3d_ms']:.1f} ms", kitchen, "same run"),
        ("Open3D time / SLAM time", f"{s['ratio']:.1f}x", kitchen, "same run"),
        ("Trajectory error (ATE RMSE): EdgeFusion / Open3D", f"{s['ours_ate_cm']:.2f} / {s['o3d_ate_cm']:.2f} cm",
         kitchen, "same run, `edgefusion eval ate`"),
        (f"Drift: relative pose of frames {d['gap_min']}-{d['gap_max']} apart against direct depth-to-depth registration "
         f"({d['pairs']} pairs), median: EdgeFusion / the dataset's reference (KinectFusion-made)",
         f"{d['ours_mm']:.1f} / {d['ref_mm']:.1f} mm, {d['ours_deg']:.2f} / {d['ref_deg']:.2f} deg", kitchen,
         "bench/reference_consistency.py --far 300 on the same run"),
        (f"Real-camera CNN (DeepLabv3-MobileNetV2, 257x193, {dl['mmac'] / 1000:.2f} G multiply-adds): whole forward "
         f"pass, {dl['forward_isa']}, one thread", f"{dl['forward_ms']:.1f} ms", "any input (timing)",
         "bench_nn_model --model"),
        (f"Its convolutions ({dl['layers']} layers), one frame: ours / XNNPACK, best ISA",
         f"{dl['best_ms']:.2f} / {dl['xnn_ms']:.2f} ms ({dl['best_ratio']:.2f}x)", "any input (timing)",
         "bench_nn_conv --model"),
        ("Its int8 labels against the float network of the TFLite file (argmax agreement, 14 classes)",
         f"{100 * a['agreement']:.2f}% of pixels", f"real: every 10th of the {args.frames} 7-Scenes frames",
         "edgefusion_models.agreement"),
        (f"Synthetic-room CNN (EdgeSegNet, 160x120, {c['mmac']:.1f} M multiply-adds): forward pass, {c['forward_isa']}",
         f"{c['forward_ms']:.2f} ms", "any input (timing)", "bench_nn_model"),
        (f"Its convolutions ({c['layers']} layers), one frame: ours / XNNPACK, best ISA",
         f"{c['best_ms']:.2f} / {c['xnn_ms']:.2f} ms ({c['best_ratio']:.2f}x)", "any input (timing)",
         "bench_nn_conv --model"),
    ]
    if c["xnn_avx2_ms"] is not None:
        rows.append(("The same on the AVX2 path: ours / XNNPACK capped at AVX2",
                     f"{c['avx2_ms']:.2f} / {c['xnn_avx2_ms']:.2f} ms ({c['avx2_ratio']:.2f}x)", "any input (timing)",
                     "same run"))
    rows += [
        ("End-to-end rate of `edgefusion run`, real-camera CNN beside the mapper, every 10th frame: 1 thread / 2 threads",
         f"{p['hz1']:.1f} / {p['hz2']:.1f} Hz", kitchen, f"bench/pipeline_hz.py's runs, median of {args.reps}"),
        ("Peak resident memory of that run, default 1,000,000-surfel pool, 2 threads", f"{p['rss2']:.0f} MB", kitchen,
         "same runs, stats.json peak_rss_bytes"),
        (f"Dense CRF over that run's map: 10 iterations over its {k['nodes']:,} confident surfels (of {k['surfels']:,}), "
         "one thread", f"{k['ms']:.0f} ms", kitchen, "bench_crf --checkpoint, median of 3"),
        ("`run --crf-final` at the default pool and budget: the CRF's surfels, the plan",
         f"{k['plan_nodes']:,}; {k['plan_mb']:.1f} of {k['budget_mb']:.0f} MB", "real: 7-Scenes kitchen (its model)",
         "edgefusion plan --crf-final"),
        (f"SLAM cost as the map grows: median per frame, last 1,000 of {g['frames']:,} frames / frames 1,000-1,999",
         f"{g['last']['sum']:.2f} / {g['second']['sum']:.2f} ms ({g['ratio']:.2f}x; "
         f"{g['second']['surfels'] / 1000:.0f}k -> {g['last']['surfels'] / 1000:.0f}k surfels)",
         "synthetic: a robot's path in a random room (seed 5001), 320x240", "bench/slam_growth.sh"),
    ]
    table = "| figure | value | data | measured by |\n|---|---|---|---|\n"
    for r in rows:
        table += "| " + " | ".join(r) + " |\n"

    when = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
    md = f"""# Headline figures

Written by `bash bench/headline.sh` (bench/headline.py) on {when}, at commit `{commit}`, on
{machine()}. One-minute load average {load_before:.2f} when the measurements began (the build
just before them raises it) and {load_after:.2f} at the end; the whole script took {minutes:.1f} minutes,
the build included. Every figure the README quotes is in this table, measured
in this one run; rerun the script when a change can move one of them.

{BEGIN}{table}{END}

## Details

- SLAM (`bench/slam_vs_open3d.sh --frames {args.frames}`): stage medians
  {", ".join(f"{k} {v:.2f}" for k, v in s['stages'].items())} ms; {s['lost']} frames lost;
  {s['surfels']:,} surfels at the end. Open3D's time is its odometry call alone (the frames are read
  and shrunk outside it); ours is the sum of the four stage medians (decoding and resampling not
  included).
- CNNs (`bench_nn_conv --model M --reps 9`, `bench_nn_model --model M --reps 9`, M each shipped
  model): thread CPU time, one thread, median of 9. Our kernels are faster than XNNPACK's on
  {dl['shapes'][0] if dl['shapes'] else '?'} of {dl['shapes'][1] if dl['shapes'] else '?'} convolution shapes of the
  real-camera network and {c['shapes'][0] if c['shapes'] else '?'} of {c['shapes'][1] if c['shapes'] else '?'}
  of EdgeSegNet on the best path. The forward passes' scalar references: {dl['scalar_ms']:.1f} ms and
  {c['scalar_ms']:.1f} ms. Agreement: median frame {100 * a['median_frame_agreement']:.2f}%, worst
  {100 * a['worst_frame_agreement']:.2f}% ({a['frames']} frames).
- Pipeline: two threads / one thread, side by side per repetition, median {p['ratio']:.2f}x; two-thread
  rates {", ".join(f"{v:.1f}" for v in p['all_hz2'])} Hz; peak RSS with one thread {p['rss1']:.0f} MB;
  {p['lost']} frames lost.
- Growth (`bench/slam_growth.sh`): median SLAM sum per 1,000 frames
  {", ".join(f"{v:.2f}" for v in g['sums'])} ms; predict visited {g['second']['blocks']}% of the pool's blocks in
  frames 1,000-1,999 and {g['last']['blocks']}% in the last 1,000 (slam/surfel_pool.h, block bounds).
"""
    with open(os.path.join(REPO, "docs", "headline.md"), "w") as f:
        f.write(md)
    log(f"wrote docs/headline.md ({minutes:.1f} minutes)")
    if not args.no_readme:
        path = os.path.join(REPO, "README.md")
        with open(path) as f:
            readme = f.read()
        a, b = readme.find(BEGIN), readme.find(END)
        if a < 0 or b < 0:
            sys.exit(f"headline: README.md has no {BEGIN.strip()} ... {END} block")
        readme = readme[:a + len(BEGIN)] + table + readme[b:]
        with open(path, "w") as f:
            f.write(readme)
        log("updated the README's table")
    print(md)


if __name__ == "__main__":
    main()
