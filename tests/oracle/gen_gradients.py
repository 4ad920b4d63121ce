#!/usr/bin/env python3
"""Oracle fixtures for the mosaic gradient operators and RGB->grey (tests/gradient_oracle.rs).

Writes under OUT/gradients/:
  <case>_in.npy                                input mosaic (uint8/uint16 values)
  <case>_<op>_<border>_<gx|gy>.npy             OpenCV output, CV_32F
      op:     filter2d  = cv2.filter2D with [-1, 0, 1] (x) / its transpose (y)
              sobel1    = cv2.Sobel ksize=1 (no smoothing: [-1, 0, 1])
              sobel3    = cv2.Sobel ksize=3
      border: reflect101 (BORDER_REFLECT_101, OpenCV's default) | replicate (BORDER_REPLICATE)
  <case>_mag.npy, <case>_phase.npy             cv2.magnitude / cv2.phase(degrees) of sobel1 reflect101
  grey_rgb.npy, grey_out.npy                   RGB (H, W, 3) uint8 and cv2.cvtColor(RGB2GRAY)

Cases:
  syn    seeded synthetic 12-bit mosaic, odd size 37x29
  nikon  a 96x64 crop at odd offset (101, 77) of the Nikon D750 14-bit RGGB raw (read by path)
  kodak  kodim01 resampled to an RGGB mosaic (8-bit), 256x192 crop at (200, 100)

Inputs come from $MOSAICD_DATA (default ../shared/data); fixtures are generated, never committed.
"""
import argparse
import os
import pathlib
import sys

import cv2
import numpy as np

BORDERS = {"reflect101": cv2.BORDER_REFLECT_101, "replicate": cv2.BORDER_REPLICATE}
KX = np.array([[-1, 0, 1]], np.float32)


def data_root() -> pathlib.Path:
    env = os.environ.get("MOSAICD_DATA")
    if env:
        return pathlib.Path(env)
    return pathlib.Path(__file__).resolve().parent / "../../../shared/data"


def require(rel: str) -> pathlib.Path:
    p = data_root() / rel
    if not p.exists():
        sys.exit(f"gen_gradients: missing {p}: set MOSAICD_DATA to the shared data directory")
    return p


def cases():
    rng = np.random.default_rng(20240611)
    yy, xx = np.mgrid[0:29, 0:37]
    smooth = 2000 + 1500 * np.sin(xx * 0.4) * np.cos(yy * 0.3)
    syn = np.clip(smooth + rng.normal(0, 300, smooth.shape), 0, 4095).astype(np.uint16)
    yield "syn", syn

    raw = np.fromfile(require("raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw"), dtype="<u2")
    raw = raw.reshape(512, 768)
    yield "nikon", np.ascontiguousarray(raw[77 : 77 + 64, 101 : 101 + 96])

    rgb = cv2.cvtColor(cv2.imread(str(require("kodak/kodim01.png")), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    mosaic = np.empty(rgb.shape[:2], np.uint8)
    mosaic[0::2, 0::2] = rgb[0::2, 0::2, 0]  # R at (0, 0): RGGB
    mosaic[0::2, 1::2] = rgb[0::2, 1::2, 1]
    mosaic[1::2, 0::2] = rgb[1::2, 0::2, 1]
    mosaic[1::2, 1::2] = rgb[1::2, 1::2, 2]
    yield "kodak", np.ascontiguousarray(mosaic[100 : 100 + 192, 200 : 200 + 256])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    out = pathlib.Path(args.out) / "gradients"
    out.mkdir(parents=True, exist_ok=True)
    for name, m in cases():
        np.save(out / f"{name}_in.npy", m)
        for bname, b in BORDERS.items():
            res = {
                "filter2d": (
                    cv2.filter2D(m, cv2.CV_32F, KX, borderType=b),
                    cv2.filter2D(m, cv2.CV_32F, KX.T.copy(), borderType=b),
                ),
                "sobel1": (
                    cv2.Sobel(m, cv2.CV_32F, 1, 0, ksize=1, borderType=b),
                    cv2.Sobel(m, cv2.CV_32F, 0, 1, ksize=1, borderType=b),
                ),
                "sobel3": (
                    cv2.Sobel(m, cv2.CV_32F, 1, 0, ksize=3, borderType=b),
                    cv2.Sobel(m, cv2.CV_32F, 0, 1, ksize=3, borderType=b),
                ),
            }
            for op, (gx, gy) in res.items():
                np.save(out / f"{name}_{op}_{bname}_gx.npy", gx)
                np.save(out / f"{name}_{op}_{bname}_gy.npy", gy)
            if bname == "reflect101":
                gx, gy = res["sobel1"]
                np.save(out / f"{name}_mag.npy", cv2.magnitude(gx, gy))
                np.save(out / f"{name}_phase.npy", cv2.phase(gx, gy, angleInDegrees=True))

    rng = np.random.default_rng(7)
    rgb = rng.integers(0, 256, (256, 256, 3), dtype=np.uint8)
    # Include the corners of the colour cube and the grey axis.
    rgb[0, :8] = [[r, g, b] for r in (0, 255) for g in (0, 255) for b in (0, 255)]
    rgb[1, :] = np.repeat(np.arange(256, dtype=np.uint8)[:, None], 3, axis=1)
    np.save(out / "grey_rgb.npy", rgb)
    np.save(out / "grey_out.npy", cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    print(f"gen_gradients: wrote {len(list(out.glob('*.npy')))} fixtures to {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
