"""Distils the real-camera network (the teacher, DeepLabv3-MobileNetV2 imported from TFLite) into
EdgeSegNet, the small RGB-D network (the student), on real recordings: issue 28's item 8.

    /usr/bin/python3 -m edgefusion_models.distill --edgefusion build/release/firmware_app/edgefusion \\
        --teacher models/deeplabv3-mnv2-nyu13.efm --source 7scenes:../shared/data/7scenes-redkitchen \\
        --holdout-from 700 --out /tmp/student/student.pt

What it does:
  1. The recording's frames at the student's input size (`edgefusion convert --resolution 160x120`,
     the runtime's own resampling) and the teacher's 14 NYU class probabilities for every frame
     (`edgefusion segment --probabilities` with the teacher, which resamples the full frames to its
     own input size): the pseudo-labels, at the teacher's output grid (stride 4).
  2. Training: the student starts from the shipped EdgeSegNet (--init, trained on the synthetic
     rooms); each batch is half real frames, whose loss is the cross entropy against the teacher's
     probabilities (resampled bilinearly to the student's output grid), and half synthetic frames of
     the shipped model's training split, whose loss is the shipped model's (class-weighted cross
     entropy against their ground truth), so that the student keeps what the rooms taught it.
     Lighting and flip augmentation on both. Frames from --holdout-from on are never trained on.
  3. After every epoch: the float student's argmax agreement with the teacher on the held-out
     frames (printed; the last epoch is kept: the held-out frames choose nothing).
The int8 export (export.py) and the int8 agreement (`--evaluate`) are separate steps
(models/distill.sh runs all of them).

Training elsewhere (a GPU machine without the binary or ../shared): `--pack FILE` writes the
prepared data to one file (write_pack says what it keeps exactly and what it rounds), `--from-pack
FILE --device cuda` trains from it, and models/distill_sweep.sh trains several students at once from
one pack. `--width` makes a wider student from random weights (net.EdgeSegNet), `--max-zoom` adds
scale augmentation, `--time-budget-s` shortens a run whose first epoch shows it would not fit.

    /usr/bin/python3 -m edgefusion_models.distill --evaluate --edgefusion BIN --teacher T.efm \\
        --student S.efm [--baseline B.efm] --source URI --holdout-from 700 [--json OUT]

compares the int8 models through the C++ runtime (`edgefusion segment --probabilities`) on the
held-out frames: argmax agreement with the teacher at the student's output grid (the teacher's
probabilities resampled bilinearly to it), over all pixels and per class of the teacher.

Deterministic for a given --seed and thread count on one machine.
"""
import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
import zipfile

import numpy as np

from .net import INPUT_HEIGHT, INPUT_WIDTH, NUM_CLASSES, CLASS_NAMES

# ----------------------------------------------------------------------------------------------
# Data


def run_tool(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()}")
    return r.stdout


def convert_frames(binary, source, folder, width=INPUT_WIDTH, height=INPUT_HEIGHT, frames=None):
    """The source's frames as a TUM folder at width x height (skipped when already there)."""
    if not os.path.exists(os.path.join(folder, "done")):
        cmd = [binary, "convert", "--source", source, "--resolution", f"{width}x{height}", "--to", "tum:" + folder,
               "--quiet"]
        if frames:
            cmd += ["--frames", str(frames)]
        run_tool(cmd)
        open(os.path.join(folder, "done"), "w").close()
    from .calibration import load_tum
    raw = load_tum(folder)  # N x H x W x 4: R, G, B, depth in metres
    return raw[..., :3].round().astype(np.uint8), raw[..., 3].astype(np.float32)


def segment_probabilities(binary, model, source, folder, frames=None):
    """N x H' x W' x classes float32: the model's probabilities for every frame of the source, at
    its output size (cached in folder)."""
    cache = os.path.join(folder, "probabilities.npy")
    if os.path.exists(cache):
        return np.load(cache)
    cmd = [binary, "segment", "--model", model, "--source", source, "--out", folder, "--probabilities", "--quiet",
           "--threads", "1"]
    if frames:
        cmd += ["--frames", str(frames)]
    run_tool(cmd)
    files = sorted(glob.glob(os.path.join(folder, "probabilities", "*.npy")))
    if not files:
        raise RuntimeError(f"{' '.join(cmd)}: wrote no probabilities")
    p = np.stack([np.load(f) for f in files]).astype(np.float32)
    np.save(cache, p)
    return p


