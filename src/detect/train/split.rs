//! Splits and folds: which photos train and which are held out.
//!
//! The validation split holds out whole photos (the file name without its trailing letter, which
//! also groups the mirrors: [`photo_prefix`]); negatives are split by a seeded shuffle. Fold `k` of
//! `n = round(1 / val_fraction)` holds out the `k`-th of `n` equal ranges of each shuffled list, so
//! the folds partition the data ([`fold_count`]); [`inner_split`] splits a training set again (for
//! choosing the SVM's cost without touching the held-out photos).

use std::path::{Path, PathBuf};

use super::error::TrainError;
use rand::seq::SliceRandom;
use rand::SeedableRng;

/// Kodak images that show people (never negatives).
pub(crate) const KODAK_WITH_PEOPLE: [u32; 6] = [4, 5, 12, 14, 15, 18];
/// Mixed into the seed of [`inner_split`].
const INNER_SPLIT_SALT: u64 = 0x696e_6e65_725f_7631;

/// Files of a train/validation split.
#[derive(Debug, Clone, Default)]
pub struct Split {
    /// Training positives.
    pub train_pos: Vec<PathBuf>,
    /// Validation positives (photos disjoint from training).
    pub val_pos: Vec<PathBuf>,
    /// Training negative images.
    pub train_neg: Vec<PathBuf>,
    /// Validation negative images.
    pub val_neg: Vec<PathBuf>,
    /// Training-only negative images (`mosaicd train --negatives-dir`, e.g. scikit-image's
    /// person-free photographs): never split, never held out, so the validation files stay those of
    /// [`split_data`] with or without them. [`inner_split`] keeps them on its training side.
    pub extra_train_neg: Vec<PathBuf>,
}

/// Photo prefix of an INRIA crop file name: the stem without its trailing letter.
pub fn photo_prefix(name: &str) -> &str {
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
    stem.trim_end_matches(|c: char| c.is_ascii_alphabetic())
}

/// The PNG and JPEG files of `dirs`, each directory's sorted by name, in the order of `dirs`: the
/// training-only negatives of [`Split::extra_train_neg`]. A directory that cannot be read or holds
/// no image is an error.
pub fn list_negative_dirs(dirs: &[PathBuf]) -> Result<Vec<PathBuf>, TrainError> {
    let mut out = Vec::new();
    for dir in dirs {
        let v = list(dir)?;
        if v.is_empty() {
            return Err(TrainError::Data {
                path: dir.clone(),
                what: "no PNG or JPEG images in this directory".into(),
            });
        }
        out.extend(v);
    }
    Ok(out)
}

fn list(dir: &Path) -> Result<Vec<PathBuf>, TrainError> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| TrainError::Data {
            path: dir.into(),
            what: e.to_string(),
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("png" | "jpg" | "jpeg" | "PNG" | "JPG")
            )
        })
        .collect();
    v.sort();
    Ok(v)
}

/// The seeded split of the shared data (`data_root`: the directory holding `pedestrian/`, `kodak/`).
///
/// Photo prefixes and negative images are shuffled with `seed`; fold `k` holds out the `k`-th
/// block of `val_fraction` of each, `[round(k·f·n), round((k+1)·f·n))`. Folds `0 .. ⌊1/f⌋` are
/// disjoint, so at `f = 0.2` folds 0–4 are a 5-fold cross-validation in which every photo and
/// every negative image is held out once; fold 0 is the split the shipped models use.
pub fn split_data(data_root: &Path, seed: u64, val_fraction: f64, fold: usize) -> Result<Split, TrainError> {
    check_fold(val_fraction, fold)?;
    let pos = list(&data_root.join("pedestrian/inria_pos_96x160"))?;
    let mut neg = list(&data_root.join("pedestrian/neg_inria"))?;
    neg.extend(list(&data_root.join("pedestrian/neg"))?);
    for k in 1..=24u32 {
        if !KODAK_WITH_PEOPLE.contains(&k) {
            neg.push(data_root.join(format!("kodak/kodim{k:02}.png")));
        }
    }
    Ok(split_lists(pos, neg, seed, val_fraction, fold))
}

