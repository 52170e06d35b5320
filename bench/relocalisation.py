#!/usr/bin/env python3
"""Never stay lost, close the loop (issue 30): relocalisation, the full-pool policy and loop closure,
measured with `edgefusion run`.

Real data: the 7-Scenes redkitchen frames (1000, geometry only: --no-labels), at the defaults.
  uninterrupted   the whole recording: ATE, lost frames, keyframes; the reference for the others
  kidnap          cut=400-549: the camera jumps 150 frames (about 0.9 m). Reports how the jump was
                  taken (lost lines, the relocalisation line), the frames until tracking resumed,
                  and the ATE over the frames after the gap (both trajectories cut to them, then
                  `edgefusion eval ate`) beside the uninterrupted run's over the same frames
  kidnap, off     the same with mapping.relocalisation false and mapping.lost_inlier_drop 0 (as
                  before issue 30)
  covered lens    blank=500+30: 30 frames of zero depth and black colour. Lost frames, the resumption,
                  ATE, and the surfels created during the loss: surfels_created of a run stopped at
                  the end of the blank frames (--frames 530) minus that of one stopped before them
                  (--frames 500)
  small pools     --surfel-capacity 100000 and 20000: lost frames, ATE, evicted and refused surfels
  loop closure    the uninterrupted run has it on (the default); the same with mapping.loop_closure
                  false, and with ElasticFusion's association (mapping.associate_active_only true, so
                  that revisits leave an inactive model to close against): closures, ATE, surfels;
                  with that association also with mapping.pose_history 0, trajectory.txt as tracked
                  (what the closures' pose correction changes)
Synthetic (regression and the issue's failing case): synthetic:random?seed=7&trajectory=inspect&
camera=kinect with relocalisation on and off; the 2000-frame living-room loop (several laps, 320x240)
at the defaults and with ElasticFusion's association; the same loop with injected drift
(depth_bias=0.01: depth bent by 1% towards the corners) at the defaults, with loop closure off, and
with ElasticFusion's association with closure on (poses corrected, and as tracked) and off.
Cost: the stages `keyframe` (encoding and the novelty test, every tracked frame), `relocalise` (lost
frames and the one that resumes) and `loop_check` (every 10th fused frame; closures included) of
stats.json: median and p95 ms, and the loop check's mean per frame.

--scans instead runs the eleven held-out 1200-frame inspecting scans of Table I (seeds 5001-5006 and
the five built-in rooms, trajectory=inspect, 320x240) at the defaults: lost frames, relocalisations,
loop closures and ATE of each (a ghosted map shows as lost frames and a large ATE).

Usage: /usr/bin/python3 bench/relocalisation.py [--data DIR] [--edgefusion BIN] [--work DIR] [--scans]
Prints a Markdown table. Exit status 2 when the data or the binary is missing.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(cmd, check=True):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if check and p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr[-2000:]}")
    return p


def ate(edgefusion, gt, est):
    out = run([edgefusion, "eval", "ate", gt, est]).stdout
    return {l.split()[0]: float(l.split()[1]) for l in out.splitlines() if len(l.split()) == 2}


def cut_trajectory(src, dst, t_min):
    """The pose lines of a TUM file with timestamps >= t_min (comments dropped)."""
    with open(src) as f, open(dst, "w") as o:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            if float(line.split()[0]) >= t_min - 1e-6:
                o.write(line)


def comments(path, word):
    with open(path) as f:
        return [l.strip() for l in f if l.startswith("# " + word)]


def stats(folder):
    with open(os.path.join(folder, "stats.json")) as f:
        return json.load(f)


def stage(s, name):
    st = s["stages"].get(name)
    return (st["median_ms"], st["p95_ms"]) if st and st.get("count", 1) else (float("nan"), float("nan"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=os.path.join(REPO, "..", "shared", "data", "7scenes-redkitchen"))
    ap.add_argument("--edgefusion", default=os.path.join(REPO, "build", "release", "firmware_app", "edgefusion"))
    ap.add_argument("--work", default="")
    ap.add_argument("--scans", action="store_true", help="the eleven inspecting scans instead")
    a = ap.parse_args()
    if not os.path.isdir(a.data) or not os.path.isfile(a.edgefusion):
        print(f"relocalisation: needs {a.data} and {a.edgefusion}", file=sys.stderr)
        return 2
    work = a.work or tempfile.mkdtemp(prefix="relocalisation-")
    os.makedirs(work, exist_ok=True)
    E = a.edgefusion
    def config(name, mapping):
        """A --config file of mapping keys in the work folder; returns its path."""
        path = os.path.join(work, name + ".yaml")
        with open(path, "w") as f:
            f.write("mapping:\n" + "".join(f"  {k}: {v}\n" for k, v in mapping.items()))
        return path

    off = config("off", {"relocalisation": "false", "lost_inlier_drop": 0})
    lc_off = config("loop-off", {"loop_closure": "false"})
    ef_assoc = config("active-only", {"associate_active_only": "true"})
    # The same, trajectory.txt as tracked (no pose history to correct): what the closures' pose
    # correction changes.
    ef_tracked = config("active-only-tracked", {"associate_active_only": "true", "pose_history": 0})
    ef_off = config("active-only-off", {"associate_active_only": "true", "loop_closure": "false"})

    def mapped(name, uri, *extra):
        out = os.path.join(work, name)
        run([E, "run", "--source", uri, "--no-labels", "--quiet", "--overwrite", "--checkpoint-seconds", "0",
             "--out", out, *extra])
        ref = os.path.join(work, "ref-" + name)
        if not os.path.isfile(os.path.join(ref, "groundtruth.txt")):
            run([E, "convert", "--source", uri, "--to", "tum:" + ref, "--resolution", "80x60", "--quiet"])
        s = stats(out)
        traj = os.path.join(out, "trajectory.txt")
        c = s["counters"]
        return {"dir": out, "traj": traj, "gt": os.path.join(ref, "groundtruth.txt"), "stats": s,
                "ate": ate(E, os.path.join(ref, "groundtruth.txt"), traj)["ate_rmse_m"] * 100,
                "lost": c["lost_frames"], "reloc": c.get("relocalisations", 0),
                "keyframes": c.get("keyframes", 0), "surfels": c.get("surfels_created", 0) - c.get("surfels_removed", 0)
                - c.get("surfels_evicted", 0),
                "loops": "%d / %d" % (c.get("loop_closures_local", 0) + c.get("loop_closures_global", 0),
                                      c.get("loop_closures_local_rejected", 0) + c.get("loop_closures_global_rejected", 0))}

    if a.scans:
        print("| scan | frames lost | relocalisations | loop closures accepted / rejected | surfels | ATE mm |")
        print("|---|---|---|---|---|---|")
        for scan in [f"random?seed={s}" for s in range(5001, 5007)] + ["living_room", "bedroom", "office", "kitchen",
                                                                          "library"]:
            r = mapped("scan-" + scan.replace("random?seed=", ""),
                       f"synthetic:{scan}{'&' if '?' in scan else '?'}trajectory=inspect&frames=1200&size=320x240")
            print(f"| {scan} | {r['lost']} | {r['reloc']} | {r['loops']} | {r['surfels']} | {10 * r['ate']:.1f} |",
                  flush=True)
        print(f"work folder: {work}")
        return 0

    kitchen = "7scenes:" + os.path.abspath(a.data)
    rows = []
    full = mapped("uninterrupted", kitchen)
    rows.append(("uninterrupted", "real", full, ""))
    rows.append(("loop closure off", "real", mapped("loop-off", kitchen, "--config", lc_off), ""))
    rows.append(("ElasticFusion's association", "real", mapped("active-only", kitchen, "--config", ef_assoc),
                 "trajectory.txt with the poses the closures corrected"))
    rows.append(("ElasticFusion's association, poses as tracked", "real",
                 mapped("active-only-tracked", kitchen, "--config", ef_tracked), "mapping.pose_history 0"))

    gap_t = 550 / 30.0  # 7-Scenes stamps are index / 30 s
    def after_gap(r, name):
        est, gt = os.path.join(work, name + "-after.txt"), os.path.join(work, name + "-after-gt.txt")
        cut_trajectory(r["traj"], est, gap_t)
        cut_trajectory(full["gt"], gt, gap_t)
        return ate(E, gt, est)["ate_rmse_m"] * 100
    full_after = after_gap(full, "uninterrupted")
    for name, extra in (("kidnap", ()), ("kidnap-off", ("--config", off))):
        r = mapped(name, kitchen + "?cut=400-549", *extra)
        lines = comments(r["traj"], "relocalised")
        first = lines[0] if lines else "never"
        r_after = after_gap(r, name)
        rows.append((name, "real", r, f"ATE after the gap {r_after:.2f} cm (uninterrupted {full_after:.2f}); "
                                      f"{first}"))

    lens = mapped("covered-lens", kitchen + "?blank=500+30")
    created = []
    for n in (500, 530):
        out = os.path.join(work, f"lens-{n}")
        run([E, "run", "--source", kitchen + "?blank=500+30", "--no-labels", "--quiet", "--overwrite",
             "--checkpoint-seconds", "0", "--frames", str(n), "--out", out])
        created.append(stats(out)["counters"]["surfels_created"])
    lines = comments(lens["traj"], "relocalised")
    rows.append(("covered lens", "real", lens, f"surfels created during the loss: {created[1] - created[0]}; "
                                                f"{lines[0] if lines else 'never resumed'}"))
    for cap in (100000, 20000):
        r = mapped(f"pool-{cap}", kitchen, "--surfel-capacity", str(cap))
        c = r["stats"]["counters"]
        rows.append((f"pool {cap}", "real", r, f"evicted {c['surfels_evicted']}, refused {c['surfels_refused']}"))

    s7 = "synthetic:random?seed=7&trajectory=inspect&camera=kinect"
    for name, extra in (("seed 7 inspect", ()), ("seed 7 inspect, off", ("--config", off))):
        r = mapped(name.replace(" ", "-").replace(",", ""), s7, *extra)
        rows.append((name, "synthetic", r, ""))

    lap = "synthetic:?frames=2000&size=320x240"
    rows.append(("2000-frame loop", "synthetic", mapped("lap", lap), ""))
    rows.append(("2000-frame loop, ElasticFusion's association", "synthetic",
                 mapped("lap-active-only", lap, "--config", ef_assoc), ""))

    # Injected drift: depth bent by 1% towards the corners (synthetic depth_bias), two laps.
    drift = "synthetic:?frames=2000&size=320x240&depth_bias=0.01"
    for name, extra, note in (
            ("drifting loop", (), "default association: revisits fuse into the old surface"),
            ("drifting loop, loop closure off", ("--config", lc_off), ""),
            ("drifting loop, ElasticFusion's association", ("--config", ef_assoc), "poses corrected by the closures"),
            ("drifting loop, ElasticFusion's association, poses as tracked", ("--config", ef_tracked),
             "mapping.pose_history 0"),
            ("drifting loop, ElasticFusion's association, loop closure off", ("--config", ef_off), "")):
        rows.append((name, "synthetic", mapped("drift-" + name.replace(",", "").replace("'", "").replace(" ", "-"),
                                                drift, *extra), note))

    print("| run | data | frames lost | relocalisations | keyframes | loop closures accepted / rejected | surfels | ATE cm | notes |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, world, r, note in rows:
        print(f"| {name} | {world} | {r['lost']} | {r['reloc']} | {r['keyframes']} | {r['loops']} | {r['surfels']} | "
              f"{r['ate']:.2f} | {note} |")
    km, kp = stage(full["stats"], "keyframe")
    rm, rp = stage([r for n, _, r, _ in rows if n == "kidnap"][0]["stats"], "relocalise")
    lm, lp = stage(full["stats"], "loop_check")
    st = full["stats"]["stages"].get("loop_check", {})
    per_frame = st.get("mean_ms", 0) * st.get("count", 0) / max(1, full["stats"]["counters"]["frames"])
    am, ap = stage([r for n, _, r, _ in rows if n == "ElasticFusion's association"][0]["stats"], "loop_check")
    print(f"\nCost (uninterrupted run): `keyframe` (every tracked frame) median {km:.3f} ms, p95 {kp:.3f} ms; "
          f"`loop_check` (every 10th fused frame) median {lm:.2f} ms, p95 {lp:.2f} ms, {per_frame:.2f} ms per frame on "
          f"average; with ElasticFusion's association (closures made) median {am:.2f} ms, p95 {ap:.2f} ms; "
          f"`relocalise` (kidnap run, lost and resuming frames): median {rm:.2f} ms, p95 {rp:.2f} ms")
    print(f"work folder: {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
