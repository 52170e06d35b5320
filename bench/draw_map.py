#!/usr/bin/python3
"""Draw an EdgeFusion surfel map (map.ply) twice side by side: in its colours and in its labels.

  /usr/bin/python3 bench/draw_map.py MAP.ply --out PICTURE.png [--trajectory trajectory.txt]
      [--title TEXT] [--size 640x480] [--elevation 45] [--azimuth 0] [--min-confidence 10]

Everything is drawn here in numpy (no renderer): each surfel is a disc of its own radius splatted
into a perspective camera with a z-buffer, lit a little by its normal so the shapes read.
The viewpoint: "up" is the opposite of the cameras' mean image-down axis (from --trajectory, TUM
format, camera-to-world; without it the first camera's: -y), the view looks from the cameras'
side towards the map's centre, down by --elevation degrees, and the picture is framed on the
surfels (0.5..99.5 percentiles). Surfels below --min-confidence (default 10, the map's stable
threshold) are left out. The right panel uses the NYUv2 13-class palette of SemanticFusion
(src/core/classes.cpp), with a legend of the classes drawn and their share of the drawn surfels.
"""
import argparse
import os

import cv2
import numpy as np

# src/core/classes.cpp: names and the paper's palette (RGB); 0 = unknown (black).
CLASS_NAMES = ["unknown", "bed", "books", "ceiling", "chair", "floor", "furniture", "objects",
               "painting", "sofa", "table", "tv", "wall", "window"]
PALETTE = np.array([
    (0, 0, 0), (0, 128, 128), (250, 50, 50), (102, 0, 204), (50, 50, 250), (230, 230, 237),
    (255, 69, 20), (255, 20, 127), (50, 50, 150), (222, 180, 140), (50, 250, 50), (255, 215, 0),
    (150, 150, 150), (0, 255, 255)], np.uint8)
BACKGROUND = (48, 54, 66)  # RGB, not in the palette
PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "<i2", "ushort": "<u2", "int": "<i4", "uint": "<u4",
             "float": "<f4", "double": "<f8", "int8": "i1", "uint8": "u1", "int16": "<i2", "uint16": "<u2",
             "int32": "<i4", "uint32": "<u4", "float32": "<f4", "float64": "<f8"}


