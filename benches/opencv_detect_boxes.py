#!/usr/bin/env python3
"""OpenCV's own HOG people detector over every USC image (or the images of a box CSV), written as a
detections CSV that `mosaicd eval detection --usc --external opencv=FILE` scores with the same
matcher and AP code as our detector.

    python3 benches/opencv_detect_boxes.py --out /tmp/opencv_usc.csv [--upsample 2] [--threshold -0.5]
    python3 benches/opencv_detect_boxes.py --upsample 1.95,1.975,1.99,2.0,2.01,2.025,2.05 \
        --out '/tmp/ocv/usc_{upsample}.csv'     # one file per pyramid phase, for --upsample-phases

Settings mirror `mosaicd eval detection` / `mosaicd detect`: the grey image is resized by --upsample
(cv2.resize, bilinear) and `detectMultiScale(hitThreshold, winStride=(8, 8), padding=(0, 0),
scale=1.05)` runs with OpenCV's default people detector and its groupRectangles grouping; boxes
are mapped back to the original pixels. Keys are `set/image` as in usc_boxes_derived.csv.
Needs opencv-python-headless < 5 (HOGDescriptor). Runs on every image: mosaicd picks its subset.
"""
import argparse
import csv
import os
import sys

import cv2
import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    data = os.environ.get("MOSAICD_DATA", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    ap.add_argument("--boxes", default=os.path.join(data, "pedestrian", "usc", "usc_boxes_derived.csv"))
    ap.add_argument("--images", help="image directory (default: the CSV's directory)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--upsample", default="2.0",
                    help="factor, or comma-separated factors (then --out must contain {upsample})")
    ap.add_argument("--threshold", type=float, default=-0.5)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    factors = [f.strip() for f in a.upsample.split(",") if f.strip()]
    if len(factors) > 1 and "{upsample}" not in a.out:
        sys.exit("several --upsample factors need {upsample} in --out")
    for f in factors:
        run(a, float(f), a.out.replace("{upsample}", f))


def run(a, upsample, out):
    if not os.path.exists(a.boxes):
        sys.exit(f"{a.boxes} not found: set MOSAICD_DATA to the shared data directory")
    root = a.images or os.path.dirname(a.boxes)
    keys = []
    with open(a.boxes, newline="") as f:
        for r in csv.DictReader(f):
            k = (r.get("set") or "", r["image"])
            if k not in keys:
                keys.append(k)
    cv2.setNumThreads(a.threads)
    hog = cv2.HOGDescriptor()
    hog.setSVMDetector(cv2.HOGDescriptor_getDefaultPeopleDetector())
    n = 0
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["image", "x", "y", "w", "h", "score"])
        for i, (s, name) in enumerate(sorted(keys)):
            p = os.path.join(root, s, name) if s else os.path.join(root, name)
            g = cv2.imread(p, cv2.IMREAD_GRAYSCALE)
            if g is None:
                sys.exit(f"cannot read {p}")
            size = (round(g.shape[1] * upsample), round(g.shape[0] * upsample))
            g2 = cv2.resize(g, size) if upsample != 1 else g
            rects, weights = hog.detectMultiScale(
                g2, hitThreshold=a.threshold, winStride=(8, 8), padding=(0, 0), scale=1.05
            )
            key = f"{s}/{name}" if s else name
            for b, sc in zip(np.asarray(rects).reshape(-1, 4), np.asarray(weights).ravel()):
                w.writerow([key] + [f"{v / upsample:.2f}" for v in b] + [f"{float(sc):.5f}"])
                n += 1
            print(f"\r[{i + 1}/{len(keys)}] {key:<40}", end="", file=sys.stderr)
    print(f"\n{len(keys)} images, {n} detections -> {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
