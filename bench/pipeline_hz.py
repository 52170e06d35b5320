#!/usr/bin/env python3
"""End-to-end rate of `edgefusion run` (issue 7): the 7-Scenes frames at 320x240, the CNN every 10th
frame, on this machine's cores. Each repetition runs the one-thread pipeline (front, CNN and
mapping steps take turns) and the two-thread pipeline (front + CNN on a thread of their own) back to
back (and others given with --threads, e.g. 3), so their ratio is measured side by side under the
same load.

For every run it reads stats.json (frames per second over the whole run, per-stage medians, the
peak resident memory from getrusage) and samples the process's resident memory (VmRSS) every
0.25 s, to show that memory is flat once the buffers are touched: everything large is allocated
at start-up, so RSS grows only while the surfel pool's pages are first written.

  /usr/bin/python3 bench/pipeline_hz.py --edgefusion build/release/firmware_app/edgefusion \\
      [--source 7scenes:../shared/data/7scenes-redkitchen] [--frames -1] [--reps 3] [--work /tmp/pipeline-hz]
      [--threads 1 2] [--extra "--surfel-capacity 1000000"]
Prints medians over the repetitions; the goal is at least 30 Hz with two threads and a peak RSS of
at most 256 MB with the default 1,000,000-surfel pool.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time

STAGES = ["source", "resample", "preprocess", "segment", "front_total", "track", "fuse", "predict", "label_fuse",
          "slam_total", "mapping_total"]


def rss_mb(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1000.0  # kB -> MB (10^6 bytes, as the memory plan)
    except OSError:
        return None
    return None


def one_run(ef, source, frames, threads, out, extra):
    cmd = [ef, "run", "--source", source, "--frames", str(frames), "--threads", str(threads), "--out", out,
           "--overwrite", "--quiet"] + extra
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    samples = []  # (seconds since start, RSS MB)
    while p.poll() is None:
        r = rss_mb(p.pid)
        if r is not None:
            samples.append((time.monotonic() - t0, r))
        time.sleep(0.25)
    stdout, stderr = p.communicate()
    if p.returncode != 0:
        sys.exit(f"pipeline_hz: {' '.join(cmd)} failed ({p.returncode}):\n{stderr}")
    with open(os.path.join(out, "stats.json")) as f:
        stats = json.load(f)
    return stats, samples


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--edgefusion", required=True)
    ap.add_argument("--source", default="7scenes:../shared/data/7scenes-redkitchen")
    ap.add_argument("--frames", type=int, default=-1, help="frames per run; -1 = all the source has")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--work", default="/tmp/pipeline-hz")
    ap.add_argument("--extra", default="", help="more `edgefusion run` options, one string")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="pipeline modes to compare (1, 2, 3)")
    a = ap.parse_args()
    extra = shlex.split(a.extra)
    modes = a.threads
    if 1 not in modes or 2 not in modes:
        sys.exit("pipeline_hz: --threads must include 1 and 2 (the ratio and the goal are read from them)")
    fps = {t: [] for t in modes}
    stages = {t: {s: [] for s in STAGES} for t in modes}
    peak = {t: [] for t in modes}
    rss_curves = {}
    frames = None
    for rep in range(a.reps):
        for threads in modes:
            out = os.path.join(a.work, f"t{threads}-r{rep}")
            stats, samples = one_run(a.edgefusion, a.source, a.frames, threads, out, extra)
            frames = stats["frames"]
            fps[threads].append(stats["fps"])
            peak[threads].append(stats["peak_rss_bytes"] / 1e6)
            for s in STAGES:
                st = stats["stages"].get(s)
                if st and st["count"] > 0:
                    stages[threads][s].append(st["median_ms"])
            rss_curves[threads] = samples
            print(f"rep {rep + 1}/{a.reps}, {threads} thread{'s' if threads > 1 else ''}: {stats['fps']:.1f} Hz, "
                  f"{frames} frames, lost {stats['counters']['lost_frames']}, peak RSS {peak[threads][-1]:.1f} MB",
                  flush=True)

    print(f"\n{a.source}, {frames} frames per run, {a.reps} repetitions, {os.cpu_count()} cores; medians")
    print("| | " + " | ".join(f"{t} thread{'s' if t > 1 else ''}" for t in modes) + " |")
    print("|---|" + "---:|" * len(modes))
    print("| end-to-end Hz | " + " | ".join(f"{statistics.median(fps[t]):.1f}" for t in modes) + " |")
    for s in STAGES:
        cells = [f"{statistics.median(stages[t][s]):.2f}" if stages[t][s] else "-" for t in modes]
        print(f"| {s} ms | " + " | ".join(cells) + " |")
    print("| peak RSS MB | " + " | ".join(f"{statistics.median(peak[t]):.1f}" for t in modes) + " |")
    ratios = [b / a_ for a_, b in zip(fps[1], fps[2])]
    print(f"\ntwo threads / one thread, per repetition side by side: "
          f"{', '.join(f'{r:.2f}' for r in ratios)} (median {statistics.median(ratios):.2f}x)")
    for threads, samples in sorted(rss_curves.items()):
        if not samples:
            continue
        end = samples[-1][0]
        marks = []
        for q in (0.1, 0.25, 0.5, 0.75, 1.0):
            t, r = min(samples, key=lambda s: abs(s[0] - q * end))
            marks.append(f"{int(q * 100)}% {r:.0f}")
        print(f"RSS over the last run, {threads} thread{'s' if threads > 1 else ''} (MB at % of its time): "
              + ", ".join(marks))
    goal_hz = statistics.median(fps[2]) >= 30.0
    print(f"\ngoal >= 30 Hz with two threads: {'met' if goal_hz else 'NOT met'}; "
          f"goal peak RSS <= 256 MB: {'met' if max(peak[2]) <= 256 else 'NOT met'}")


if __name__ == "__main__":
    main()
