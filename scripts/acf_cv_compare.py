#!/usr/bin/env python3
"""Paired differences over folds between ACF cross-validation runs (scripts/acf_cv.sh).

Each argument is a cv.tsv written by scripts/acf_cv.sh (name, fold, positives, MR at 1e-2,
1e-3, 1e-4 FPPW, training seconds). For every pair (each run against the first, or the pairs
given with --pairs A:B,C:D by name) it prints, at 1e-4 FPPW, the per-fold difference in points
(and in missed positives), the mean, its 95 % Student-t interval over the folds both runs share,
and in how many folds the difference has the sign of the mean.

    scripts/acf_cv_compare.py out/acf_cv/mosaic/cv.tsv out/acf_cv/colour/cv.tsv ...
"""
import argparse
import math
import sys

# two-sided 95 % quantiles of Student's t, by degrees of freedom
T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}


def read(path):
    runs = {}
    with open(path) as f:
        for line in f:
            p = line.rstrip("\n").split("\t")
            if len(p) < 6:
                continue
            name, fold, pos = p[0], int(p[1]), int(p[2])
            mr = [float(v) for v in p[3:6]]
            runs.setdefault(name, {})[fold] = (pos, mr)
    return runs


def compare(a_name, a, b_name, b):
    folds = sorted(set(a) & set(b))
    if not folds:
        print(f"{a_name} − {b_name}: no common fold", file=sys.stderr)
        return
    d, miss = [], []
    for k in folds:
        (pa, ma), (pb, mb) = a[k], b[k]
        if pa != pb:
            sys.exit(f"fold {k}: {pa} positives in {a_name}, {pb} in {b_name}")
        d.append(100.0 * (ma[2] - mb[2]))
        miss.append(round(ma[2] * pa) - round(mb[2] * pb))
    n = len(d)
    mean = sum(d) / n
    line = f"{a_name} − {b_name}, MR @ 1e-4, points: " + ", ".join(
        f"f{k} {v:+.1f} ({m:+d})" for k, v, m in zip(folds, d, miss)
    )
    line += f"; mean {mean:+.2f} ({sum(miss):+d} positives)"
    if n > 1:
        sd = math.sqrt(sum((v - mean) ** 2 for v in d) / (n - 1))
        half = T95.get(n - 1, 1.96) * sd / math.sqrt(n)
        t = mean / (sd / math.sqrt(n)) if sd > 0 else float("inf")
        same = sum(1 for v in d if (v > 0) == (mean > 0) and v != 0)
        line += f", 95 % t [{mean - half:+.2f}, {mean + half:+.2f}], t = {t:.2f} ({n - 1} df), {same} of {n} folds with the mean's sign"
    print(line)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("tsv", nargs="+")
    ap.add_argument("--pairs", default="", help="A:B,C:D: the runs to compare by name (default: each against the first)")
    args = ap.parse_args()
    runs = {}
    for p in args.tsv:
        runs.update(read(p))
    names = list(runs)
    for name in names:
        r = runs[name]
        mrs = [r[k][1][2] for k in sorted(r)]
        print(
            f"{name}: MR @ 1e-4 " + ", ".join(f"f{k} {r[k][1][2]:.3f}" for k in sorted(r))
            + f"; mean {sum(mrs) / len(mrs):.3f} over {len(mrs)} folds"
        )
    pairs = [p.split(":", 1) for p in args.pairs.split(",") if p] if args.pairs else [(n, names[0]) for n in names[1:]]
    for a, b in pairs:
        compare(a, runs[a], b, runs[b])


if __name__ == "__main__":
    main()
