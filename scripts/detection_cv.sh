#!/usr/bin/env bash
# K-fold cross-validation of the mosaic-vs-colour training recipes (docs/detection.md,
# "Cross-validated pairs"). For each fold, trains the shipped recipe of each domain on the other
# folds (`mosaicd train --fold K`, the shipped C and jitter: they were chosen on fold 0's inner
# split), scores both on the fold's held-out windows (`mosaicd eval detection --fold K`), and
# summarises the per-fold miss rates and their paired differences (scripts/detection_cv.py).
#
#   scripts/detection_cv.sh sampled   # models/mosaic.json vs models/colour.json (bias scale 1, as trained)
#   scripts/detection_cv.sh clean     # the paper's pair as shipped now: models/mosaic_raw_srgb.json
#                                     # vs models/colour_raw.json (srgb tone, bias scale 10, C 0.03 each)
#   MOSAIC_ARGS= TRAIN_ARGS="--bias-scale 1" C_COLOUR=0.3 scripts/detection_cv.sh clean
#                                     # the linear models/mosaic_raw.json and the colour model before 2026-11-25
# Fold 0 of each default rebuilds the shipped files' weights and bias bit for bit.
#
# Environment: MOSAICD (binary, default target/release/mosaicd), OUT (default out/cv),
# FOLDS (default "0 1 2 3 4"), THREADS (default 2), MOSAICD_DATA (the shared data),
# MOSAIC_ARGS (extra `mosaicd train` flags for the mosaic model; default "--mosaic-tone srgb" for
# `clean`, none for `sampled`; set it empty for none),
# TRAIN_ARGS (extra `mosaicd train` flags for both models; default "--bias-scale 1" for `sampled`,
# none for `clean`, i.e. `mosaicd train`'s bias scale 10),
# C_MOSAIC / C_COLOUR (the SVM cost of each domain, default the shipped recipe's for the input),
# JITTER (`--jitter-positives` of both domains, default 2 as shipped),
# ALSO (more `--inputs` for the same fold models, e.g. "low,medium": scored into foldK/also/ and
# summarised in OUT/INPUT/cv_also.md).
# Models already in OUT/INPUT/foldK/ are reused whatever flags built them, so a variant can share
# the colour models: give each recipe its own OUT.
# Time on 2 cores: about 4 min per fold for `sampled`, 5 min for `clean`.
set -euo pipefail
cd "$(dirname "$0")/.."
input=${1:?usage: scripts/detection_cv.sh sampled|clean}
bin=${MOSAICD:-target/release/mosaicd}
out=${OUT:-out/cv}/$input
folds=${FOLDS:-0 1 2 3 4}
threads=${THREADS:-2}
case $input in
  sampled) c_mosaic=0.03; c_colour=0.03; train_args="--bias-scale 1"; mosaic_args="" ;;
  clean) c_mosaic=0.03; c_colour=0.03; train_args=""; mosaic_args="--mosaic-tone srgb" ;;
  *) echo "detection_cv: input must be sampled or clean, got '$input'" >&2; exit 2 ;;
esac
c_mosaic=${C_MOSAIC:-$c_mosaic}; c_colour=${C_COLOUR:-$c_colour}
# unset: the input's default; set (even empty): as given
TRAIN_ARGS=${TRAIN_ARGS-$train_args}; MOSAIC_ARGS=${MOSAIC_ARGS-$mosaic_args}
[ -x "$bin" ] || { echo "detection_cv: no binary at $bin (cargo build --release)" >&2; exit 2; }
common=(--seed 1 --neg-per-image 20 --rounds 2 --max-hard 5000 --raw-negatives --jitter-positives "${JITTER:-2}"
        --threads "$threads" --input "$input")
for k in $folds; do
  d=$out/fold$k
  mkdir -p "$d"
  for dom in mosaic colour; do
    c=$c_mosaic; [ "$dom" = colour ] && c=$c_colour
    if [ ! -s "$d/$dom.json" ]; then
      echo "detection_cv: fold $k: training $dom (C $c)" >&2
      extra=(); [ "$dom" = mosaic ] && read -r -a extra <<<"${MOSAIC_ARGS:-}"
      both=(); read -r -a both <<<"${TRAIN_ARGS:-}"
      "$bin" train --domain "$dom" --c "$c" --fold "$k" --out "$d/$dom.json" "${common[@]}" \
        "${both[@]}" "${extra[@]}" >"$d/train_$dom.log" 2>&1
    fi
  done
  echo "detection_cv: fold $k: evaluating" >&2
  "$bin" eval detection "$d/mosaic.json=mosaic" "$d/colour.json=colour" "$d/colour.json=mosaic" \
    "$d/mosaic.json=colour" --inputs "$input" --seed 1 --fold "$k" --threads "$threads" \
    --out "$d/eval" >"$d/eval.log" 2>&1
  if [ -n "${ALSO:-}" ]; then
    echo "detection_cv: fold $k: evaluating on $ALSO" >&2
    "$bin" eval detection "$d/mosaic.json=mosaic" "$d/colour.json=colour" --inputs "$ALSO" --seed 1 \
      --fold "$k" --threads "$threads" --out "$d/also" >"$d/also.log" 2>&1
  fi
done
python3 scripts/detection_cv.py "$out"
if [ -n "${ALSO:-}" ]; then python3 scripts/detection_cv.py "$out" also; fi
