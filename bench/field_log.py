#!/usr/bin/env python3
"""Field logs (issue 29) on real data: replay, cost, and the low-power logging mode.

Real data: the 7-Scenes redkitchen frames (1000, 640x480 at 30 Hz), at the defaults (labels on: the
real-camera network) unless said.

  1. Replay. `run --log` with the colour logged losslessly (--log-color png), then
     `run --source mcap:LOG`: the trajectory must be byte-identical (depth is lossless, and the
     colour is the recording's own). With the default JPEG colour the replay sees other colour
     values, so its trajectory differs: both ATEs against the recording's poses are printed.
     @mcap/core (tests/npm) reads the log: schemas and message counts.
  2. The cost of logging on the mapping rate: the same run with and without --log, one after the
     other (Hz = frames / wall time of the run as `run` prints it).
  3. The low-power mode: `edgefusion log --realtime` (record only) against `edgefusion run
     --realtime` (the full pipeline), both paced at the recording's 30 Hz: CPU time per frame
     (user + system of the process, getrusage), one after the other. Decoding the dataset's PNG
     files is part of both (it stands in for the camera driver).

Usage: /usr/bin/python3 bench/field_log.py [--data DIR] [--edgefusion BIN] [--work DIR] [--skip-cpu]
"""
import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from kill_resume import ate_cm  # noqa: E402  (the same `edgefusion eval ate` reading)


