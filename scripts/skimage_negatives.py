#!/usr/bin/env python3
"""Write scikit-image's person-free sample photographs as PNGs, for `mosaicd train --negatives-dir`.

Only images shipped inside the scikit-image wheel are used (never a pooch download: each image's
file must already be in `skimage.data.data_dir`, or the script fails). Each image was checked by
eye; those with people, and those that are not photographs or cannot hold a 64x128 window, are left
out (EXCLUDED says why). Grey images stay grey (mosaicd reads them as RGB with equal channels).

    python3 scripts/skimage_negatives.py --out target/skimage_negatives

The images are generated, never committed. The script prints each image's size and a SHA-256 of its
decoded pixels; `mosaicd train` records its own digest of what it trained on in the model's
provenance.
"""
import argparse
import hashlib
import os
import pathlib
import sys

# skimage.data function → the file it reads from the wheel. Person-free photographs, each at least
# 64x128 (some are textures, microscopy or astronomy: still real photographs, so still negatives).
INCLUDED = {
    "brick": "brick.png",
    "cell": "cell.png",
    "chelsea": "chelsea.png",
    "clock": "clock_motion.png",
    "coffee": "coffee.png",
    "grass": "grass.png",
    "gravel": "gravel.png",
    "hubble_deep_field": "hubble_deep_field.jpg",
    "immunohistochemistry": "ihc.png",
    "moon": "moon.png",
    "page": "page.png",
    "retina": "retina.jpg",
    "rocket": "rocket.jpg",
    "text": "text.png",
    # stereo_motorcycle() returns (left, right, disparity); both views are written.
    "stereo_motorcycle": "motorcycle_left.png",
}

# Everything else skimage.data offers, and why it is not used.
EXCLUDED = {
    "astronaut": "a person",
    "camera": "a person (the cameraman)",
    "coins": "coins with human heads and a standing figure in relief",
    "lfw_subset": "faces (25x25)",
    "no_time_for_that_tiny.gif": "a person, 25x14 (a file, no skimage.data function)",
    "microaneurysms": "102x102: smaller than a 64x128 window",
    "horse": "a binary silhouette, not a photograph",
    "logo": "a drawn logo, not a photograph",
    "colorwheel": "synthetic",
    "shepp_logan_phantom": "synthetic",
    "checkerboard": "synthetic",
    "binary_blobs": "synthetic",
    "brain": "needs a download",
    "cat": "the same image as chelsea",
    "cells3d": "needs a download",
    "eagle": "needs a download",
    "human_mitosis": "needs a download",
    "kidney": "needs a download",
    "lily": "needs a download",
    "nickel_solidification": "needs a download",
    "palisades_of_vogt": "needs a download",
    "protein_transport": "needs a download",
    "skin": "needs a download",
    "vortex": "needs a download",
}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="target/skimage_negatives")
    args = ap.parse_args()

    import numpy as np
    import skimage
    import skimage.data
    import skimage.io

    missing = [f for f in INCLUDED.values() if not os.path.exists(os.path.join(skimage.data.data_dir, f))]
    if missing:
        print(f"skimage_negatives: not in the installed wheel (would need a download): {missing}", file=sys.stderr)
        return 1
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    images = {}
    for name in INCLUDED:
        if name == "stereo_motorcycle":
            left, right, _ = skimage.data.stereo_motorcycle()
            images["motorcycle_left"], images["motorcycle_right"] = left, right
        else:
            images[name] = getattr(skimage.data, name)()
    for name, img in images.items():
        assert img.dtype == np.uint8 and img.ndim in (2, 3), (name, img.dtype, img.shape)
        h, w = img.shape[:2]
        assert w >= 64 and h >= 128, (name, img.shape)
        skimage.io.imsave(out / f"{name}.png", img, check_contrast=False)
        digest = hashlib.sha256(np.ascontiguousarray(img).tobytes()).hexdigest()[:16]
        print(f"{name}.png {w}x{h} {'rgb' if img.ndim == 3 else 'grey'} sha256:{digest}")
    print(f"skimage_negatives: {len(images)} images (scikit-image {skimage.__version__}) in {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
