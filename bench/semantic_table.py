#!/usr/bin/env python3
"""The SemanticFusion Table I on held-out synthetic loopy sequences: single-frame CNN, the fused map
(SF) and the fused map with the dense CRF (SF-CRF), per class, class average, pixel average and mIoU.

Every number comes from the `edgefusion` program:
  convert   synthetic:random?seed=S&trajectory=loop&frames=N at 320x240 (--resolution) -> a TUM folder with labels/
  segment   the single-frame CNN on every K-th frame                       -> CNN/labels/<stem>.png
  run       the mapper, CNN fused every --label-every frames, the map's labels rendered into every
            K-th frame with the CNN as fallback ("captured immediately", as the paper)  -> SF/
  run       the same with --crf-every M and --crf-final                    -> SF-CRF/
            both runs also with --labels-final-out: after the run, the final map rendered into the
            same frames at the estimated poses ("SF end", "SF-CRF end": the map's final state,
            which has also seen the views after each frame; for SF-CRF after the final CRF)
  eval labels GT EST --every K --depth DIR   for each of the five

Seeds must be ones training never used (models/edgefusion_models/dataset.py: train 1..360,
validation 9001..9012, test 7001..7024). Default 5001 5002 5003, 1200 frames each (over one lap of
the room's loop, so the end of each sequence revisits its start). --rooms takes the built-in rooms
instead (synthetic:ROOM, e.g. living_room bedroom office kitchen library: fixed layouts that training,
which only drew random rooms, never used); --trajectory robot the planar robot path instead of the
hand-held loop, --trajectory inspect the inspecting scan (the loop's path, the gaze turning to the
near wall and back). --model runs another segmentation model (.efm) in place of the shipped synthetic-room
one (EdgeSegNet, models/edgefusion-seg.efm), for the CNN row and both runs (the work folder's outputs are then that model's: use a folder per model).
--camera kinect renders the sequences through the synthetic source's Kinect-like colour camera
(camera=kinect: motion blur, vignetting, auto-exposure and white balance, shot noise), directly at
320x240 (size=320x240: five renders per frame at 640x480 would take four times as long); use it with
a model trained on that camera (python3 -m edgefusion_models.train --camera kinect).

  /usr/bin/python3 bench/semantic_table.py --edgefusion build/release/firmware_app/edgefusion \\
      --work /tmp/semantic-table [--seeds 5001 5002 5003 | --rooms ROOM...] [--trajectory loop|robot|inspect] \\
      [--frames 1200] [--every 10] [--crf-every 500] [--model FILE.efm] [--camera ideal|kinect] [--resolution WxH]
Prints a Markdown table (per sequence and the mean of the sequences).
"""
import argparse
import os
import subprocess
import sys

CLASSES = ["bed", "books", "ceiling", "chair", "floor", "furniture", "objects", "painting", "sofa", "table",
           "tv", "wall", "window"]
HELD_OUT_FORBIDDEN = set(range(1, 361)) | set(range(9001, 9013)) | set(range(7001, 7025))


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"semantic_table: command failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    return r.stdout


