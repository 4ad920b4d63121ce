#!/usr/bin/env python3
"""OpenCV peer for `mosaicd bench gradients`: the conventional path on the same mosaic.

Reads a Bayer mosaic (.npy, uint8 or uint16, physical pattern given by --cfa) and times, on
--threads threads (cv2.setNumThreads; default one), the median of --repeats runs of:

  mag:        cvtColor(Bayer→BGR, bilinear) → cvtColor(BGR2GRAY) → filter2D [-1,0,1] in x and y
              (CV_32F) → cv2.magnitude
  mag_phase:  the same plus cv2.phase(angleInDegrees=True), for orientation (like for like with
              our magnitude + orientation bin)

Physical RGGB (red at (0,0)) is OpenCV's COLOR_BayerBG2BGR: OpenCV names the pattern by the
second row's first two pixels. Prints one JSON line: {"mag_ms": .., "mag_phase_ms": .., ...}: median
wall time, median CPU time of the calling thread (with one thread OpenCV runs its loops there) and
median CPU time of the process (`*_proc_cpu_ms`, every thread).
"""
import argparse
import json
import sys
import time

import cv2
import numpy as np

# Physical pattern name -> OpenCV's (shifted) conversion code.
CODES = {
    "RGGB": cv2.COLOR_BayerBG2BGR,
    "BGGR": cv2.COLOR_BayerRG2BGR,
    "GRBG": cv2.COLOR_BayerGB2BGR,
    "GBRG": cv2.COLOR_BayerGR2BGR,
}
KX = np.array([[-1, 0, 1]], np.float32)
KY = KX.T.copy()


def pipeline(mosaic, code, with_phase):
    bgr = cv2.cvtColor(mosaic, code)
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    gx = cv2.filter2D(grey, cv2.CV_32F, KX)
    gy = cv2.filter2D(grey, cv2.CV_32F, KY)
    mag = cv2.magnitude(gx, gy)
    if with_phase:
        ph = cv2.phase(gx, gy, angleInDegrees=True)
        return mag, ph
    return mag, None


def median_ms(fn, repeats):
    """Median wall time, median CPU time of this thread and median CPU time of the process (all
    threads: what OpenCV's workers spend with --threads > 1), in ms. CPU times are robust when the
    machine is shared: time during which other processes ran is not counted."""
    fn()  # warm-up (allocations, page faults)
    wall, cpu, proc = [], [], []
    for _ in range(repeats):
        c = time.thread_time()
        p = time.process_time()
        t = time.perf_counter()
        fn()
        wall.append((time.perf_counter() - t) * 1e3)
        cpu.append((time.thread_time() - c) * 1e3)
        proc.append((time.process_time() - p) * 1e3)
    wall.sort()
    cpu.sort()
    proc.sort()
    return wall[len(wall) // 2], cpu[len(cpu) // 2], proc[len(proc) // 2]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--npy", required=True)
    ap.add_argument("--cfa", default="RGGB", choices=sorted(CODES))
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    cv2.setNumThreads(args.threads)
    mosaic = np.load(args.npy)
    if mosaic.dtype not in (np.uint8, np.uint16) or mosaic.ndim != 2:
        print(f"peer: need a 2-D uint8/uint16 mosaic, got {mosaic.dtype} {mosaic.shape}", file=sys.stderr)
        return 2
    code = CODES[args.cfa]
    mag_ms, mag_cpu_ms, mag_proc_ms = median_ms(lambda: pipeline(mosaic, code, False), args.repeats)
    mag_phase_ms, mag_phase_cpu_ms, mag_phase_proc_ms = median_ms(
        lambda: pipeline(mosaic, code, True), args.repeats
    )
    print(
        json.dumps(
            {
                "mag_ms": mag_ms,
                "mag_phase_ms": mag_phase_ms,
                "mag_cpu_ms": mag_cpu_ms,
                "mag_phase_cpu_ms": mag_phase_cpu_ms,
                "mag_proc_cpu_ms": mag_proc_ms,
                "mag_phase_proc_cpu_ms": mag_phase_proc_ms,
                "opencv": cv2.__version__,
                "threads": cv2.getNumThreads(),
                "shape": list(mosaic.shape),
                "dtype": str(mosaic.dtype),
            }
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
