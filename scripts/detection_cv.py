#!/usr/bin/env python3
"""Summarise scripts/detection_cv.sh: per-fold window-protocol miss rates and the paired
difference mosaic-on-mosaic minus colour-on-colour, with a t interval over the folds.

Reads OUT/fold*/EVAL_DIR/detection.md (the tables `mosaicd eval detection` writes; EVAL_DIR
defaults to `eval`) and prints a Markdown report, one paired table per input pipeline; also
writes it to OUT/cv.md (OUT/cv_EVAL_DIR.md). Standard library only.
"""
import math
import pathlib
import re
import statistics
import sys

# Two-sided 95 % Student t quantiles by degrees of freedom (folds - 1).
T975 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}
RATES = ["MR@1e-2", "MR@1e-3", "MR@1e-4"]


def rows_of(md: pathlib.Path):
    """{(model file stem, input domain, pipeline): [mr2, mr3, mr4]} and the table's title."""
    text = md.read_text()
    title = next((l.strip().strip("*") for l in text.splitlines() if l.startswith("**Window protocol")), "")
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 7 or not re.fullmatch(r"[0-9.]+", cells[4]):
            continue
        model = pathlib.Path(cells[0].split(" (")[0]).stem
        out[(model, cells[1], cells[2])] = [float(c) for c in cells[4:7]]
    return out, title


def interval(xs):
    m = statistics.fmean(xs)
    if len(xs) < 2:
        return m, float("nan")
    return m, T975.get(len(xs) - 1, 1.96) * statistics.stdev(xs) / math.sqrt(len(xs))


def main(root: pathlib.Path, eval_dir: str = "eval") -> int:
    out_name = "cv.md" if eval_dir == "eval" else f"cv_{eval_dir}.md"
    folds = sorted(root.glob(f"fold*/{eval_dir}/detection.md"), key=lambda p: int(p.parts[-3][4:]))
    if not folds:
        print(f"detection_cv: no fold*/{eval_dir}/detection.md under {root}", file=sys.stderr)
        return 2
    per = []
    lines = [f"# Cross-validated window protocol: {root.name}", ""]
    for md in folds:
        rows, title = rows_of(md)
        per.append((md.parts[-3], rows, title))
        lines.append(f"- {md.parts[-3]}: {title}")
    keys = sorted(set.intersection(*(set(r) for _, r, _ in per)))
    lines += ["", "| model | input | pipeline | " + " | ".join(f"{f} MR@1e-4" for f, _, _ in per)
              + " | mean MR@1e-2 | mean MR@1e-3 | mean MR@1e-4 (95 % t) |",
              "|" + "---|" * (len(per) + 6)]
    for k in keys:
        vals = [r[k] for _, r, _ in per]
        means = [interval([v[i] for v in vals]) for i in range(3)]
        lines.append(f"| {k[0]} | {k[1]} | {k[2]} | " + " | ".join(f"{v[2]:.3f}" for v in vals)
                     + f" | {means[0][0]:.3f} | {means[1][0]:.3f} | {means[2][0]:.3f} ± {means[2][1]:.3f} |")
    for pipeline in sorted({k[2] for k in keys}):
        pair = (("mosaic", "mosaic", pipeline), ("colour", "colour", pipeline))
        if not all(p in keys for p in pair):
            continue
        lines += ["", f"Paired difference on `{pipeline}`, mosaic model on mosaic minus colour model on "
                  "colour (per fold; negative = the mosaic misses fewer):", "",
                  "| rate | " + " | ".join(f for f, _, _ in per) + " | mean (95 % t) | folds with mosaic ≤ colour |",
                  "|" + "---|" * (len(per) + 3)]
        for i, name in enumerate(RATES):
            d = [r[pair[0]][i] - r[pair[1]][i] for _, r, _ in per]
            m, h = interval(d)
            lines.append(f"| {name} | " + " | ".join(f"{x:+.3f}" for x in d)
                         + f" | {m:+.3f} [{m - h:+.3f}, {m + h:+.3f}] | {sum(x <= 0 for x in d)} / {len(d)} |")
    report = "\n".join(lines) + "\n"
    (root / out_name).write_text(report)
    print(report, end="")
    return 0


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        print("usage: detection_cv.py OUT/INPUT [EVAL_DIR]", file=sys.stderr)
        sys.exit(2)
    sys.exit(main(pathlib.Path(sys.argv[1]), *sys.argv[2:]))