def resample_probabilities(p, height, width):
    """N x h x w x C probabilities -> N x height x width x C by bilinear interpolation with
    half-pixel centres (a convex combination per pixel: the sums stay 1)."""
    import torch
    import torch.nn.functional as F
    t = torch.from_numpy(np.ascontiguousarray(p.transpose(0, 3, 1, 2)))
    r = F.interpolate(t, size=(height, width), mode="bilinear", align_corners=False)
    return r.numpy().transpose(0, 2, 3, 1)


def split_indices(count, holdout_from):
    """Training frames [0, holdout_from) and held-out frames [holdout_from, count)."""
    if not 0 < holdout_from < count:
        raise ValueError(f"--holdout-from {holdout_from}: needs 0 < N < {count} (the recording's frames)")
    return np.arange(holdout_from), np.arange(holdout_from, count)


def agreement(student_probs, teacher_probs):
    """(share of pixels whose argmax agrees, per teacher class: (pixels, agreeing)) with the teacher's
    probabilities resampled to the student's grid first."""
    n, h, w, _ = student_probs.shape
    t = resample_probabilities(teacher_probs, h, w) if teacher_probs.shape[1:3] != (h, w) else teacher_probs
    ts, ss = t.argmax(-1), student_probs.argmax(-1)
    agree = ts == ss
    per_class = {int(c): (int((ts == c).sum()), int(agree[ts == c].sum())) for c in range(t.shape[-1])}
    return float(agree.mean()), per_class


# ----------------------------------------------------------------------------------------------
# A data pack: the prepared frames in one file, to train where the edgefusion binary is not at hand
# (a lent GPU machine): `--pack FILE` writes it, `--from-pack FILE` trains from it.


PACK_SYNTHETIC_STRIDE = 14  # one frame of each of the 360 synthetic rooms (train split: 14 frames a room)


def _encode_images(rgb):
    import cv2
    blobs = [cv2.imencode(".webp", np.ascontiguousarray(f[..., ::-1]), [cv2.IMWRITE_WEBP_QUALITY, 101])[1]
             for f in rgb]  # quality above 100: lossless
    return np.concatenate(blobs), np.cumsum([0] + [len(b) for b in blobs]).astype(np.int64)


def _decode_images(blob, offsets):
    import cv2
    out = []
    for i in range(len(offsets) - 1):
        image = cv2.imdecode(blob[offsets[i]:offsets[i + 1]], cv2.IMREAD_COLOR)
        if image is None:
            raise ValueError(f"image {i} of the pack does not decode")
        out.append(image[..., ::-1])
    return np.stack(out)


def _depth_planes(depth):
    """Depth in metres -> whole centimetres as two byte planes (low, high): deflate packs them
    better than interleaved 16-bit values."""
    cm = np.round(depth * 100).astype(np.uint16)
    return np.stack([(cm & 255).astype(np.uint8), (cm >> 8).astype(np.uint8)])


def _depth_from_planes(planes):
    return (planes[0].astype(np.float32) + 256 * planes[1].astype(np.float32)) / 100


PACK_KEYS = ("rgb", "rgb_offsets", "depth_cm", "teacher", "synth_rgb", "synth_rgb_offsets", "synth_depth_cm",
             "synth_labels")


def write_pack(path, rgb, depth, teacher, synth):
    """One compressed file of what training reads: colour exact (lossless WebP), depth in whole
    centimetres (the int8 input's depth step is 3/127 m = 2.4 cm, so the student cannot see finer),
    the teacher's probabilities in steps of 1/255 (renormalised on reading), every
    PACK_SYNTHETIC_STRIDE-th synthetic frame with its labels."""
    s_rgb, s_depth, s_lab = (a[::PACK_SYNTHETIC_STRIDE] for a in synth)
    r_blob, r_off = _encode_images(rgb)
    s_blob, s_off = _encode_images(s_rgb)
    np.savez_compressed(path, rgb=r_blob, rgb_offsets=r_off, depth_cm=_depth_planes(depth),
                        teacher=np.round(teacher.transpose(3, 0, 1, 2) * 255).astype(np.uint8),  # planar: smaller
                        synth_rgb=s_blob, synth_rgb_offsets=s_off,
                        synth_depth_cm=_depth_planes(s_depth), synth_labels=s_lab)


