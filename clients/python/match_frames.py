#!/usr/bin/env python3
"""Track a camera's motion from the daemon's mosaic SIFT features, in Python, with OpenCV's matcher.

Subscribes to a running daemon's ``keypoints`` and ``descriptors`` services (``compute.keypoints``
and ``compute.keypoint_descriptors`` on), joins them by frame index, matches every frame with the
one before it (``cv2.BFMatcher`` with the L2 norm, Lowe's ratio 0.8 and a mutual check, as
``mosaicd``'s own matcher) and prints one JSON line per frame pair: the number of matches and the
median displacement of the matched keypoints (full-resolution mosaic pixels), i.e. how the image
moved between the frames. The descriptors are OpenCV's 128 ``uint8`` values, so OpenCV takes them
as they arrive from shared memory, with no demosaicing anywhere::

    python3 clients/python/match_frames.py --camera front --until-final
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

import cv2
import iceoryx2 as iox2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mosaicd_subscriber import (  # noqa: E402  (the sibling module, wherever this runs from)
    DEFAULT_ROOT,
    DESCRIPTOR_BYTES,
    MAX_KEYPOINTS,
    DescriptorsMsg,
    KeypointsMsg,
    StatsMsg,
    create_node,
    open_service,
)

RATIO = 0.8


def features(k: KeypointsMsg, d: DescriptorsMsg) -> tuple[np.ndarray, np.ndarray]:
    """Keypoint positions (n x 2, float32) and descriptors (n x 128, float32) of one frame."""
    n = min(k.keypoint_count, d.descriptor_count, MAX_KEYPOINTS)
    xy = np.array([[p.x, p.y] for p in k.keypoints[:n]], dtype=np.float32).reshape(n, 2)
    desc = np.frombuffer(bytes(d.descriptors), dtype=np.uint8).reshape(MAX_KEYPOINTS, DESCRIPTOR_BYTES)
    return xy, desc[:n].astype(np.float32)


def match(d1: np.ndarray, d2: np.ndarray) -> list[tuple[int, int]]:
    """Mutual nearest neighbours passing Lowe's ratio test, as (index in 1, index in 2)."""
    if len(d1) < 2 or len(d2) < 2:
        return []
    bf = cv2.BFMatcher(cv2.NORM_L2)

    def one_way(a: np.ndarray, b: np.ndarray) -> dict[int, int]:
        out = {}
        for m in bf.knnMatch(a, b, k=2):
            if len(m) == 2 and m[0].distance < RATIO * m[1].distance:
                out[m[0].queryIdx] = m[0].trainIdx
        return out

    fwd, back = one_way(d1, d2), one_way(d2, d1)
    return sorted((i, j) for i, j in fwd.items() if back.get(j) == i)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--camera", required=True)
    p.add_argument("--prefix", default="mosaicd")
    p.add_argument("--root", default=DEFAULT_ROOT, help="the daemon's iceoryx2 root (publish.root)")
    p.add_argument("--buffer", type=int, default=64)
    p.add_argument("--until-final", action="store_true", help="exit after the daemon's final stats")
    p.add_argument("--timeout-s", type=float, help="exit with an error after this many seconds")
    a = p.parse_args(argv)

    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    node = create_node(f"mosaicd-py-match-{os.getpid()}", a.root)

    def subscribe(topic: str, payload: type):
        try:
            svc = open_service(node, a.prefix, a.camera, topic, payload, a.buffer)
            return svc.subscriber_builder().buffer_size(a.buffer).create()
        except Exception as e:  # iceoryx2 raises its own exception types per builder
            raise SystemExit(
                f"match_frames: cannot subscribe to {a.prefix}/{a.camera}/{topic}: {type(e).__name__}: {e}"
            ) from None

    kp, desc, st = (
        subscribe("keypoints", KeypointsMsg),
        subscribe("descriptors", DescriptorsMsg),
        subscribe("stats", StatsMsg),
    )
    print(f"match_frames: subscribed to {a.prefix}/{a.camera}/{{keypoints,descriptors}}", file=sys.stderr, flush=True)

    # Frames whose keypoints or descriptors arrived without the other yet, by index. Each service
    # delivers in order, so: a message whose partner was lost (safe overflow drops a slow
    # subscriber's oldest samples, each service on its own) is dropped once a later frame is
    # joined, and an index at or below the last one of its service means a new daemon run, whose
    # messages replace what that service had pending. So these stay small.
    pending: dict[str, dict[int, Any]] = {"keypoints": {}, "descriptors": {}}
    last = {"keypoints": -1, "descriptors": -1}
    previous = None  # (index, xy, descriptors)
    start = time.monotonic()

    def put(topic: str, m: Any) -> None:
        store = pending[topic]
        if m.index <= last[topic]:
            for j in [j for j in store if j >= m.index]:
                del store[j]
        last[topic] = m.index
        store[m.index] = m

    def drain() -> None:
        nonlocal previous
        while (s := kp.receive()) is not None:
            put("keypoints", KeypointsMsg.from_buffer_copy(s.payload().contents))
        while (s := desc.receive()) is not None:
            put("descriptors", DescriptorsMsg.from_buffer_copy(s.payload().contents))
        ks, ds = pending["keypoints"], pending["descriptors"]
        for i in sorted(set(ks) & set(ds)):
            for store in (ks, ds):
                for stale in [j for j in store if j < i]:
                    del store[stale]
            xy, d = features(ks.pop(i), ds.pop(i))
            if previous is not None and previous[0] >= i:
                previous = None  # a new run: nothing to match this frame with
            if previous is not None:
                j, xy0, d0 = previous
                pairs = match(d0, d)
                shift = [xy[b] - xy0[a_] for a_, b in pairs]
                dx, dy = (float(v) for v in np.median(shift, axis=0)) if shift else (None, None)
                print(json.dumps({"from": j, "to": i, "keypoints": len(xy), "matches": len(pairs), "dx": dx, "dy": dy}))
            previous = (i, xy, d)
        sys.stdout.flush()

    cycle = iox2.Duration.from_millis(1)
    while True:
        try:
            node.wait(cycle)
        except iox2.NodeWaitFailure:
            break
        drain()
        final = False
        while (s := st.receive()) is not None:
            final = final or bool(s.payload().contents.is_final)
        if final and a.until_final:
            drain()
            break
        if a.timeout_s is not None and time.monotonic() - start >= a.timeout_s:
            print(f"timed out after {a.timeout_s} s", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
