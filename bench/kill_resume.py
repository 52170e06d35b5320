#!/usr/bin/env python3
"""Never lose a run (issue 29): `edgefusion run` killed at random moments, then resumed.

Real data: the 7-Scenes redkitchen frames (1000, labels on: the real-camera network, every 10th
frame), at the defaults except --checkpoint-seconds (default here 2 s, so that a run of ~20 s has
checkpoints to lose; the product's default is 30 s).

  1. One uninterrupted run (the reference): its wall time T, its trajectory, its ATE against the
     recording's poses (`edgefusion convert ... --to tum:` then `edgefusion eval ate`).
  2. --kills runs, each sent SIGKILL (and --terms runs sent SIGTERM) at a moment drawn uniformly from
     [0.5 s, T] (seeded: --seed). After each, what the folder holds is checked:
       trajectory.txt  every line parses (8 numbers, or a comment)
       stats.json      parses; says "running" after SIGKILL, "stopped" after SIGTERM
       checkpoint.efs  present and valid (`edgefusion export` reads it) once the kill came later
                       than the first checkpoint, and no older than the interval plus its write
                       (its age: kill time - the file's modification time)
       map.ply         absent or whole (never half written)
       log.mcap        the field log (run --log): @mcap/core (tests/npm/mcap_summary.mjs) reads it,
                       through its index after SIGTERM (closed), streamed up to its last whole
                       chunk after SIGKILL; its frames lag the trajectory's by at most one chunk
                       (log.chunk_seconds of recording, 30 frames) plus the frames in flight
     then `edgefusion run --resume DIR` finishes the run: its ATE against the same poses, the
     difference to the reference's, and whether the trajectory is byte-identical to it.
Prints one line per kill and a summary: the worst checkpoint age, the largest |ATE - reference|
(the issue's acceptance: within 0.2 cm), how many resumed trajectories are byte-identical.

Usage: /usr/bin/python3 bench/kill_resume.py [--kills 20] [--terms 5] [--seed 1] [--checkpoint-seconds 2]
           [--data DIR] [--edgefusion BIN] [--work DIR] [--no-log]
Exit status: 0 when every check held, 1 when one failed, 2 when the data or the binary is missing.
"""
import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_trajectory(path):
    """Pose lines of a TUM file; raises ValueError naming the first line that does not parse."""
    poses = []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if not line.endswith("\n"):
                raise ValueError(f"{path}:{n}: last line without its newline (cut)")
            t = line.strip()
            if not t or t.startswith("#"):
                continue
            fields = t.split()
            if len(fields) != 8:
                raise ValueError(f"{path}:{n}: {len(fields)} fields")
            poses.append([float(x) for x in fields])
    return poses


