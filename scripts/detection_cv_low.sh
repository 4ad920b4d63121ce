#!/usr/bin/env bash
# K-fold cross-validation of the recipes for noisy sensors (docs/detection.md, "The model for noisy
# sensors, retrained"): for each fold, trains on the other folds at the paper's low noise
#   new: the srgb tone with the free bias (models/mosaic_raw_srgb_low.json's recipe),
#   old: the linear mosaic with bias scale 1 (the recipe of the replaced mosaic_raw_low.json),
# both at C 0.03, and scores them next to the clean-trained srgb fold model of
# scripts/detection_cv.sh (OUT_CLEAN/clean/foldK/mosaic.json, run that first) on clean, low,
# medium and high noise. Prints the per-fold miss rates at 1e-4 FPPW, their means and the paired
# differences (mean, 95 % t interval over folds, folds where the new recipe is no worse).
#
# Environment: MOSAICD (binary, default target/release/mosaicd), OUT (default out/cv_low),
# OUT_CLEAN (default out/cv), FOLDS (default "0 1 2 3 4"), THREADS (default 2), MOSAICD_DATA.
# Time on 2 cores: about 3.5 min per fold.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${MOSAICD:-target/release/mosaicd}
out=${OUT:-out/cv_low}
clean=${OUT_CLEAN:-out/cv}/clean
folds=${FOLDS:-0 1 2 3 4}
threads=${THREADS:-2}
[ -x "$bin" ] || { echo "detection_cv_low: no binary at $bin (cargo build --release)" >&2; exit 2; }
common=(--domain mosaic --input low --seed 1 --neg-per-image 20 --rounds 2 --max-hard 5000 --raw-negatives
        --jitter-positives 2 --threads "$threads" --c 0.03 --no-eval)
for k in $folds; do
  d=$out/fold$k
  mkdir -p "$d"
  [ -s "$clean/fold$k/mosaic.json" ] || { echo "detection_cv_low: no $clean/fold$k/mosaic.json (run scripts/detection_cv.sh clean)" >&2; exit 2; }
  train() { # name, extra flags...
    local name=$1; shift
    [ -s "$d/$name.json" ] && return 0
    echo "detection_cv_low: fold $k: training $name" >&2
    "$bin" train "${common[@]}" --fold "$k" "$@" --out "$d/$name.json" >"$d/train_$name.log" 2>&1 \
      || { echo "detection_cv_low: training $name failed, see $d/train_$name.log" >&2; exit 1; }
  }
  train new --mosaic-tone srgb --bias-scale 10
  train old --bias-scale 1
  echo "detection_cv_low: fold $k: evaluating" >&2
  "$bin" eval detection "$d/new.json=mosaic" "$d/old.json=mosaic" "$clean/fold$k/mosaic.json=mosaic" \
    --inputs clean,low,medium,high --seed 1 --fold "$k" --threads "$threads" --out "$d/eval" >"$d/eval.log" 2>&1 \
    || { echo "detection_cv_low: evaluation failed, see $d/eval.log" >&2; exit 1; }
done
python3 - "$out" $folds <<'PY'
import statistics, sys
out, folds = sys.argv[1], sys.argv[2:]
# two-sided 95 % Student t quantiles by degrees of freedom (as scripts/detection_cv.py)
T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}
rows = {}
for k in folds:
    for line in open(f"{out}/fold{k}/eval/detection.md"):
        c = [x.strip() for x in line.strip().strip("|").split("|")]
        if len(c) < 7 or not c[0].endswith("(Mosaic)"):
            continue
        name = {"new.json": "new", "old.json": "old"}.get(c[0].split()[0].split("/")[-1], "srgb clean")
        rows.setdefault((name, c[2]), []).append(float(c[-1]))
for inp in ["raw-clean", "raw-low", "raw-medium", "raw-high"]:
    print(inp)
    for n in ["new", "old", "srgb clean"]:
        v = rows[(n, inp)]
        print(f"  {n:>10}: " + " ".join(f"{x:.3f}" for x in v) + f"  mean {statistics.mean(v):.3f}")
    for other in ["old", "srgb clean"]:
        d = [a - b for a, b in zip(rows[("new", inp)], rows[(other, inp)])]
        m = statistics.mean(d)
        h = T95.get(len(d) - 1, float("nan")) * statistics.stdev(d) / len(d) ** 0.5 if len(d) > 1 else float("nan")
        print(f"  new - {other}: {m:+.3f} [{m - h:+.3f}, {m + h:+.3f}], no worse in {sum(x <= 0 for x in d)}/{len(d)}")
PY