def read_pack(path):
    """(rgb, depth in metres, teacher probabilities N x h x w x C, (synthetic rgb, depth, labels))."""
    try:
        z = np.load(path)
        missing = [k for k in PACK_KEYS if k not in z.files]
    except (OSError, ValueError, zipfile.BadZipFile) as e:
        raise ValueError(f"{path}: not a readable data pack ({e})") from e
    if missing:
        raise ValueError(f"{path}: not a data pack of distill.py --pack (no {', '.join(missing)})")
    try:
        rgb = _decode_images(z["rgb"], z["rgb_offsets"])
        s_rgb = _decode_images(z["synth_rgb"], z["synth_rgb_offsets"])
    except (ValueError, IndexError, TypeError) as e:
        raise ValueError(f"{path}: a damaged data pack ({e})") from e
    teacher = z["teacher"].transpose(1, 2, 3, 0).astype(np.float32)
    teacher /= np.maximum(teacher.sum(-1, keepdims=True), 1.0)
    return (rgb, _depth_from_planes(z["depth_cm"]), teacher,
            (s_rgb, _depth_from_planes(z["synth_depth_cm"]), z["synth_labels"]))


def zoom(x, target, rng, max_zoom, nearest_channels=(), nearest_target=False):
    """Scale augmentation: each frame magnified by a random factor in [1, max_zoom] about a random
    point that keeps the view inside the frame (a crop resampled to the full size), its targets with
    it. x: N x C x H x W; target: N x K x H x W (probabilities) or N x H x W (class ids, nearest).
    Channels in nearest_channels (depth) are resampled by nearest neighbour, not blended across edges."""
    import torch
    import torch.nn.functional as F
    n = x.shape[0]
    s = 1.0 / rng.uniform(1.0, max_zoom, n)  # the crop's size as a share of the frame
    cx, cy = ((1 - s) * rng.uniform(-1, 1, n), (1 - s) * rng.uniform(-1, 1, n))
    theta = np.zeros((n, 2, 3), np.float32)
    theta[:, 0, 0], theta[:, 1, 1], theta[:, 0, 2], theta[:, 1, 2] = s, s, cx, cy
    grid = F.affine_grid(torch.from_numpy(theta).to(x.device), list(x.shape), align_corners=False)
    out = F.grid_sample(x, grid, mode="bilinear", padding_mode="border", align_corners=False)
    if nearest_channels:
        keep = list(nearest_channels)
        out[:, keep] = F.grid_sample(x[:, keep], grid, mode="nearest", padding_mode="border", align_corners=False)
    if nearest_target:
        t = F.grid_sample(target[:, None].float(), grid, mode="nearest", padding_mode="border",
                          align_corners=False)[:, 0].long()
    else:
        t = F.grid_sample(target, grid, mode="bilinear", padding_mode="border", align_corners=False)
    return out, t


# ----------------------------------------------------------------------------------------------
# Training


def soft_cross_entropy(logits, target):
    """Mean over pixels of -sum_c target_c log softmax(logits)_c (N x C x H x W both): the cross
    entropy against the teacher's distribution (its KL divergence up to the teacher's entropy)."""
    import torch.nn.functional as F
    return -(target * F.log_softmax(logits, dim=1)).sum(1).mean()


def predict(model, rgb, depth, batch=32, device="cpu"):
    """Float softmax probabilities N x H x W x C."""
    import torch
    from .train import to_input
    model.eval()
    out = []
    with torch.no_grad():
        for i in range(0, rgb.shape[0], batch):
            x = to_input(rgb[i:i + batch], depth[i:i + batch]).to(device)
            out.append(torch.softmax(model(x), 1).cpu().numpy())
    return np.concatenate(out).transpose(0, 2, 3, 1)


