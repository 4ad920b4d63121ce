#!/usr/bin/env python3
"""Oracle for src/raw/sample.rs and the pattern names of src/raw/cfa.rs.

Inputs are synthesised with a fixed seed (no shared data needed). Writes to --out:
  raw_rgb.npy                 uint8 (29, 37, 3) random RGB image
  raw_mosaic_{P}.npy          colour_demosaicing.mosaicing_CFA_Bayer(raw_rgb, P) for P in
                              RGGB, BGGR, GRBG, GBRG (colour-demosaicing names patterns physically)
  raw_opencv_names.json       for each physical pattern P, the OpenCV code COLOR_<name>2RGB whose
                              bilinear demosaic of a mosaic of P reproduces a linear colour ramp
                              exactly in the interior (found by trying all four codes)
"""
import argparse
import json
import pathlib

import cv2
import numpy as np
from colour_demosaicing import mosaicing_CFA_Bayer

PATTERNS = ["RGGB", "BGGR", "GRBG", "GBRG"]
OPENCV = ["BayerBG", "BayerGB", "BayerRG", "BayerGR"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    out = pathlib.Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261122)
    rgb = rng.integers(0, 256, size=(29, 37, 3), dtype=np.uint8)
    np.save(out / "raw_rgb.npy", rgb)
    for p in PATTERNS:
        m = mosaicing_CFA_Bayer(rgb.astype(np.float64), p)
        np.save(out / f"raw_mosaic_{p}.npy", m)

    # A linear colour ramp: bilinear demosaicing reproduces it exactly away from the border,
    # but only when the pattern is interpreted correctly.
    h, w = 24, 32
    y, x = np.mgrid[0:h, 0:w]
    ramp = np.stack([40 + 3 * x + 2 * y, 60 + 2 * x + 4 * y, 200 - 3 * x - y], axis=-1).astype(np.uint8)
    names = {}
    for p in PATTERNS:
        mosaic = mosaicing_CFA_Bayer(ramp.astype(np.float64), p).astype(np.uint8)
        errs = {}
        for code in OPENCV:
            out_rgb = cv2.cvtColor(mosaic, getattr(cv2, f"COLOR_{code}2RGB"))
            errs[code] = int(np.abs(out_rgb[2:-2, 2:-2].astype(int) - ramp[2:-2, 2:-2].astype(int)).max())
        best = min(errs, key=errs.get)
        assert errs[best] <= 1, (p, errs)
        names[p] = best
    (out / "raw_opencv_names.json").write_text(json.dumps(names, indent=1))


if __name__ == "__main__":
    main()