def timed(cmd):
    """Runs cmd; returns (wall s, CPU s of the child, stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    out = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {out.stderr.strip()[-400:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, out.stdout


def run_hz(stdout):
    for line in stdout.splitlines():
        if line.startswith("frames ") and " fps)" in line:
            return float(line.split("(")[1].split()[0]), int(line.split()[1])
    raise RuntimeError("no frames line in: " + stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=os.path.join(REPO, "..", "shared", "data", "7scenes-redkitchen"))
    ap.add_argument("--edgefusion", default=os.environ.get("EDGEFUSION", os.path.join(
        REPO, "build", "release", "firmware_app", "edgefusion")))
    ap.add_argument("--work", default="")
    ap.add_argument("--skip-cpu", action="store_true", help="leave out part 3 (two runs of 33 s)")
    a = ap.parse_args()
    if not os.path.isdir(a.data):
        print(f"field_log: SKIPPED: no 7-Scenes data at {a.data}", file=sys.stderr)
        return 2
    ef = a.edgefusion
    work = a.work or tempfile.mkdtemp(prefix="field_log.")
    os.makedirs(work, exist_ok=True)
    source = "7scenes:" + os.path.abspath(a.data)
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    print(f"machine: {cpu}, {os.cpu_count()} cores; data: {a.data} (real, 1000 frames, 640x480)")
    gt_dir = os.path.join(work, "reference-poses")
    if not os.path.exists(os.path.join(gt_dir, "groundtruth.txt")):
        shutil.rmtree(gt_dir, ignore_errors=True)
        subprocess.run([ef, "convert", "--source", source, "--to", "tum:" + gt_dir, "--resolution", "80x60",
                        "--quiet"], check=True, capture_output=True)
    gt = os.path.join(gt_dir, "groundtruth.txt")
    summary_js = os.path.join(REPO, "tests", "npm", "mcap_summary.mjs")
    have_npm = os.path.isdir(os.path.join(REPO, "tests", "npm", "node_modules", "@mcap", "core"))
    failed = False

    # 2 first (its runs give part 1's originals too): without a log, with the default log, with PNG colour.
    base = ["run", "--source", source, "--quiet", "--overwrite"]
    runs = {}
    for name, extra in (("no log", []), ("log (jpeg colour)", ["--log", "log.mcap"]),
                        ("log (png colour)", ["--log", "log.mcap", "--log-color", "png"])):
        d = os.path.join(work, name.split()[0] + ("-" + extra[-1] if extra else ""))
        wall, cpu_s, out = timed([ef] + base + ["--out", d] + extra)
        hz, frames = run_hz(out)
        log = os.path.join(d, "log.mcap")
        size = os.path.getsize(log) / 1e6 if os.path.exists(log) else 0
        stats = json.load(open(os.path.join(d, "stats.json")))
        log_ms = stats["stages"].get("log", {}).get("median_ms", 0)
        runs[name] = (d, hz)
        print(f"{name:18}: {frames} frames, {hz:5.1f} Hz, CPU {1000 * cpu_s / frames:5.1f} ms/frame"
              + (f", log {size:6.1f} MB ({size / frames * 1000:.0f} kB/frame), writing a frame {log_ms:.1f} ms "
                 f"median on the front thread" if size else ""))
    print(f"mapping rate with the default log / without: {runs['log (jpeg colour)'][1]:.1f} / "
          f"{runs['no log'][1]:.1f} Hz = {runs['log (jpeg colour)'][1] / runs['no log'][1]:.3f}")

    # 1. Replay.
    for name in ("log (png colour)", "log (jpeg colour)"):
        d = runs[name][0]
        r = os.path.join(d, "replayed")
        subprocess.run([ef, "run", "--source", "mcap:" + os.path.join(d, "log.mcap"), "--quiet", "--overwrite",
                        "--out", r], check=True, capture_output=True)
        orig = open(os.path.join(d, "trajectory.txt")).read()
        again = open(os.path.join(r, "trajectory.txt")).read()
        same = orig == again
        a1, a2 = ate_cm(ef, gt, os.path.join(d, "trajectory.txt")), ate_cm(ef, gt, os.path.join(r, "trajectory.txt"))
        print(f"replay of the {name[5:-1]} log: trajectory {'byte-identical' if same else 'differs'}; ATE original "
              f"{a1:.3f} cm, replayed {a2:.3f} cm")
        if name == "log (png colour)" and not same:
            failed = True
        if have_npm:
            js = json.loads(subprocess.run(["node", summary_js, os.path.join(d, "log.mcap")], capture_output=True,
                                           text=True, check=True).stdout)
            print("  @mcap/core: " + ("indexed" if js["indexed"] else "streamed") + f", {js['chunks']} chunks, "
                  + ", ".join(f"{t} {n} ({js['schemas'][t].split('/')[-1]})" for t, n in sorted(js["counts"].items())))

    # 3. CPU per frame at 30 Hz: the logging mode against the full pipeline.
    if not a.skip_cpu:
        lg = os.path.join(work, "lowpower.mcap")
        if os.path.exists(lg):
            os.remove(lg)
        w1, c1, out1 = timed([ef, "log", "--source", source, "--out", lg, "--realtime", "--quiet"])
        w2, c2, out2 = timed([ef, "run", "--source", source, "--realtime", "--quiet", "--overwrite", "--out",
                              os.path.join(work, "realtime-run")])
        _, frames = run_hz(out2)
        logged = int(out1.split()[1])  # "logged N frames ..."
        print(f"at 30 Hz (--realtime), 640x480: logging mode CPU {1000 * c1 / logged:.1f} ms/frame ({w1:.1f} s wall), "
              f"full pipeline CPU {1000 * c2 / frames:.1f} ms/frame ({w2:.1f} s wall): ratio {c2 / c1:.1f}x")
        print("  " + out1.strip())
        # Cheaper logs: depth not encoded (16UC1, 3x the bytes), and colour left out too (the
        # source's own cost, plus writing depth).
        for extra in (["--log-depth", "raw"], ["--log-depth", "raw", "--log-color", "none"]):
            os.remove(lg)
            w, c, out = timed([ef, "log", "--source", source, "--out", lg, "--realtime", "--quiet"] + extra)
            n = int(out.split()[1])
            print(f"  logging mode {' '.join(extra)}: CPU {1000 * c / n:.1f} ms/frame, "
                  f"{os.path.getsize(lg) / 1e6 / n * 1000:.0f} kB/frame ({w:.1f} s wall)")
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
