#!/usr/bin/env python3
"""Oracle for src/raw/kodak_radc.rs: LibRaw's decoding (through rawpy) of the Kodak DC50 KDC.

Reads $MOSAICD_DATA/raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC (default ../shared/data) and writes to
--out/raw/:
  kdc_dc50_raw.npy    uint16 (512, 768): rawpy's raw_image_visible (LibRaw kodak_radc_load_raw,
                      values after LibRaw's linearisation curve)
  kdc_dc50.json       pattern (physical name from raw_pattern + color_desc), black levels per
                      channel, white level, visible size, margins, rawpy/LibRaw versions
Derived from shared data: generated, never committed.
"""
import argparse
import json
import os
import pathlib
import sys

import numpy as np
import rawpy


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    out = pathlib.Path(ap.parse_args().out) / "raw"
    out.mkdir(parents=True, exist_ok=True)
    data = pathlib.Path(os.environ.get("MOSAICD_DATA", "../shared/data"))
    src = data / "raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC"
    if not src.exists():
        print(f"{src} is missing: put the shared data there or set MOSAICD_DATA", file=sys.stderr)
        return 1
    with rawpy.imread(str(src)) as r:
        # copy: raw_image_visible is a view into LibRaw memory freed when the file is closed
        vis = np.array(r.raw_image_visible, dtype=np.uint16, copy=True)
        desc = r.color_desc.decode()
        pattern = "".join(desc[i] for i in r.raw_pattern.flatten())
        meta = {
            "pattern": pattern,
            "black_level_per_channel": [int(v) for v in r.black_level_per_channel],
            "white_level": int(r.white_level),
            "width": int(r.sizes.width),
            "height": int(r.sizes.height),
            "raw_width": int(r.sizes.raw_width),
            "raw_height": int(r.sizes.raw_height),
            "top_margin": int(r.sizes.top_margin),
            "left_margin": int(r.sizes.left_margin),
            "rawpy": rawpy.__version__,
            "libraw": ".".join(str(v) for v in rawpy.libraw_version),
        }
    np.save(out / "kdc_dc50_raw.npy", vis)
    (out / "kdc_dc50.json").write_text(json.dumps(meta, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
