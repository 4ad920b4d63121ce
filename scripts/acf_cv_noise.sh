#!/usr/bin/env bash
# K-fold cross-validation of ACF under the paper's noise levels (docs/acf.md, "Under the paper's
# noise levels"). For each fold, trains on the other folds (seed 1, the full schedule, cascade −8
# in training, no rejection trace: each model rejects with the constant −8)
#   acf_low:    ACF mosaic, reverse ISP to raw with the paper's low noise, srgb tone
#               (docs/acf.md's ACF low; not shipped),
#   acf_clean:  ACF mosaic, clean raw, srgb tone (models/acf-mosaic.json's recipe, without its trace),
#   acf_colour: ACF colour on the sRGB itself (models/acf-colour.json's recipe, without its trace),
#   hog_low:    HOG mosaic at low noise (models/mosaic_raw_srgb_low.json's recipe at C 0.03, as
#               scripts/detection_cv_low.sh trains it),
# and scores all four on the fold's held-out windows (`mosaicd eval detection --fold K`) on clean,
# low, medium and high raw inputs: the mosaic models read the raw frame, the colour model the
# forward ISP's colour output of it. The three ACF models are also scored without a cascade (copies
# with casc_thr −1e30: every window runs all 2 048 trees), to separate what the cascade rejects
# from what the trees score. With TRACE=1 (the default) the two mosaic models also get the
# calibrated rejection trace of the shipped files (an inner-split model each) and are scored with it.
# With COLOUR_LOW=1 (the default) an ACF colour model trained at low noise (the ISP's colour output
# of the noisy training frames, `--domain colour --input low`) is trained and scored too.
# Prints the per-fold miss rates at 1e-2 / 1e-3 / 1e-4 FPPW,
# their means and the paired differences (mean, 95 % t interval over folds, folds where the first
# model misses no more). ACF's FPPW is per window of its own scan (stride 4 px), HOG's of its own.
#
# Environment: MOSAICD (binary, default target/release/mosaicd), OUT (default out/acf_cv_noise),
# FOLDS (default "0 1 2 3 4"), THREADS (default 2), COLOUR_LOW (default 1), TRACE (default 1;
# 0: no traces), TRACE_MODELS (default "acf_low acf_clean": which mosaic models get a trace),
# MOSAICD_DATA.
# Models already in OUT/foldK/ are reused. Time on 2 cores at load 4–11: about 10 min per fold,
# 1.5 min more per traced model.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${MOSAICD:-target/release/mosaicd}
out=${OUT:-out/acf_cv_noise}
folds=${FOLDS:-0 1 2 3 4}
threads=${THREADS:-2}
trace_models=${TRACE_MODELS:-acf_low acf_clean}
[ -x "$bin" ] || { echo "acf_cv_noise: no binary at $bin (cargo build --release)" >&2; exit 2; }
acf=(--detector acf --seed 1 --acf-casc-thr -8 --acf-trace none --no-eval --threads "$threads")
low=(--domain mosaic --input low --mosaic-tone srgb)
clean=(--domain mosaic --input clean --mosaic-tone srgb)
hog=(--domain mosaic --input low --mosaic-tone srgb --seed 1 --neg-per-image 20 --rounds 2 --max-hard 5000
     --raw-negatives --jitter-positives 2 --bias-scale 10 --c 0.03 --no-eval --threads "$threads")
for k in $folds; do
  d=$out/fold$k
  mkdir -p "$d"
  train() { # name, flags...
    local name=$1; shift
    [ -s "$d/$name.json" ] && return 0
    echo "acf_cv_noise: fold $k: training $name ($(date -u +%T))" >&2
    "$bin" train "$@" --fold "$k" --out "$d/$name.json" >"$d/train_$name.log" 2>&1 \
      || { echo "acf_cv_noise: training $name failed, see $d/train_$name.log" >&2; exit 1; }
  }
  train acf_low "${acf[@]}" "${low[@]}"
  train acf_clean "${acf[@]}" "${clean[@]}"
  train acf_colour "${acf[@]}" --domain colour --input sampled
  train hog_low "${hog[@]}"
  if [ ! -s "$d/eval/detection.md" ]; then
    echo "acf_cv_noise: fold $k: evaluating ($(date -u +%T))" >&2
    "$bin" eval detection "$d/acf_low.json=mosaic" "$d/acf_clean.json=mosaic" "$d/acf_colour.json=colour" \
      "$d/hog_low.json=mosaic" --inputs clean,low,medium,high --seed 1 --fold "$k" --threads "$threads" \
      --out "$d/eval" >"$d/eval.log" 2>&1 \
      || { echo "acf_cv_noise: evaluation failed, see $d/eval.log" >&2; exit 1; }
  fi
  if [ ! -s "$d/eval_nocasc/detection.md" ]; then
    for m in acf_low acf_clean acf_colour; do
      python3 -c 'import json, sys
