#!/usr/bin/env python3
"""Measurement tools for the sensor's vignetting (docs/stages/sweep.md, "256² hall").

Needs numpy and Pillow. Views are HCI folders (input_CamNNN.png, 9×9 grid, 8-bit RGB).

  vignetting.py errmap EST.pfm GT.pfm OUT.png
      |est − gt| > 0.07 px as a PNG (4× nearest): grey the ground truth, red too near
      (est > gt), blue too far, brighter with the error (saturating at 0.5 px).
  vignetting.py estimate SCENE EST.pfm
      The radial vignetting k of the model V = 1 − k·r²/r²_corner (r from the image
      centre), fitted to the views of the centre row and column warped to the centre
      view by the disparity EST.pfm: log(I_v(x − d·u) / I_c(x)) = log V(x − d·u) − log V(x)
      ≈ −k·(r²(x − d·u) − r²(x)) / r²_corner, least squares over pixels brighter than
      8 levels in both, residuals beyond 3 median deviations dropped (three rounds).
  vignetting.py flatten SCENE OUT K
      Writes SCENE's views divided by V (16-bit PNG, level·257, so unit intensity is
      kept and nothing is rounded to 8 bits again) and its other files into OUT.
"""
import os
import shutil
import struct
import sys
import zlib

import numpy as np
from PIL import Image

GRID = 9
CENTRE = GRID // 2


def read_pfm(path):
    with open(path, "rb") as f:
        f.readline()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        d = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4").reshape(h, w)
    return np.flipud(d).astype(np.float64)


def view(scene, row, col):
    path = f"{scene}/input_Cam{row * GRID + col:03d}.png"
    return np.asarray(Image.open(path).convert("RGB"), np.float64)


def bilinear(img, sx, sy):
    h, w = img.shape
    sx = np.clip(sx, 0, w - 1.000001)
    sy = np.clip(sy, 0, h - 1.000001)
    x0 = np.floor(sx).astype(int)
    y0 = np.floor(sy).astype(int)
    fx, fy = sx - x0, sy - y0
    top = img[y0, x0] * (1 - fx) + img[y0, x0 + 1] * fx
    bottom = img[y0 + 1, x0] * (1 - fx) + img[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def radius2(h, w, x, y):
    cx, cy = (w - 1) / 2, (h - 1) / 2
    return ((x - cx) ** 2 + (y - cy) ** 2) / (cx * cx + cy * cy)


def estimate(scene, est):
    d = read_pfm(est)
    h, w = d.shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    centre = view(scene, CENTRE, CENTRE).mean(2)
    a_all, b_all = [], []
    others = [(CENTRE, k) for k in range(GRID) if k != CENTRE]
    others += [(k, CENTRE) for k in range(GRID) if k != CENTRE]
    for row, col in others:
        u, v = col - CENTRE, row - CENTRE
        sx, sy = xx - d * u, yy - d * v
        sample = bilinear(view(scene, row, col).mean(2), sx, sy)
        ok = (sx > 2) & (sx < w - 3) & (sy > 2) & (sy < h - 3) & (centre > 8) & (sample > 8)
        a_all.append(-(radius2(h, w, sx, sy) - radius2(h, w, xx, yy))[ok])
        b_all.append(np.log(sample[ok] / centre[ok]))
    a, b = np.concatenate(a_all), np.concatenate(b_all)
    keep = np.ones_like(a, bool)
    k = 0.0
    for _ in range(4):
        k = (a[keep] * b[keep]).sum() / (a[keep] * a[keep]).sum()
        res = np.abs(b - k * a)
        keep = res < 3 * np.median(res) + 1e-12
    print(f"k = {k:.4f} ({keep.sum()} samples)")


def png16(path, rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].astype(">u2").tobytes() for y in range(h))

    def chunk(tag, data):
        crc = zlib.crc32(tag + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", w, h, 16, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header))
        f.write(chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def flatten(scene, out, k):
    os.makedirs(out, exist_ok=True)
    for name in os.listdir(scene):
        path = f"{scene}/{name}"
        if os.path.isfile(path) and not name.startswith("input_Cam"):
            shutil.copy(path, f"{out}/{name}")
    for index in range(GRID * GRID):
        rgb = view(scene, index // GRID, index % GRID)
        h, w, _ = rgb.shape
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
        gain = 1 - k * radius2(h, w, xx, yy)
        flat = np.clip(np.round(rgb / gain[..., None] * 257), 0, 65535).astype(np.uint16)
        png16(f"{out}/input_Cam{index:03d}.png", flat)


def errmap(est, gt, out):
    e, g = read_pfm(est), read_pfm(gt)
    err = e - g
    base = ((g - g.min()) / (g.max() - g.min() + 1e-9) * 120).astype(np.uint8)
    rgb = np.repeat(base[..., None], 3, axis=2)
    mag = (120 + 135 * np.clip(np.abs(err) / 0.5, 0, 1)).astype(np.uint8)
    high, low = err > 0.07, err < -0.07
    rgb[high] = 0
    rgb[low] = 0
    rgb[high, 0] = mag[high]
    rgb[low, 2] = mag[low]
    h, w = g.shape
    Image.fromarray(rgb).resize((4 * w, 4 * h), Image.NEAREST).save(out)
    print(f"{100 * (high | low).mean():.3f} % of the pixels off by more than 0.07 px")


if __name__ == "__main__":
    commands = {"errmap": (errmap, 3), "estimate": (estimate, 2), "flatten": (flatten, 3)}
    if len(sys.argv) < 2 or sys.argv[1] not in commands:
        sys.exit(__doc__)
    run, count = commands[sys.argv[1]]
    args = sys.argv[2:]
    if len(args) != count:
        sys.exit(__doc__)
    if run is flatten:
        args[2] = float(args[2])
    run(*args)