def evaluate(ef, gt, est, every):
    out = run([ef, "eval", "labels", os.path.join(gt, "labels"), est, "--every", str(every),
               "--depth", os.path.join(gt, "depth")])
    values = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2:
            try:
                values[parts[0]] = float(parts[1])
            except ValueError:
                pass
    return values


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--edgefusion", required=True)
    ap.add_argument("--work", required=True, help="folder for the sequences and outputs (reused when present)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[5001, 5002, 5003])
    ap.add_argument("--rooms", nargs="+", default=[],
                    help="built-in rooms (synthetic:ROOM) to render instead of random seeds")
    ap.add_argument("--trajectory", choices=["loop", "robot", "inspect"], default="loop",
                    help="camera path of the rendered sequences (default the hand-held loop)")
    ap.add_argument("--frames", type=int, default=1200)
    ap.add_argument("--resolution", default="320x240",
                    help="the sequences' size and the runs' working resolution (e.g. 160x120 for the smallest boards)")
    ap.add_argument("--every", type=int, default=10, help="evaluate every K-th frame (and fuse every K-th)")
    ap.add_argument("--crf-every", type=int, default=500, help="SF-CRF: CRF every M frames (paper: 500)")
    ap.add_argument("--run-config", default="",
                    help="configuration file given to every `edgefusion run` (e.g. mapping.index_map_scale)")
    ap.add_argument("--sequences", nargs="*", default=[],
                    help="existing TUM folders with labels/ to use instead of rendering seeds")
    ap.add_argument("--model", default="",
                    help="segmentation model (.efm) for the CNN and both runs; default the shipped synthetic-room "
                         "model models/edgefusion-seg.efm (the sequences are converted to tum: folders, which "
                         "`run` would otherwise treat as real recordings and give the real-camera model)")
    ap.add_argument("--camera", choices=["ideal", "kinect"], default="ideal",
                    help="colour camera of the rendered sequences (the synthetic source's camera=)")
    ap.add_argument("--layout", choices=["walls", "island"], default="walls",
                    help="room layout of the rendered sequences (the synthetic source's layout=; island: "
                         "furniture in the middle too)")
    args = ap.parse_args()
    ef = args.edgefusion
    run_config = ["--config", args.run_config] if args.run_config else []
    model = ["--model", args.model or os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                                   "models", "edgefusion-seg.efm")]
    for s in args.seeds:
        if s in HELD_OUT_FORBIDDEN:
            sys.exit(f"semantic_table: seed {s} was used in training, validation or the model's test set")
    os.makedirs(args.work, exist_ok=True)

    if args.sequences and (args.camera != "ideal" or args.layout != "walls"):
        sys.exit("semantic_table: --camera and --layout render the sequences; --sequences are already rendered (drop one)")
    sequences = list(args.sequences)
    if not sequences:
        suffix = "" if args.trajectory == "loop" else "-" + args.trajectory
        suffix += "" if args.resolution == "320x240" else "-" + args.resolution
        camera = "" if args.camera == "ideal" else f"&size={args.resolution}&camera=" + args.camera
        suffix += "" if args.camera == "ideal" else "-" + args.camera
        camera += "" if args.layout == "walls" else "&layout=" + args.layout
        suffix += "" if args.layout == "walls" else "-" + args.layout
        if args.rooms:
            jobs = [(room + suffix, f"synthetic:{room}?trajectory={args.trajectory}&frames={args.frames}{camera}")
                    for room in args.rooms]
        else:
            jobs = [(f"seed{s}{suffix}", f"synthetic:random?seed={s}&trajectory={args.trajectory}&frames={args.frames}{camera}")
                    for s in args.seeds]
        for name, uri in jobs:
            folder = os.path.join(args.work, name)
            if not os.path.exists(os.path.join(folder, "done")):
                print(f"rendering {uri}", file=sys.stderr)
                run([ef, "convert", "--source", uri, "--resolution", args.resolution, "--to", "tum:" + folder, "--quiet"])
                open(os.path.join(folder, "done"), "w").close()
            sequences.append(folder)

    rows = []  # (sequence, method, metrics)
    for gt in sequences:
        name = os.path.basename(os.path.normpath(gt))
        out = os.path.join(args.work, "out-" + name)
        print(f"{name}: single-frame CNN", file=sys.stderr)
        run([ef, "segment", "--source", "tum:" + gt, "--out", os.path.join(out, "cnn"), "--every", str(args.every),
             "--quiet"] + model)
        rows.append((name, "CNN", evaluate(ef, gt, os.path.join(out, "cnn", "labels"), args.every)))
        # The CRF's lattices take 588 bytes per surfel of capacity (docs/architecture.md): above the
        # board's 256 MB with the default pool, fine on the laptop this table is made on.
        # --crf-final: the CRF once more when the run ends, so "SF-CRF end" is the finished map after
        # its last CRF (the rendered frames of "SF-CRF" all come before it and are not affected).
        crf = ["--crf-every", str(args.crf_every), "--crf-final", "--memory-budget-mb", "2000"]
        for method, extra in (("SF", []), ("SF-CRF", crf)):
            print(f"{name}: {method}", file=sys.stderr)
            d = os.path.join(out, method.lower())
            cmd = [ef, "run", "--source", "tum:" + gt, "--resolution", args.resolution, "--out", d,
                   "--label-every", str(args.every),
                   "--labels-out", os.path.join(d, "labels"), "--labels-out-every", str(args.every),
                   "--labels-final-out", os.path.join(d, "labels-end"), "--overwrite", "--quiet"] + run_config + model + extra
            # A run whose outputs exist from the same command line (and the same binary) is reused.
            marker = os.path.join(d, "done")
            key = " ".join(cmd) + f" [{os.path.getmtime(ef)}]"
            if os.path.exists(marker) and open(marker).read() == key:
                print("  (outputs of the same command reused)", file=sys.stderr)
            else:
                log = run(cmd)
                print("  " + " ".join(l for l in log.splitlines() if l.startswith("frames")), file=sys.stderr)
                with open(marker, "w") as f:
                    f.write(key)
            rows.append((name, method, evaluate(ef, gt, os.path.join(d, "labels"), args.every)))
            rows.append((name, method + " end", evaluate(ef, gt, os.path.join(d, "labels-end"), args.every)))

    methods = ["CNN", "SF", "SF-CRF", "SF end", "SF-CRF end"]
    names = [os.path.basename(os.path.normpath(g)) for g in sequences]
    header = "| sequence | method | " + " | ".join(CLASSES) + " | class avg | pixel avg | mIoU |"
    print(header)
    print("|" + "---|" * (len(CLASSES) + 5))

    def fmt(v):
        return "-" if v is None else f"{100 * v:.1f}"

    def line(seq, method, m):
        cells = [fmt(m.get("acc_" + c)) for c in CLASSES]
        return (f"| {seq} | {method} | " + " | ".join(cells) +
                f" | {fmt(m.get('class_avg'))} | {fmt(m.get('pixel_avg'))} | {fmt(m.get('miou'))} |")

    for seq in names:
        for method in methods:
            m = next(r[2] for r in rows if r[0] == seq and r[1] == method)
            print(line(seq, method, m))
    for method in methods:
        ms = [r[2] for r in rows if r[1] == method]
        mean = {}
        for key in set().union(*ms):
            vals = [m[key] for m in ms if key in m]
            mean[key] = sum(vals) / len(vals)
        print(line("mean", method, mean))
    cnn = [r[2]["class_avg"] for r in rows if r[1] == "CNN"]
    parts = [f"CNN {100 * sum(cnn) / len(cnn):.1f}"]
    for method in methods[1:]:
        v = [r[2]["class_avg"] for r in rows if r[1] == method]
        parts.append(f"{method} {100 * sum(v) / len(v):.1f} ({100 * (sum(v) - sum(cnn)) / len(cnn):+.1f})")
    print(f"\nclass average, mean of {len(cnn)} sequences: " + ", ".join(parts))


if __name__ == "__main__":
    main()