def ate_cm(ef, gt, traj):
    out = subprocess.run([ef, "eval", "ate", gt, traj], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(out.stderr.strip())
    for line in out.stdout.splitlines():
        k, v = line.split()
        if k == "ate_rmse_m":
            return 100.0 * float(v)
    raise RuntimeError("no ate_rmse_m")


def ply_whole(path):
    """A binary PLY's header count against its body size (40-byte records)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    count = next(int(l.split()[2]) for l in data[:end].decode().splitlines() if l.startswith("element vertex"))
    return len(data) - end == 40 * count


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kills", type=int, default=20)
    ap.add_argument("--terms", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--checkpoint-seconds", type=float, default=2.0)
    ap.add_argument("--data", default=os.path.join(REPO, "..", "shared", "data", "7scenes-redkitchen"))
    ap.add_argument("--edgefusion", default=os.environ.get("EDGEFUSION",
                                                           os.path.join(REPO, "build", "release", "firmware_app",
                                                                        "edgefusion")))
    ap.add_argument("--work", default="")
    ap.add_argument("--no-log", action="store_true", help="runs without a field log")
    a = ap.parse_args()
    if not os.path.isdir(a.data):
        print(f"kill_resume: SKIPPED: no 7-Scenes data at {a.data}", file=sys.stderr)
        return 2
    if not os.access(a.edgefusion, os.X_OK):
        print(f"kill_resume: no edgefusion binary at {a.edgefusion} (build it: cmake --preset release && "
              f"cmake --build build/release --target edgefusion)", file=sys.stderr)
        return 2
    ef = a.edgefusion
    work = a.work or tempfile.mkdtemp(prefix="kill_resume.")
    os.makedirs(work, exist_ok=True)
    source = "7scenes:" + os.path.abspath(a.data)
    run_args = ["--source", source, "--checkpoint-seconds", str(a.checkpoint_seconds), "--quiet", "--overwrite"]
    summary_js = os.path.join(REPO, "tests", "npm", "mcap_summary.mjs")
    with_log = not a.no_log
    if with_log and not os.path.isdir(os.path.join(REPO, "tests", "npm", "node_modules", "@mcap", "core")):
        print("kill_resume: the field log check needs tests/npm's readers: (cd tests/npm && npm ci)", file=sys.stderr)
        return 2
    if with_log:
        run_args += ["--log", "log.mcap"]
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    print(f"machine: {cpu}, {os.cpu_count()} cores; data: {a.data} (real, 1000 frames); "
          f"checkpoint every {a.checkpoint_seconds} s; seed {a.seed}")

    gt_dir = os.path.join(work, "reference-poses")
    if not os.path.exists(os.path.join(gt_dir, "groundtruth.txt")):
        shutil.rmtree(gt_dir, ignore_errors=True)
        subprocess.run([ef, "convert", "--source", source, "--to", "tum:" + gt_dir, "--resolution", "80x60",
                        "--quiet"], check=True, capture_output=True)
    gt = os.path.join(gt_dir, "groundtruth.txt")

    ref = os.path.join(work, "reference")
    t0 = time.monotonic()
    subprocess.run([ef, "run", "--out", ref] + run_args, check=True, capture_output=True)
    total = time.monotonic() - t0
    ref_traj = open(os.path.join(ref, "trajectory.txt")).read()
    ref_ate = ate_cm(ef, gt, os.path.join(ref, "trajectory.txt"))
    ref_stats = json.load(open(os.path.join(ref, "stats.json")))
    pause = ref_stats["stages"]["checkpoint"]
    print(f"reference: {total:.1f} s uninterrupted, ATE {ref_ate:.3f} cm, {ref_stats['checkpoints']:.0f} checkpoints, "
          f"each a pause of {pause['median_ms']:.1f} ms median ({pause['max_ms']:.1f} max)")

    rng = random.Random(a.seed)
    # Moments up to 95% of the reference's length: a run that ends before its signal (runs vary by a
    # few per cent) is reported as such and not counted.
    plan = [(signal.SIGKILL, rng.uniform(0.5, 0.95 * total)) for _ in range(a.kills)] + \
           [(signal.SIGTERM, rng.uniform(0.5, 0.95 * total)) for _ in range(a.terms)]
    failures = []
    worst_age, worst_date, identical, late, worst_lag = 0.0, 0.0, 0, 0, 0
    print(f"{'#':>3} {'signal':7} {'at s':>6} {'frames':>6} {'poses':>6} {'state':9} {'ckpt age s':>10} "
          f"{'log frames':>10} {'resume s':>8} {'ATE cm':>7} {'dATE cm':>8} identical")
    for i, (sig, at) in enumerate(plan):
        d = os.path.join(work, f"k{i:02d}")
        shutil.rmtree(d, ignore_errors=True)
        p = subprocess.Popen([ef, "run", "--out", d] + run_args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(at)
        killed_at = time.time()
        p.send_signal(sig)
        rc = p.wait()
        name = "SIGKILL" if sig == signal.SIGKILL else "SIGTERM"
        fail = []
        if rc == 0 and sig == signal.SIGKILL:
            print(f"{i:>3} {name:7} {at:6.1f}  the run had ended before the signal: not counted")
            late += 1
            continue
        try:
            poses = parse_trajectory(os.path.join(d, "trajectory.txt"))
        except (OSError, ValueError) as e:
            poses = []
            fail.append(f"trajectory: {e}")
        state, frames = "?", -1
        try:
            st = json.load(open(os.path.join(d, "stats.json")))
            state, frames = st["state"], int(st["frames"])
            want = "running" if sig == signal.SIGKILL else "stopped"
            if state != want:
                fail.append(f"stats.json says {state}, expected {want}")
        except (OSError, ValueError, KeyError) as e:
            fail.append(f"stats.json: {e}")
        ckpt = os.path.join(d, "checkpoint.efs")
        age = float("nan")
        if os.path.exists(ckpt):
            age = killed_at - os.path.getmtime(ckpt)
            ex = subprocess.run([ef, "export", d, "--out", os.path.join(d, "exported.ply")], capture_output=True,
                                text=True)
            if ex.returncode != 0:
                fail.append(f"checkpoint not readable: {ex.stderr.strip()}")
            # After SIGTERM the last checkpoint is written at the stop: age ~0.
            if age > a.checkpoint_seconds + 1.0:
                fail.append(f"checkpoint {age:.1f} s old")
            worst_age = max(worst_age, age)
        elif at > a.checkpoint_seconds + 1.5:
            fail.append("no checkpoint")
        if os.path.exists(os.path.join(d, "map.ply")) and not ply_whole(os.path.join(d, "map.ply")):
            fail.append("map.ply half written")
        for leftover in ("map.ply.partial",):
            if os.path.exists(os.path.join(d, leftover)) and sig == signal.SIGTERM:
                fail.append(f"{leftover} left after SIGTERM")
        log_frames = -1
        if with_log:
            lp = os.path.join(d, "log.mcap")
            if not os.path.exists(lp):
                fail.append("no log.mcap")
            else:
                out = subprocess.run(["node", summary_js, lp], capture_output=True, text=True)
                if out.returncode != 0:
                    fail.append(f"@mcap/core cannot read log.mcap: {(out.stderr or out.stdout).strip()[-200:]}")
                else:
                    js = json.loads(out.stdout)
                    log_frames = js["counts"].get("/camera/depth", 0)
                    if sig == signal.SIGTERM and not js["indexed"]:
                        fail.append("log.mcap not closed after SIGTERM")
                    lag = len(poses) - log_frames
                    worst_lag = max(worst_lag, lag)
                    if lag > 40:
                        fail.append(f"log.mcap holds {log_frames} frames, the trajectory {len(poses)}")
        # Resume (from the checkpoint; without one, a kill before the first: the run starts over).
        t1 = time.monotonic()
        if os.path.exists(ckpt) or os.path.exists(os.path.join(d, "checkpoint.prev.efs")):
            r = subprocess.run([ef, "run", "--resume", d, "--quiet"], capture_output=True, text=True)
        else:
            r = subprocess.run([ef, "run", "--out", d] + run_args, capture_output=True, text=True)
        resume_s = time.monotonic() - t1
        ate = date = float("nan")
        same = False
        if r.returncode != 0:
            fail.append(f"resume failed: {r.stderr.strip()[-300:]}")
        else:
            ate = ate_cm(ef, gt, os.path.join(d, "trajectory.txt"))
            date = ate - ref_ate
            worst_date = max(worst_date, abs(date))
            if abs(date) > 0.2:
                fail.append(f"ATE {ate:.3f} cm, {date:+.3f} from the reference")
            same = open(os.path.join(d, "trajectory.txt")).read() == ref_traj
            identical += same
        print(f"{i:>3} {name:7} {at:6.1f} {frames:6d} {len(poses):6d} {state:9} {age:10.2f} {log_frames:10d} {resume_s:8.1f} "
              f"{ate:7.3f} {date:+8.3f} {'yes' if same else 'no'}" + ("" if not fail else "   FAIL: " + "; ".join(fail)))
        if fail:
            failures.append(i)
        if not a.work:
            shutil.rmtree(d, ignore_errors=True)
    n = len(plan) - late
    print(f"summary: {n} interruptions ({a.kills} SIGKILL, {a.terms} SIGTERM; {late} came after the run's end and are "
          f"not counted); checkpoint age at most {worst_age:.2f} s "
          f"(interval {a.checkpoint_seconds} s); |ATE - reference| at most {worst_date:.3f} cm (goal 0.2); "
          f"{identical} of {n} resumed trajectories byte-identical to the uninterrupted run; "
          + (f"field log read by @mcap/core after every interruption, at most {worst_lag} frames behind the "
             f"trajectory; " if with_log else "") +
          f"{len(failures)} failed")
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