def read_ply(path):
    """Binary little-endian PLY with one 'vertex' element of scalar properties -> structured array."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline()
            if not line:
                raise ValueError(path + ": no end_header")
            line = line.decode("ascii").strip()
            header.append(line)
            if line == "end_header":
                break
        if "format binary_little_endian 1.0" not in header:
            raise ValueError(path + ": not binary little-endian")
        fields, count, in_vertex = [], 0, False
        for line in header:
            t = line.split()
            if t[0] == "element":
                in_vertex = t[1] == "vertex"
                if in_vertex:
                    count = int(t[2])
            elif t[0] == "property" and in_vertex:
                if t[1] == "list":
                    raise ValueError(path + ": list properties in vertex are not handled")
                fields.append((t[2], PLY_TYPES[t[1]]))
        return np.fromfile(f, np.dtype(fields), count=count)


def read_tum_poses(path):
    poses = []
    for line in open(path):
        v = line.split()
        if not v or v[0].startswith("#"):
            continue
        tx, ty, tz, qx, qy, qz, qw = (float(t) for t in v[1:8])
        n = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        x, y, z, w = qx / n, qy / n, qz / n, qw / n
        T = np.eye(4)
        T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        T[:3, 3] = (tx, ty, tz)
        poses.append(T)
    return poses


def unit(v):
    return v / max(np.linalg.norm(v), 1e-12)


def view_camera(points, poses, elevation_deg, azimuth_deg):
    """World-to-view rotation R (rows: right, down, forward) and eye position."""
    if poses:
        up = unit(-np.mean([T[:3, 1] for T in poses], axis=0))
        cam_mean = np.mean([T[:3, 3] for T in poses], axis=0)
        fwd_mean = np.mean([T[:3, 2] for T in poses], axis=0)
    else:
        up, cam_mean, fwd_mean = np.array([0.0, -1.0, 0.0]), np.zeros(3), np.array([0.0, 0.0, 1.0])
    centre = np.median(points, axis=0)
    h = centre - cam_mean
    h = h - up * (h @ up)
    if np.linalg.norm(h) < 0.2:  # cameras in the middle: look the way they looked on average
        h = fwd_mean - up * (fwd_mean @ up)
    h = unit(h)
    a = np.radians(azimuth_deg)
    h = unit(np.cos(a) * h + np.sin(a) * np.cross(up, h))
    e = np.radians(elevation_deg)
    fwd = unit(np.cos(e) * h - np.sin(e) * up)
    down = unit(-up - fwd * (-up @ fwd))  # image y: "up" projected into the image, downwards
    right = np.cross(down, fwd)  # x = y cross z for a camera looking along +z, y down
    R = np.stack([right, down, fwd])
    rel = points - centre
    extent = np.percentile(np.linalg.norm(rel, axis=1), 95)
    eye = centre - fwd * 2.2 * extent
    return R, eye


def splat(points, normals, radius, colours_list, R, eye, size, max_px=6):
    """Z-buffered disc splats; returns one HxWx3 float image per entry of colours_list and the mask."""
    W, H = size
    p = (points - eye) @ R.T
    front = p[:, 2] > 0.05
    p, normals, radius = p[front], normals[front], radius[front]
    colours_list = [c[front] for c in colours_list]
    x, y = p[:, 0] / p[:, 2], p[:, 1] / p[:, 2]
    lo_x, hi_x = np.percentile(x, [0.5, 99.5])
    lo_y, hi_y = np.percentile(y, [0.5, 99.5])
    f = 0.94 * min(W / (hi_x - lo_x), H / (hi_y - lo_y))
    u = (x - (lo_x + hi_x) / 2) * f + W / 2
    v = (y - (lo_y + hi_y) / 2) * f + H / 2
    r = np.clip(f * radius / p[:, 2], 0.6, max_px)
    ui, vi = np.rint(u).astype(np.int64), np.rint(v).astype(np.int64)
    pix, zs, idx = [], [], []
    R_ = int(np.ceil(max_px))
    for dy in range(-R_, R_ + 1):
        for dx in range(-R_, R_ + 1):
            d2 = dx * dx + dy * dy
            m = (r * r >= d2) if d2 else np.ones(r.shape, bool)
            uu, vv = ui[m] + dx, vi[m] + dy
            ok = (uu >= 0) & (uu < W) & (vv >= 0) & (vv < H)
            sel = np.nonzero(m)[0][ok]
            pix.append(vv[ok] * W + uu[ok])
            zs.append(p[sel, 2])
            idx.append(sel)
    pix, zs, idx = np.concatenate(pix), np.concatenate(zs), np.concatenate(idx)
    order = np.lexsort((zs, pix))
    first = np.ones(order.size, bool)
    first[1:] = pix[order][1:] != pix[order][:-1]
    win_pix, win = pix[order][first], idx[order][first]
    # light from the viewer, a little from above-left; normals may face either way
    light = unit(np.array([-0.3, -0.5, -1.0]))
    n_view = normals[win] @ R.T
    shade = 0.55 + 0.45 * np.abs(n_view @ light)
    images = []
    for c in colours_list:
        img = np.zeros((H * W, 3), np.float64)
        img[:] = BACKGROUND
        img[win_pix] = c[win].astype(np.float64) * shade[:, None]
        images.append(img.reshape(H, W, 3))
    mask = np.zeros(H * W, bool)
    mask[win_pix] = True
    return images, mask.reshape(H, W)


def put_text(img, text, org, scale=0.5, colour=(255, 255, 255), thickness=1):
    """img is RGB uint8; draws with an outline so text reads on any background, smaller if too wide."""
    while scale > 0.3 and cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thickness)[0][0] > \
            img.shape[1] - org[0] - 4:
        scale *= 0.95
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), thickness + 2, cv2.LINE_AA)
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, thickness, cv2.LINE_AA)


def legend(width, classes, shares=None, row_h=22, col_w=170, background=BACKGROUND):
    """A strip of colour boxes and class names (RGB uint8), as many columns as fit."""
    cols = max(1, width // col_w)
    rows = (len(classes) + cols - 1) // cols
    strip = np.zeros((rows * row_h + 8, width, 3), np.uint8)
    strip[:] = background
    for k, c in enumerate(classes):
        x0, y0 = 8 + (k % cols) * col_w, 4 + (k // cols) * row_h
        cv2.rectangle(strip, (x0, y0 + 3), (x0 + 16, y0 + 17), tuple(int(t) for t in PALETTE[c]), -1)
        cv2.rectangle(strip, (x0, y0 + 3), (x0 + 16, y0 + 17), (255, 255, 255), 1)
        text = CLASS_NAMES[c] + ("  %.1f%%" % (100 * shares[c]) if shares is not None else "")
        cv2.putText(strip, text, (x0 + 22, y0 + 15), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1,
                    cv2.LINE_AA)
    return strip


def write_png(path, rgb, limit_bytes=400_000):
    """PNG, level 9; photographs are quantised (5, then 4 bits per channel) if over the limit."""
    bgr = np.ascontiguousarray(rgb[:, :, ::-1])
    for bits in (8, 6, 5, 4):
        q = bgr if bits == 8 else (bgr >> (8 - bits) << (8 - bits)) + (1 << (7 - bits))
        ok, buf = cv2.imencode(".png", q, [cv2.IMWRITE_PNG_COMPRESSION, 9])
        if len(buf) <= limit_bytes:
            break
    with open(path, "wb") as f:
        f.write(buf.tobytes())
    return len(buf), bits


def draw(ply_path, out, trajectory=None, title=None, size=(640, 480), elevation=45.0, azimuth=0.0,
         min_confidence=10.0):
    m = read_ply(ply_path)
    keep = m["confidence"] >= min_confidence if "confidence" in m.dtype.names else np.ones(len(m), bool)
    m = m[keep]
    pts = np.stack([m["x"], m["y"], m["z"]], 1).astype(np.float64)
    nrm = np.stack([m["nx"], m["ny"], m["nz"]], 1).astype(np.float64)
    rgb = np.stack([m["red"], m["green"], m["blue"]], 1)
    cls = m["class_id"].astype(np.int64)
    lab = PALETTE[np.clip(cls, 0, 13)]
    poses = read_tum_poses(trajectory) if trajectory else []
    R, eye = view_camera(pts, poses, elevation, azimuth)
    (img_rgb, img_lab), _ = splat(pts, nrm, m["radius"].astype(np.float64), [rgb, lab], R, eye, size)
    img_rgb = np.clip(img_rgb, 0, 255).astype(np.uint8)
    img_lab = np.clip(img_lab, 0, 255).astype(np.uint8)
    put_text(img_rgb, "colour", (10, 22), 0.6)
    put_text(img_lab, "labels (NYUv2 13 classes)", (10, 22), 0.6)
    gap = np.zeros((size[1], 4, 3), np.uint8)
    gap[:] = 255
    body = np.concatenate([img_rgb, gap, img_lab], axis=1)
    shares = np.bincount(cls, minlength=14) / max(len(cls), 1)
    present = [c for c in range(14) if shares[c] >= 0.001]
    strip = legend(body.shape[1], present, shares)
    parts = []
    if title:
        head = np.zeros((28, body.shape[1], 3), np.uint8)
        head[:] = BACKGROUND
        put_text(head, title, (10, 19), 0.5)
        parts.append(head)
    parts += [body, strip]
    picture = np.concatenate(parts, axis=0)
    nbytes, bits = write_png(out, picture)
    return {"surfels_in_file": int(len(keep)), "surfels_drawn": int(keep.sum()), "class_share": shares.tolist(),
            "png_bytes": nbytes, "bits_per_channel": bits}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ply")
    ap.add_argument("--out", required=True)
    ap.add_argument("--trajectory", help="TUM trajectory of the run (sets up and the viewing side)")
    ap.add_argument("--title")
    ap.add_argument("--size", default="640x480", help="each panel, WxH")
    ap.add_argument("--elevation", type=float, default=45.0, help="degrees looking down")
    ap.add_argument("--azimuth", type=float, default=0.0, help="degrees around up")
    ap.add_argument("--min-confidence", type=float, default=10.0)
    a = ap.parse_args()
    W, H = (int(t) for t in a.size.split("x"))
    info = draw(a.ply, a.out, a.trajectory, a.title, (W, H), a.elevation, a.azimuth, a.min_confidence)
    shares = info["class_share"]
    print("%s: %d of %d surfels drawn (confidence >= %g), %d bytes (%d bits/channel)" %
          (a.out, info["surfels_drawn"], info["surfels_in_file"], a.min_confidence, info["png_bytes"],
           info["bits_per_channel"]))
    print("classes: " + ", ".join("%s %.1f%%" % (CLASS_NAMES[c], 100 * s) for c, s in enumerate(shares) if s >= 0.001))


if __name__ == "__main__":
    main()
