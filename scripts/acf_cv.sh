#!/usr/bin/env bash
# K-fold cross-validation of an ACF training recipe in the window protocol (docs/acf.md,
# "Cross-validation", "ACF on grey", "Channel ablation"). For each fold, trains the recipe on the
# other folds without a rejection trace (`mosaicd train --detector acf --fold K --no-eval
# --acf-trace none`), then evaluates it on the fold's held-out windows without a cascade
# (`--acf-evaluate MODEL --acf-casc-thr -1e30`: every tree, the rows "no cascade" of docs/acf.md).
# Prints one line per fold (miss rate at FPPW 1e-2, 1e-3, 1e-4) and writes them to
# OUT/NAME/cv.tsv.
#
#   scripts/acf_cv.sh mosaic --domain mosaic                   # docs/acf.md's mosaic row
#   scripts/acf_cv.sh colour --domain colour --input sampled   # its colour row
#   scripts/acf_cv.sh grey --domain grey --input sampled       # ACF on grey
#   scripts/acf_cv.sh mosaic-grad --domain mosaic --acf-drop-colour   # channel ablation
#
# Every argument after NAME goes to both `mosaicd train` calls (the recipe; the evaluation needs
# the same domain and input). Environment: MOSAICD (binary, default target/release/mosaicd),
# OUT (default out/acf_cv), FOLDS (default "0 1 2 3 4"), THREADS (default 2), MOSAICD_DATA (the
# shared data). A model already in OUT/NAME/ is reused whatever flags built it: give each recipe
# its own NAME. Time on 2 cores: about 4 min per fold to train, 1 min to evaluate.
set -euo pipefail
cd "$(dirname "$0")/.."
name=${1:?usage: scripts/acf_cv.sh NAME TRAIN_FLAGS...}
shift
bin=${MOSAICD:-target/release/mosaicd}
out=${OUT:-out/acf_cv}/$name
folds=${FOLDS:-0 1 2 3 4}
threads=${THREADS:-2}
mkdir -p "$out"
for f in $folds; do
  model=$out/cv_f$f.json
  if [ ! -f "$model" ]; then
    nice -n 10 "$bin" train --detector acf --fold "$f" --out "$model.tmp" --no-eval --acf-trace none \
      --threads "$threads" "$@" 2>"$out/train_f$f.log"
    mv "$model.tmp" "$model"
  fi
  line=$(nice -n 10 "$bin" train --detector acf --fold "$f" --out /dev/null --acf-evaluate "$model" \
    --acf-casc-thr -1e30 --threads "$threads" "$@" 2>"$out/eval_f$f.log" | grep 'miss rate at FPPW')
  # "...: 374 positives, N negative windows, miss rate at FPPW [(0.01, a), (0.001, b), (0.0001, c)]"
  mr=$(sed -E 's/.*\[\(0\.01, ([^)]*)\), \(0\.001, ([^)]*)\), \(0\.0001, ([^)]*)\)\].*/\1\t\2\t\3/' <<<"$line")
  pos=$(sed -E 's/.*: ([0-9]+) positives.*/\1/' <<<"$line")
  secs=$(sed -nE 's/^training took ([0-9.]+) s.*/\1/p' "$out/train_f$f.log")
  printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$f" "$pos" "$mr" "${secs:-?}" | tee -a "$out/cv.tsv"
done