def prepare(args):
    """The recording's frames at the student's size, the teacher's probabilities for each and the
    synthetic rooms, made with the edgefusion binary (cached in --work-dir)."""
    from . import dataset
    work = args.work_dir
    os.makedirs(work, exist_ok=True)
    rgb, depth = convert_frames(args.edgefusion, args.source, os.path.join(work, "frames"), frames=args.frames)
    teacher = segment_probabilities(args.edgefusion, args.teacher, args.source, os.path.join(work, "teacher"),
                                    frames=args.frames)
    if teacher.shape[0] != rgb.shape[0]:
        raise RuntimeError(f"{rgb.shape[0]} frames but {teacher.shape[0]} teacher outputs")
    if teacher.shape[-1] != NUM_CLASSES:
        raise RuntimeError(f"the teacher gives {teacher.shape[-1]} classes; the student has {NUM_CLASSES}")
    return rgb, depth, teacher, dataset.build_split(args.edgefusion, "train", args.synthetic_dir)


def train(args):
    import torch
    import torch.nn.functional as F
    from .export import load_checkpoint
    from .net import EdgeSegNet, count_macs
    from .train import augment, class_weights, to_input

    t_start = time.time()
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    rng = np.random.default_rng(args.seed)
    device = torch.device(("cuda" if torch.cuda.is_available() else "cpu") if args.device == "auto" else args.device)
    if args.from_pack:
        rgb, depth, teacher, synth = read_pack(args.from_pack)
    else:
        rgb, depth, teacher, synth = prepare(args)
    if args.pack:
        write_pack(args.pack, rgb, depth, teacher, synth)
        print(f"pack: {args.pack}, {os.path.getsize(args.pack) / 1e6:.1f} MB ({time.time() - t_start:.0f} s)")
        return
    train_idx, held_idx = split_indices(rgb.shape[0], args.holdout_from)
    print(f"data: {len(train_idx)} real training frames, {len(held_idx)} held out (from frame {args.holdout_from}), "
          f"{synth[0].shape[0]} synthetic frames; teacher outputs {teacher.shape[1]}x{teacher.shape[2]} "
          f"({time.time() - t_start:.0f} s)", flush=True)

    model = load_checkpoint(args.init) if args.init else EdgeSegNet(width=args.width)
    print(f"student: EdgeSegNet width {model.width:g}, {count_macs(model.cpu()) / 1e6:.1f} MMAC, from "
          f"{args.init or 'random weights'}, on {device}", flush=True)
    model.to(device)
    weights = class_weights(synth[2]).to(device)
    held_teacher = teacher[held_idx]

    def held_agreement():
        a, _ = agreement(predict(model, rgb[held_idx], depth[held_idx], device=device), held_teacher)
        return a

    start = held_agreement()
    print(f"before: float student agrees with the teacher on {100 * start:.2f}% of held-out pixels", flush=True)
    half = args.batch // 2
    steps_per_epoch = len(train_idx) // half
    epochs = args.epochs
    opt = torch.optim.AdamW(model.parameters(), lr=args.lr, weight_decay=args.weight_decay)

    def schedule(total_epochs, done_steps=0):
        sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=args.lr, total_steps=total_epochs * steps_per_epoch,
                                                    pct_start=0.1)
        with warnings.catch_warnings():  # stepping a fresh schedule forward is intended here
            warnings.simplefilter("ignore", UserWarning)
            for _ in range(done_steps):  # resume the new schedule where the old one was
                sched.step()
        return sched

    sched = schedule(epochs)
    history = [{"epoch": 0, "held_out_agreement": start}]
    epoch = 0
    while epoch < epochs:
        model.train()
        t0 = time.time()
        order = rng.permutation(train_idx)
        real_loss = synth_loss = 0.0
        for b in range(steps_per_epoch):
            sel = np.sort(order[b * half:(b + 1) * half])
            r_rgb, r_depth, r_p = augment(rgb[sel], depth[sel], teacher[sel], rng)  # flips the targets too
            s_sel = np.sort(rng.choice(synth[0].shape[0], half, replace=False))
            s_rgb, s_depth, s_lab = augment(synth[0][s_sel], synth[1][s_sel], synth[2][s_sel], rng)
            target = F.interpolate(torch.from_numpy(np.ascontiguousarray(r_p.transpose(0, 3, 1, 2))).to(device),
                                   size=(INPUT_HEIGHT, INPUT_WIDTH), mode="bilinear", align_corners=False)
            r_x, s_x = to_input(r_rgb, r_depth).to(device), to_input(s_rgb, s_depth).to(device)
            s_t = torch.from_numpy(s_lab.astype(np.int64)).to(device)
            if args.max_zoom > 1.0:
                r_x, target = zoom(r_x, target, rng, args.max_zoom, nearest_channels=(3,))
                s_x, s_t = zoom(s_x, s_t, rng, args.max_zoom, nearest_channels=(3,), nearest_target=True)
            lr_ = soft_cross_entropy(model(r_x), target)
            ls_ = F.cross_entropy(model(s_x), s_t, weight=weights, ignore_index=0)
            loss = lr_ + args.synthetic_weight * ls_
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            real_loss += lr_.item()
            synth_loss += ls_.item()
        epoch += 1
        a = held_agreement()
        history.append({"epoch": epoch, "real_loss": real_loss / steps_per_epoch,
                        "synthetic_loss": synth_loss / steps_per_epoch, "held_out_agreement": a})
        print(f"epoch {epoch}/{epochs}: real loss {history[-1]['real_loss']:.4f}  synthetic loss "
              f"{history[-1]['synthetic_loss']:.4f}  held-out agreement {100 * a:.2f}%  ({time.time() - t0:.0f} s)",
              flush=True)
        if epoch == 1 and args.time_budget_s:
            # Fit the run into the budget: fewer epochs from the first epoch's time, the learning-rate
            # schedule redrawn over the new length (the first epoch was warm-up either way).
            fit = max(2, int(args.time_budget_s / max(time.time() - t0, 1e-3)))
            if fit < epochs:
                print(f"time budget {args.time_budget_s:.0f} s: {fit} epochs instead of {epochs}", flush=True)
                epochs = fit
                sched = schedule(epochs, steps_per_epoch)
    args.epochs_run = epochs
    model.cpu()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    torch.save({"model": model.state_dict(), "epoch": epochs, "args": vars(args)}, args.out)
    # Calibration frames for the int8 export: real training frames and synthetic ones, as export.py reads them.
    cal = np.sort(rng.choice(train_idx, min(64, len(train_idx)), replace=False))
    cal_s = np.sort(rng.choice(synth[0].shape[0], min(64, synth[0].shape[0]), replace=False))
    np.savez_compressed(os.path.splitext(args.out)[0] + "_calibration.npz",
                        rgb=np.concatenate([rgb[cal], synth[0][cal_s]]),
                        depth=np.concatenate([depth[cal], synth[1][cal_s]]),
                        labels=np.concatenate([np.zeros((len(cal), INPUT_HEIGHT, INPUT_WIDTH), np.uint8),
                                               synth[2][cal_s]]))
    run_s = time.time() - t_start
    print(f"done: held-out agreement {100 * start:.2f}% -> {100 * history[-1]['held_out_agreement']:.2f}% "
          f"(float); {run_s / 60:.1f} min with {args.threads} threads", flush=True)
    with open(os.path.splitext(args.out)[0] + "_history.json", "w") as f:
        json.dump({"history": history, "run_time_s": run_s, "threads": args.threads, "args": vars(args)}, f, indent=1)


