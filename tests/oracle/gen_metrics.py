#!/usr/bin/env python3
"""Reference fixtures for the image metrics (tests/metrics_parity.rs).

For a few Kodak images (read from $MOSAICD_DATA/kodak) this makes a deterministic distorted copy
(Gaussian blur, gain/offset, seeded Gaussian noise; float32, not quantised) and computes with
scikit-image, on float64 copies of exactly the float32 values written:
  * structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
    data_range=255), grey and per channel (channel_axis=2) and the full SSIM map for one image;
  * peak_signal_noise_ratio(data_range=255) and mean_squared_error, grey and RGB;
  * GMSD of Xue et al. 2014 on grey, re-implemented here from their GMSD.m with scipy.
Grey is BT.601 (0.299 R + 0.587 G + 0.114 B) computed here in float64 and stored as float32.
Writes metrics_<name>_{dist_rgb,grey_ref,grey_dist}.npy, metrics_kodim01_ssim_map.npy and
metrics.json under --out. The reference RGB is the PNG itself (the Rust test reads it too).
"""
import argparse
import json
import os
import pathlib
import sys

import cv2
import numpy as np
from skimage.metrics import mean_squared_error, peak_signal_noise_ratio, structural_similarity

IMAGES = ["kodim01", "kodim05", "kodim13", "kodim23"]
DATA_RANGE = 255.0
SEED = 20140101


def ssim(a, b, **kw):
    return float(structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
                                       use_sample_covariance=False, data_range=DATA_RANGE, **kw))


def gmsd_xue2014(y1, y2):
    """GMSD.m of Xue et al. 2014 (T = 170, 2x2 average + downsample, Prewitt/3, std2 with N - 1),
    written independently with scipy.signal.convolve2d (zero padding, 'same' as MATLAB for 3x3)."""
    from scipy.signal import convolve2d
    t = 170.0
    dx = np.array([[1.0, 0.0, -1.0]] * 3) / 3.0
    dy = dx.T
    def down(y):
        # conv2(Y, ones(2)/4, 'same') in MATLAB averages Y(i, j) .. Y(i+1, j+1); keep (1:2:end).
        p = np.pad(y, ((0, 1), (0, 1)))
        ave = (p[:-1, :-1] + p[1:, :-1] + p[:-1, 1:] + p[1:, 1:]) / 4.0
        return ave[0::2, 0::2]
    def mag(y):
        return np.sqrt(convolve2d(y, dx, mode="same") ** 2 + convolve2d(y, dy, mode="same") ** 2)
    g1, g2 = mag(down(y1)), mag(down(y2))
    q = (2 * g1 * g2 + t) / (g1 ** 2 + g2 ** 2 + t)
    return float(np.std(q, ddof=1))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    data = pathlib.Path(os.environ.get("MOSAICD_DATA", pathlib.Path(__file__).resolve().parents[3] / "shared/data"))
    result = {"data_range": DATA_RANGE, "images": {}}
    for i, name in enumerate(IMAGES):
        path = data / "kodak" / f"{name}.png"
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            print(f"gen_metrics: cannot read {path}: set MOSAICD_DATA to the shared data directory", file=sys.stderr)
            return 1
        ref = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB).astype(np.float64)
        rng = np.random.default_rng(SEED + i)
        dist = cv2.GaussianBlur(ref, (0, 0), 1.0 + 0.3 * i) * 0.95 + 6.0
        dist = (dist + rng.normal(0.0, 4.0, size=dist.shape)).astype(np.float32)
        w = np.array([0.299, 0.587, 0.114])
        grey_ref = (ref @ w).astype(np.float32)
        grey_dist = (dist.astype(np.float64) @ w).astype(np.float32)
        np.save(out / f"metrics_{name}_dist_rgb.npy", dist)
        np.save(out / f"metrics_{name}_grey_ref.npy", grey_ref)
        np.save(out / f"metrics_{name}_grey_dist.npy", grey_dist)
        d64 = dist.astype(np.float64)
        gr, gd = grey_ref.astype(np.float64), grey_dist.astype(np.float64)
        entry = {
            "grey": {"ssim": ssim(gr, gd),
                     "psnr": float(peak_signal_noise_ratio(gr, gd, data_range=DATA_RANGE)),
                     "mse": float(mean_squared_error(gr, gd)),
                     "gmsd_xue2014": gmsd_xue2014(gr, gd)},
            "rgb": {"ssim": ssim(ref, d64, channel_axis=2),
                    "psnr": float(peak_signal_noise_ratio(ref, d64, data_range=DATA_RANGE)),
                    "mse": float(mean_squared_error(ref, d64))},
            "channels": [{"ssim": ssim(ref[..., c], d64[..., c]),
                          "psnr": float(peak_signal_noise_ratio(ref[..., c], d64[..., c], data_range=DATA_RANGE))}
                         for c in range(3)],
        }
        if name == "kodim01":
            _, smap = structural_similarity(gr, gd, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                                            data_range=DATA_RANGE, full=True)
            np.save(out / "metrics_kodim01_ssim_map.npy", smap.astype(np.float32))
        result["images"][name] = entry
    (out / "metrics.json").write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