/// Number of disjoint folds at held-out fraction `val_fraction`: `⌊1/f⌋` (with a little slack for
/// `f` like 0.2 that is not exact in binary), 1 at `f = 0` (nothing held out: train on
/// everything), 0 outside `[0, 1)`.
pub(crate) fn fold_count(val_fraction: f64) -> usize {
    if val_fraction == 0.0 {
        1
    } else if val_fraction > 0.0 && val_fraction < 1.0 {
        (1.0 / val_fraction + 1e-9).floor() as usize
    } else {
        0
    }
}

fn check_fold(val_fraction: f64, fold: usize) -> Result<(), TrainError> {
    if !(0.0..1.0).contains(&val_fraction) {
        return Err(TrainError::BadOption {
            what: "val_fraction",
            value: val_fraction.to_string(),
            allowed: "0 <= fraction < 1",
        });
    }
    if fold >= fold_count(val_fraction) {
        return Err(TrainError::BadOption {
            what: "fold",
            value: format!(
                "{fold} (held-out fraction {val_fraction}: folds 0..{})",
                fold_count(val_fraction)
            ),
            allowed: "0 <= fold < floor(1 / held-out fraction)",
        });
    }
    Ok(())
}

/// Split the *training* part of `split` once more, the same way (positives by photo prefix,
/// negatives by image), for model selection; `split`'s own validation files are not used, and its
/// training-only negatives stay training-only.
pub fn inner_split(split: &Split, seed: u64, val_fraction: f64) -> Split {
    Split {
        extra_train_neg: split.extra_train_neg.clone(),
        ..split_lists(
            split.train_pos.clone(),
            split.train_neg.clone(),
            seed ^ INNER_SPLIT_SALT,
            val_fraction,
            0,
        )
    }
}

/// The fraction [`super::select_c`] holds out of the training files: the outer `val_fraction`, or 0.2
/// (the default split) when nothing is held out outside (`val_fraction` 0: a model trained on
/// every file still chooses its C on an inner split).
pub fn inner_val_fraction(val_fraction: f64) -> f64 {
    if val_fraction > 0.0 {
        val_fraction
    } else {
        0.2
    }
}

/// The held-out block `[round(k·f·n), round((k+1)·f·n))` of `n` shuffled items.
fn fold_range(n: usize, val_fraction: f64, fold: usize) -> std::ops::Range<usize> {
    let at = |k: usize| ((n as f64 * val_fraction * k as f64).round() as usize).min(n);
    at(fold)..at(fold + 1)
}

/// Seeded split of positives (`pos` sorted by name, grouped by photo prefix) and negatives; fold
/// `fold` of [`split_data`].
pub(super) fn split_lists(
    pos: Vec<PathBuf>,
    mut neg: Vec<PathBuf>,
    seed: u64,
    val_fraction: f64,
    fold: usize,
) -> Split {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut prefixes: Vec<String> = pos
        .iter()
        .filter_map(|p| p.file_name()?.to_str().map(|n| photo_prefix(n).to_string()))
        .collect();
    prefixes.dedup();
    prefixes.shuffle(&mut rng);
    let val: std::collections::HashSet<&str> = prefixes[fold_range(prefixes.len(), val_fraction, fold)]
        .iter()
        .map(|s| s.as_str())
        .collect();
    let mut s = Split::default();
    for p in pos {
        let n = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if val.contains(photo_prefix(n)) {
            s.val_pos.push(p);
        } else {
            s.train_pos.push(p);
        }
    }
    neg.shuffle(&mut rng);
    let r = fold_range(neg.len(), val_fraction, fold);
    s.val_neg = neg[r.clone()].to_vec();
    s.train_neg = neg[..r.start].iter().chain(&neg[r.end..]).cloned().collect();
    s
}
