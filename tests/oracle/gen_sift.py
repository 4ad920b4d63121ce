#!/usr/bin/env python3
"""OpenCV SIFT reference for the grey-SIFT parity test (tests/sift_parity.rs).

For a few Kodak images: grey = cv2.cvtColor(BGR2GRAY) (8-bit), then cv2.SIFT_create() defaults
(detectAndCompute). Writes, per image NAME:
  sift_NAME_grey.npy        the exact 8-bit grey input (H x W)
  sift_NAME_kp.npy          keypoints, N x 6: x, y, size, angle, response, octave (unpacked, signed)
  sift_NAME_desc.npy        descriptors, N x 128 (float32 holding OpenCV's integer values)
Inputs come from $MOSAICD_DATA/kodak; fixtures are derived data and are never committed.
"""
import argparse
import os
import pathlib
import sys

import cv2
import numpy as np

IMAGES = ["kodim01", "kodim09", "kodim23"]


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    data = pathlib.Path(os.environ.get("MOSAICD_DATA", "../shared/data"))
    cv2.setNumThreads(1)
    sift = cv2.SIFT_create()
    for name in IMAGES:
        path = data / "kodak" / f"{name}.png"
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            print(f"gen_sift: missing {path}: set MOSAICD_DATA to the shared data directory", file=sys.stderr)
            return 1
        grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
        kps, desc = sift.detectAndCompute(grey, None)
        rows = []
        for k in kps:
            octave = k.octave & 255
            octave = octave if octave < 128 else octave - 256
            rows.append([k.pt[0], k.pt[1], k.size, k.angle, k.response, octave])
        np.save(out / f"sift_{name}_grey.npy", grey.astype(np.uint8))
        np.save(out / f"sift_{name}_kp.npy", np.asarray(rows, dtype=np.float64).reshape(-1, 6))
        np.save(out / f"sift_{name}_desc.npy", np.asarray(desc, dtype=np.float32).reshape(-1, 128))
        print(f"gen_sift: {name}: {len(kps)} keypoints", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