m = json.load(open(sys.argv[1])); m["casc_thr"] = -1e30; m.pop("casc_trace", None)
json.dump(m, open(sys.argv[2], "w"))' "$d/$m.json" "$d/${m}_nc.json"
    done
    echo "acf_cv_noise: fold $k: evaluating without a cascade ($(date -u +%T))" >&2
    "$bin" eval detection "$d/acf_low_nc.json=mosaic" "$d/acf_clean_nc.json=mosaic" "$d/acf_colour_nc.json=colour" \
      --inputs clean,low,medium,high --seed 1 --fold "$k" --threads "$threads" \
      --out "$d/eval_nocasc" >"$d/eval_nocasc.log" 2>&1 \
      || { echo "acf_cv_noise: evaluation failed, see $d/eval_nocasc.log" >&2; exit 1; }
  fi
  if [ "${COLOUR_LOW:-1}" != 0 ]; then
    # ACF colour trained like ACF low: the ISP's colour output of the noisy training frames
    train acf_colour_low "${acf[@]}" --domain colour --input low
    if [ ! -s "$d/eval_colour_low/detection.md" ]; then
      echo "acf_cv_noise: fold $k: evaluating acf_colour_low ($(date -u +%T))" >&2
      "$bin" eval detection "$d/acf_colour_low.json=colour" --inputs clean,low,medium,high --seed 1 --fold "$k" \
        --threads "$threads" --out "$d/eval_colour_low" >"$d/eval_colour_low.log" 2>&1 \
        || { echo "acf_cv_noise: evaluation failed, see $d/eval_colour_low.log" >&2; exit 1; }
    fi
  fi
  [ "${TRACE:-1}" = 0 ] && continue
  # the calibrated rejection trace, as the shipped files get it: a model of the same recipe on the
  # fold's inner split, the trace calibrated on its inner held-out positives (floor −10, loss 0,
  # margin 1), stored in the fold model (trees unchanged)
  for m in $trace_models; do
    case $m in acf_low) args=("${low[@]}") ;; acf_clean) args=("${clean[@]}") ;; *) echo "acf_cv_noise: TRACE_MODELS: $m?" >&2; exit 2 ;; esac
    train "${m}_inner" "${acf[@]}" "${args[@]}" --acf-inner
    train "${m}_trace" --detector acf --seed 1 --threads "$threads" "${args[@]}" --acf-inner --acf-trace=-10,0,1 \
      --acf-calibrate "$d/${m}_inner.json" --acf-calibrate-into "$d/$m.json"
    e=$d/eval_trace_$m
    [ -s "$e/detection.md" ] && continue
    echo "acf_cv_noise: fold $k: evaluating $m with its trace ($(date -u +%T))" >&2
    "$bin" eval detection "$d/${m}_trace.json=mosaic" --inputs clean,low,medium,high --seed 1 --fold "$k" \
      --threads "$threads" --out "$e" >"$e.log" 2>&1 \
      || { echo "acf_cv_noise: evaluation failed, see $e.log" >&2; exit 1; }
  done
done
python3 - "$out" $folds <<'PY'
import os, statistics, sys
out, folds = sys.argv[1], sys.argv[2:]
# two-sided 95 % Student t quantiles by degrees of freedom (as scripts/detection_cv.py)
T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262}
names = ["acf_low", "acf_clean", "acf_colour", "hog_low", "acf_low_nc", "acf_clean_nc", "acf_colour_nc",
         "acf_colour_low", "acf_low_trace", "acf_clean_trace"]
rows = {}  # (model, input) -> [(mr 1e-2, 1e-3, 1e-4) per fold]
for k in folds:
    for ev in ["eval", "eval_nocasc", "eval_colour_low", "eval_trace_acf_low", "eval_trace_acf_clean"]:
        if not os.path.exists(f"{out}/fold{k}/{ev}/detection.md"):
            continue
        for line in open(f"{out}/fold{k}/{ev}/detection.md"):
            c = [x.strip() for x in line.strip().strip("|").split("|")]
            if len(c) < 7 or not c[2].startswith("raw-"):
                continue
            name = c[0].split()[0].split("/")[-1].removesuffix(".json")
            if name in names:
                rows.setdefault((name, c[2]), []).append(tuple(float(x) for x in c[-3:]))
def pair(a, b, i):
    d = [x[i] - y[i] for x, y in zip(a, b)]
    m = statistics.mean(d)
    h = T95.get(len(d) - 1, float("nan")) * statistics.stdev(d) / len(d) ** 0.5 if len(d) > 1 else float("nan")
    return f"{m:+.3f} [{m - h:+.3f}, {m + h:+.3f}], {sum(x <= 0 for x in d)}/{len(d)}"
print(f"folds {' '.join(folds)}; MR @ 1e-2 / 1e-3 / 1e-4 FPPW per fold, then the mean")
for inp in ["raw-clean", "raw-low", "raw-medium", "raw-high"]:
    print(inp)
    for n in names:
        v = rows.get((n, inp), [])
        if len(v) != len(folds):
            continue
        per = "  ".join("/".join(f"{x:.3f}" for x in f) for f in v)
        mean = " / ".join(f"{statistics.mean(f[i] for f in v):.3f}" for i in range(3))
        print(f"  {n:>10}: {per}   mean {mean}")
    for a, b in [("acf_low", "acf_clean"), ("acf_low", "hog_low"), ("acf_clean", "hog_low"),
                 ("acf_colour", "acf_clean"), ("acf_colour", "acf_low"),
                 ("acf_low_nc", "acf_clean_nc"), ("acf_low_nc", "hog_low"), ("acf_clean_nc", "hog_low"),
                 ("acf_colour_nc", "acf_clean_nc"), ("acf_low_trace", "acf_clean_trace"),
                 ("acf_low_trace", "hog_low"), ("acf_low_trace", "acf_low"),
                 ("acf_colour_low", "acf_low"), ("acf_colour_low", "hog_low"),
                 ("acf_clean_trace", "acf_clean"), ("acf_clean_trace", "hog_low")]:
        if any(len(rows.get((n, inp), [])) != len(folds) for n in (a, b)):
            continue
        print(f"  {a} - {b} at 1e-4: {pair(rows[(a, inp)], rows[(b, inp)], 2)}"
              f"; at 1e-3: {pair(rows[(a, inp)], rows[(b, inp)], 1)}")
PY
