#!/usr/bin/env python3
"""Run every tests/oracle/gen_*.py generator, writing reference fixtures under --out.

Each generator computes reference outputs with OpenCV / scikit-image / colour-demosaicing on
inputs it either synthesises (seeded) or reads from $MOSAICD_DATA, and writes .npy/.json files
that the Rust parity tests read from $MOSAICD_ORACLE. Fixtures are derived from shared data and are
therefore generated, never committed.
"""
import argparse
import os
import pathlib
import subprocess
import sys


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="target/oracle")
    args = ap.parse_args()
    out = pathlib.Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    here = pathlib.Path(__file__).resolve().parent
    env = dict(os.environ)
    env.setdefault("MOSAICD_DATA", str((here / "../../../shared/data").resolve()))
    failed = []
    for gen in sorted(here.glob("gen_*.py")):
        print(f"oracle: {gen.name}", file=sys.stderr)
        r = subprocess.run([sys.executable, str(gen), "--out", str(out)], env=env)
        if r.returncode != 0:
            failed.append(gen.name)
    if failed:
        print(f"oracle: generators failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
