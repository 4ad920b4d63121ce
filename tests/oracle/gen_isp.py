#!/usr/bin/env python3
"""Reference demosaicing for the isp parity tests (tests/isp_demosaic_parity.rs).

Reads kodak/kodim23.png from $MOSAICD_DATA (a 256x200 crop), mosaics it with each physical Bayer
pattern and writes under OUT/isp/:
  mosaic_<CFA>.npy            float64 HxW, the mosaic in [0, 1] (u8 / 255)
  bilinear_<CFA>.npy          float64 HxWx3, colour_demosaicing.demosaicing_CFA_Bayer_bilinear
  malvar_<CFA>.npy            float64 HxWx3, colour_demosaicing.demosaicing_CFA_Bayer_Malvar2004
  opencv_bilinear_<CFA>.npy   uint8 HxWx3 (RGB), cv2.cvtColor(mosaic_u8, COLOR_<opencv name>2RGB)
  meta.json                   source, crop, versions
OpenCV names patterns shifted by one (physical RGGB = COLOR_BayerBG2RGB); the mapping below is the
same as mosaicd's Cfa::opencv_code_name.
"""
import argparse
import json
import os
import pathlib
import sys
import warnings

import cv2
import numpy as np

warnings.filterwarnings("ignore")
import colour_demosaicing  # noqa: E402

OPENCV_NAME = {"RGGB": "BayerBG", "BGGR": "BayerRG", "GRBG": "BayerGB", "GBRG": "BayerGR"}
CROP = (100, 300, 200, 456)  # y0, y1, x0, x1


def mosaic(rgb, pattern):
    h, w, _ = rgb.shape
    out = np.zeros((h, w), dtype=rgb.dtype)
    idx = {"R": 0, "G": 1, "B": 2}
    for ch, (y, x) in zip(pattern, [(0, 0), (0, 1), (1, 0), (1, 1)]):
        out[y::2, x::2] = rgb[y::2, x::2, idx[ch]]
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    data = pathlib.Path(os.environ.get("MOSAICD_DATA", "../shared/data"))
    src = data / "kodak" / "kodim23.png"
    if not src.exists():
        print(f"gen_isp: {src} not found: set MOSAICD_DATA to the shared data directory", file=sys.stderr)
        return 1
    out = pathlib.Path(args.out) / "isp"
    out.mkdir(parents=True, exist_ok=True)
    bgr = cv2.imread(str(src), cv2.IMREAD_COLOR)
    y0, y1, x0, x1 = CROP
    rgb8 = np.ascontiguousarray(bgr[y0:y1, x0:x1, ::-1])
    for pattern, cvname in OPENCV_NAME.items():
        m8 = mosaic(rgb8, pattern)
        mf = m8.astype(np.float64) / 255.0
        np.save(out / f"mosaic_{pattern}.npy", mf)
        np.save(out / f"bilinear_{pattern}.npy", colour_demosaicing.demosaicing_CFA_Bayer_bilinear(mf, pattern))
        np.save(out / f"malvar_{pattern}.npy", colour_demosaicing.demosaicing_CFA_Bayer_Malvar2004(mf, pattern))
        code = getattr(cv2, f"COLOR_{cvname}2RGB")
        np.save(out / f"opencv_bilinear_{pattern}.npy", cv2.cvtColor(m8, code))
    meta = {
        "source": "kodak/kodim23.png",
        "crop_y0_y1_x0_x1": CROP,
        "opencv": cv2.__version__,
        "colour_demosaicing": colour_demosaicing.__version__,
    }
    (out / "meta.json").write_text(json.dumps(meta, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
