#!/usr/bin/env python3
"""HOG parity fixtures from OpenCV's cv2.HOGDescriptor (default people-detector geometry).

Writes under --out/hog/:
  windows_grey.npy   (N,128,64) u8  grey 64x128 windows (Kodak crops + INRIA positives img[16:144,16:80])
  desc_grey.npy      (N,3780)  f32  cv2.HOGDescriptor().compute(window)
  windows_bgr.npy    (M,128,64,3) u8 colour windows in BGR order (OpenCV's max-magnitude channel)
  desc_bgr.npy       (M,3780)  f32
  scene_grey.npy     (H,W) u8      a grey Kodak image (kodim01)
  scene_scores.npy   (K,3) f64     hog.detect(scene, hitThreshold=-1e9, winStride=(8,8), padding=(0,0))
                                   rows = (x, y, score) with the default people detector
  scene2_grey.npy / scene2_scores.npy   same for an INRIA negative photo (neg_inria), grey
  multi_<tag>.npy    (K,5) f64     hog.detectMultiScale(img, winStride=(8,8), padding=(0,0), scale=1.05)
                                   rows = (x, y, w, h, weight), for Kodak 12/15 (colour, grey) and neg 11a
Inputs are read from $MOSAICD_DATA (default ../shared/data); missing data is an error.
"""
import argparse
import os
import pathlib
import sys

import cv2
import numpy as np


def data_root() -> pathlib.Path:
    return pathlib.Path(os.environ.get("MOSAICD_DATA", pathlib.Path(__file__).resolve().parents[3] / "shared/data"))


def need(rel: str) -> pathlib.Path:
    p = data_root() / rel
    if not p.exists():
        sys.exit(f"gen_hog: missing {p}: set MOSAICD_DATA to the shared data directory")
    return p


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    out = pathlib.Path(args.out) / "hog"
    out.mkdir(parents=True, exist_ok=True)
    cv2.setNumThreads(1)
    hog = cv2.HOGDescriptor()
    assert hog.gammaCorrection and hog.getDescriptorSize() == 3780

    grey, bgr = [], []
    # Kodak crops at fixed offsets (64x128 windows), grey via OpenCV's BGR2GRAY.
    for name, offs in [("kodim01", [(0, 0), (300, 200), (704, 384)]), ("kodim07", [(100, 50), (500, 300)]),
                       ("kodim13", [(40, 120), (600, 10)]), ("kodim23", [(350, 250)])]:
        img = cv2.imread(str(need(f"kodak/{name}.png")), cv2.IMREAD_COLOR)
        g = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        for (x, y) in offs:
            grey.append(g[y:y + 128, x:x + 64].copy())
            bgr.append(img[y:y + 128, x:x + 64].copy())
    pos_dir = need("pedestrian/inria_pos_96x160")
    for f in sorted(os.listdir(pos_dir))[:: 150][:12]:
        img = cv2.imread(str(pos_dir / f), cv2.IMREAD_COLOR)
        win = img[16:144, 16:80]
        grey.append(cv2.cvtColor(win, cv2.COLOR_BGR2GRAY).copy())
        bgr.append(win.copy())
    grey = np.stack(grey)
    bgr = np.stack(bgr)
    np.save(out / "windows_grey.npy", grey)
    np.save(out / "desc_grey.npy", np.stack([hog.compute(w).reshape(-1) for w in grey]).astype(np.float32))
    np.save(out / "windows_bgr.npy", bgr)
    np.save(out / "desc_bgr.npy", np.stack([hog.compute(w).reshape(-1) for w in bgr]).astype(np.float32))

    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    scenes = [("scene", cv2.cvtColor(cv2.imread(str(need("kodak/kodim01.png"))), cv2.COLOR_BGR2GRAY))]
    neg_dir = need("pedestrian/neg_inria")
    neg = sorted(os.listdir(neg_dir))[5]  # 00000011a: the default detector fires twice here
    scenes.append(("scene2", cv2.cvtColor(cv2.imread(str(neg_dir / neg)), cv2.COLOR_BGR2GRAY)))
    for tag, g in scenes:
        locs, weights = hog.detect(g, hitThreshold=-1e9, winStride=(8, 8), padding=(0, 0))
        locs = np.asarray(locs).reshape(-1, 2)
        weights = np.asarray(weights).reshape(-1)
        rows = np.column_stack([locs.astype(np.float64), weights.astype(np.float64)])
        np.save(out / f"{tag}_grey.npy", g)
        np.save(out / f"{tag}_scores.npy", rows)
    # Full multi-scale detection (default detectMultiScale arguments except explicit padding 0).
    multi = [("kodim12", need("kodak/kodim12.png"), False), ("kodim12_grey", need("kodak/kodim12.png"), True),
             ("neg11a", neg_dir / neg, True), ("kodim15", need("kodak/kodim15.png"), False)]
    for tag, p, as_grey in multi:
        img = cv2.imread(str(p))
        if as_grey:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        rects, weights = hog.detectMultiScale(img, hitThreshold=0, winStride=(8, 8), padding=(0, 0), scale=1.05)
        rects = np.asarray(rects, dtype=np.float64).reshape(-1, 4)
        weights = np.asarray(weights, dtype=np.float64).reshape(-1, 1)
        np.save(out / f"multi_{tag}.npy", np.hstack([rects, weights]) if len(rects) else np.zeros((0, 5)))
    print(f"gen_hog: {len(grey)} grey + {len(bgr)} colour windows, scenes {[s[0] for s in scenes]} -> {out}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
