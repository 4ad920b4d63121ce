#!/usr/bin/env python3
"""Oracle for src/features/superpixel.rs: cv2.GaussianBlur and cv2.resize(INTER_LINEAR) on float32.

Inputs are synthesised with a fixed seed (no shared data needed). Writes superpixel_*.npy to --out:
  superpixel_src.npy                      float32 (61, 83) source in [0, 1)
  superpixel_blur_s{sigma}.npy            GaussianBlur(src, (0,0), sigma)        (kernel from sigma)
  superpixel_blur_k{k}.npy                GaussianBlur(src, (k,k), 0)            (OpenCV fixed tables / formula)
  superpixel_resize_{w}x{h}.npy           resize(src, (w,h), INTER_LINEAR)
"""
import argparse
import pathlib

import cv2
import numpy as np

SIGMAS = [0.8, 1.6, 2.5]
KSIZES = [3, 5, 9]
SIZES = [(41, 30), (120, 90), (79, 58), (166, 122), (30, 61)]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    out = pathlib.Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261122)
    src = rng.random((61, 83), dtype=np.float32)
    np.save(out / "superpixel_src.npy", src)
    for s in SIGMAS:
        np.save(out / f"superpixel_blur_s{s}.npy", cv2.GaussianBlur(src, (0, 0), s))
    for k in KSIZES:
        np.save(out / f"superpixel_blur_k{k}.npy", cv2.GaussianBlur(src, (k, k), 0))
    for w, h in SIZES:
        np.save(out / f"superpixel_resize_{w}x{h}.npy", cv2.resize(src, (w, h), interpolation=cv2.INTER_LINEAR))


if __name__ == "__main__":
    main()