# ----------------------------------------------------------------------------------------------
# int8 evaluation


def evaluate(args):
    work = args.work_dir
    os.makedirs(work, exist_ok=True)
    teacher = segment_probabilities(args.edgefusion, args.teacher, args.source, os.path.join(work, "teacher"),
                                    frames=args.frames)
    _, held_idx = split_indices(teacher.shape[0], args.holdout_from)
    res = {"source": args.source, "holdout_from": args.holdout_from, "held_out_frames": int(len(held_idx))}
    for key, model in (("student", args.student), ("baseline", args.baseline)):
        if not model:
            continue
        with tempfile.TemporaryDirectory(prefix="ef_distill_") as tmp:
            p = segment_probabilities(args.edgefusion, model, args.source, tmp, frames=args.frames)
        a, per_class = agreement(p[held_idx], teacher[held_idx])
        res[key] = {"model": os.path.basename(model), "agreement": a,
                    "per_teacher_class": {CLASS_NAMES[c]: {"pixels": n, "agreement": (k / n if n else None)}
                                          for c, (n, k) in per_class.items()}}
        print(f"{os.path.basename(model)}: argmax agreement with {os.path.basename(args.teacher)} on the "
              f"{len(held_idx)} held-out frames: {100 * a:.2f}% of pixels", flush=True)
        for c, (n, k) in per_class.items():
            if n:
                print(f"  {CLASS_NAMES[c]:10s} {100 * n / p[held_idx].shape[0] / p.shape[1] / p.shape[2]:5.1f}% of "
                      f"pixels, {100 * k / n:5.1f}% agree", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m edgefusion_models.distill", description=__doc__.split("\n")[0])
    ap.add_argument("--edgefusion", help="the edgefusion binary (convert, segment); not needed with --from-pack")
    ap.add_argument("--teacher", help="the teacher's int8 model (.efm), 14 NYU classes out")
    ap.add_argument("--source", help="the real recording (EdgeFusion source URI)")
    ap.add_argument("--holdout-from", type=int, required=True, help="frames from this one on are never trained on")
    ap.add_argument("--frames", type=int, help="read at most N frames of the source")
    ap.add_argument("--work-dir", default="/tmp/edgefusion-distill", help="converted frames and teacher outputs")
    ap.add_argument("--evaluate", action="store_true", help="compare int8 models instead of training")
    ap.add_argument("--student", help="--evaluate: the student's int8 model")
    ap.add_argument("--baseline", help="--evaluate: another model to compare (e.g. the shipped EdgeSegNet)")
    ap.add_argument("--json", help="--evaluate: also write the figures here")
    ap.add_argument("--out", help="training: the student's checkpoint (.pt)")
    ap.add_argument("--init", default="models/checkpoints/edgesegnet.pt", help="training: starting weights ('' = random)")
    ap.add_argument("--synthetic-dir", default="/tmp/edgefusion-data", help="training: the synthetic rooms (train.py's)")
    ap.add_argument("--synthetic-weight", type=float, default=0.5, help="training: weight of the synthetic frames' loss")
    ap.add_argument("--epochs", type=int, default=12)
    ap.add_argument("--batch", type=int, default=16, help="half real, half synthetic frames")
    ap.add_argument("--lr", type=float, default=1e-3, help="peak learning rate (AdamW, one-cycle)")
    ap.add_argument("--weight-decay", type=float, default=1e-4)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--width", type=float, default=1.0,
                    help="training with --init '': the student's channel multiplier (net.EdgeSegNet; 1 = shipped)")
    ap.add_argument("--device", default="cpu",
                    help="training: torch device ('cuda' on a GPU machine; 'auto': cuda where torch sees one)")
    ap.add_argument("--max-zoom", type=float, default=1.0,
                    help="training: scale augmentation, frames magnified up to this factor (1 = off)")
    ap.add_argument("--time-budget-s", type=float,
                    help="training: fewer epochs if the first one shows the run would take longer")
    ap.add_argument("--pack", help="write the prepared data (frames, teacher outputs, synthetic rooms) to this "
                                   "file and stop")
    ap.add_argument("--from-pack", help="training: read the data from a --pack file instead of the binary")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if args.evaluate:
        if not (args.edgefusion and args.teacher and args.source):
            ap.error("--evaluate needs --edgefusion, --teacher and --source")
        if not args.student and not args.baseline:
            ap.error("--evaluate needs --student and/or --baseline")
        evaluate(args)
    else:
        if not args.out and not args.pack:
            ap.error("training needs --out")
        if not args.from_pack and not (args.edgefusion and args.teacher and args.source):
            ap.error("--edgefusion, --teacher and --source are needed unless --from-pack")
        if args.init and args.width != 1.0:
            ap.error("--width applies to a student from random weights (--init '')")
        if not args.width > 0 or not args.max_zoom >= 1.0:
            ap.error("--width must be > 0 and --max-zoom >= 1")
        train(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
