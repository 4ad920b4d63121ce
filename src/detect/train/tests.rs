//! Tests of the trainer (splits, domains, windows, SVM training).

use std::path::Path;

use rand::seq::SliceRandom;
use rand::Rng;

use super::split::split_lists;
use super::windows::rank_negatives;
use super::*;
use crate::isp::NoiseLevel;
use crate::metrics::detection::det_curve;
use crate::metrics::interval::Interval;

/// Scores of `images` negative images with `per` windows each and `photos` photos of two crops
/// each, from a fixed generator.
fn window_scores(
    images: usize,
    per: usize,
    photos: usize,
    shift: f32,
    seed: u64,
) -> (WindowScores, Vec<f32>) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let neg: Vec<f32> = (0..images * per)
        .map(|_| (rng.random::<f32>() * 4.0 - 2.0).round() / 2.0)
        .collect();
    let positives: Vec<f32> = (0..2 * photos)
        .map(|_| rng.random::<f32>() * 3.0 - 1.0 + shift)
        .collect();
    let windows_per_image = vec![per; images];
    let scores = WindowScores {
        positive_photo: (0..2 * photos as u32).map(|i| i / 2).collect(),
        positives,
        top_negatives: rank_negatives(&neg, &windows_per_image).1,
        windows_per_image,
    };
    (scores, neg)
}

#[test]
fn weighted_miss_rate_equals_the_plain_one_and_duplicated_files() {
    // 20 000 windows, scores on a coarse grid so that ties cross the kept cut.
    let (w, neg) = window_scores(40, 500, 30, 0.0, 3);
    assert!(w.top_negatives.len() < neg.len(), "the cut keeps a part");
    let mut sorted = neg.clone();
    sorted.sort_by(|a, b| b.total_cmp(a));
    assert_eq!(rank_negatives(&neg, &[500; 40]).0, sorted);
    let ones_p = vec![1; 30];
    let ones_i = vec![1; 40];
    for f in [0.0, 1e-4, 1e-3, 5e-3, 1e-2] {
        assert_eq!(
            w.weighted_miss_rate(&ones_p, &ones_i, f).unwrap(),
            miss_rate_at_fppw(&w.positives, &sorted, f),
            "fppw {f}"
        );
    }
    // Weights equal duplicating the files (and 0 dropping them).
    let mut photo_w = vec![1u32; 30];
    photo_w[3] = 3;
    photo_w[7] = 0;
    let mut image_w = vec![1u32; 40];
    image_w[0] = 2;
    image_w[5] = 0;
    let mut pos = Vec::new();
    for (i, &s) in w.positives.iter().enumerate() {
        for _ in 0..photo_w[i / 2] {
            pos.push(s);
        }
    }
    let mut dup = Vec::new();
    for (i, chunk) in neg.chunks(500).enumerate() {
        for _ in 0..image_w[i] {
            dup.extend_from_slice(chunk);
        }
    }
    dup.sort_by(|a, b| b.total_cmp(a));
    for f in [1e-4, 1e-3, 1e-2] {
        assert_eq!(
            w.weighted_miss_rate(&photo_w, &image_w, f).unwrap(),
            miss_rate_at_fppw(&pos, &dup, f),
            "fppw {f}"
        );
    }
}

#[test]
fn window_bootstrap_is_paired_reproducible_and_checks_its_input() {
    let (a, _) = window_scores(30, 400, 40, 0.0, 5);
    let (b, _) = window_scores(30, 400, 40, 0.8, 6);
    let rows = [&a, &b];
    let f = [1e-3, 1e-2];
    let r1 = window_bootstrap(&rows, 0, &f, 200, 9).unwrap();
    assert_eq!(r1, window_bootstrap(&rows, 0, &f, 200, 9).unwrap());
    assert_ne!(r1, window_bootstrap(&rows, 0, &f, 200, 10).unwrap());
    // The reference against itself: a zero difference on every draw.
    assert_eq!(r1[0].diff, vec![Interval { lo: 0.0, hi: 0.0 }; 2]);
    assert_eq!(r1[0].not_worse, vec![1.0; 2]);
    // Row b's positives score 0.8 higher: it misses less on every draw.
    for (j, &fj) in f.iter().enumerate() {
        assert!(r1[1].diff[j].hi < 0.0, "{:?}", r1[1].diff);
        assert_eq!(r1[1].not_worse[j], 1.0);
        let plain = a.weighted_miss_rate(&[1; 40], &[1; 30], fj).unwrap();
        assert!(r1[0].miss_rate[j].lo <= plain && plain <= r1[0].miss_rate[j].hi);
    }
    // Bad input: no resamples, a reference past the rows, an FPPW above the kept range, rows
    // over different files.
    assert!(window_bootstrap(&rows, 0, &f, 0, 9).is_err());
    assert!(window_bootstrap(&rows, 2, &f, 10, 9).is_err());
    assert!(window_bootstrap(&rows, 0, &[0.05], 10, 9).is_err());
    let (c, _) = window_scores(31, 400, 40, 0.0, 5);
    assert!(window_bootstrap(&[&a, &c], 0, &f, 10, 9).is_err());
}

#[test]
fn miss_rate_by_hand() {
    let neg = [5.0, 4.0, 3.0, 2.0, 1.0, 0.0, -1.0, -2.0, -3.0, -4.0];
    let pos = [4.5, 3.5, 2.5, 0.5];
    // FPPW 0.1 → 1 false positive allowed → threshold at 4.0: positives > 4.0: one.
    assert_eq!(miss_rate_at_fppw(&pos, &neg, 0.1), 0.75);
    assert_eq!(miss_rate_at_fppw(&pos, &neg, 0.3), 0.25);
}

#[test]
fn thinned_det_curve_keeps_ends_and_shape() {
    let pos: Vec<f32> = (0..100).map(|i| i as f32 / 10.0).collect();
    let neg: Vec<f32> = (0..10_000).map(|i| -(i as f32) / 1000.0).collect();
    let full = det_curve(&pos, &neg).unwrap();
    let thin = thin_det_curve(&full, 50);
    assert!(thin.len() <= 52 && thin.len() > 10, "{}", thin.len());
    assert_eq!(thin.first().map(|p| p.fppw), Some(0.0));
    assert_eq!(thin.last(), full.last());
    // Monotone like the full curve, and every kept point is a point of the full curve.
    assert!(thin
        .windows(2)
        .all(|w| w[1].fppw > w[0].fppw && w[1].miss_rate <= w[0].miss_rate));
    assert!(thin.iter().all(|p| full.contains(p)));
}

#[test]
fn reverse_isp_inputs_are_seeded_and_noisy() {
    let rgb = Image::from_fn(32, 24, |x, y| [(x * 7) as u8, (y * 9) as u8, 128]);
    let noisy = |seed, index| {
        let p = InputPipeline::ReverseIsp {
            noise: Some(NoiseLevel::High),
            seed,
        };
        DomainImage::from_rgb_via(&rgb, Domain::Mosaic, Cfa::Rggb, &p, index, &MosaicPrep::default()).unwrap()
    };
    let clean = DomainImage::from_rgb_via(
        &rgb,
        Domain::Mosaic,
        Cfa::Rggb,
        &InputPipeline::ReverseIsp { noise: None, seed: 1 },
        0,
        &MosaicPrep::default(),
    )
    .unwrap();
    let px = |d: &DomainImage| match d {
        DomainImage::Mosaic(m) => m.as_slice().to_vec(),
        _ => unreachable!(),
    };
    assert_eq!(
        px(&noisy(1, 0)),
        px(&noisy(1, 0)),
        "same seed and index: same image"
    );
    assert_ne!(
        px(&noisy(1, 0)),
        px(&noisy(1, 1)),
        "another image index: another noise"
    );
    assert_ne!(px(&noisy(1, 0)), px(&clean));
    // Colour through the forward ISP keeps the size (cropped to even).
    let c = DomainImage::from_rgb_via(
        &rgb,
        Domain::Colour,
        Cfa::Rggb,
        &InputPipeline::ReverseIsp { noise: None, seed: 1 },
        0,
        &MosaicPrep::default(),
    )
    .unwrap();
    assert_eq!(c.dimensions(), (32, 24));
}

#[test]
fn srgb_tone_undoes_the_raw_frames_white_balance_and_curve_per_site() {
    // mid grey through the reverse ISP: the raw R and B sites are darker than G (no white
    // balance) and linear; the srgb tone brings every site back to the grey's code
    let rgb = Image::from_fn(32, 24, |_, _| [128u8; 3]);
    let pipe = InputPipeline::ReverseIsp { noise: None, seed: 1 };
    let mosaic =
        |prep: MosaicPrep| match DomainImage::from_rgb_via(&rgb, Domain::Mosaic, Cfa::Rggb, &pipe, 0, &prep)
            .unwrap()
        {
            DomainImage::Mosaic(m) => m,
            _ => unreachable!(),
        };
    let lin = mosaic(MosaicPrep::default());
    let (r, g, b) = (lin.get(0, 0), lin.get(1, 0), lin.get(1, 1));
    assert!(
        r < 0.8 * g && b < 0.5 * g && g < 0.3 * 255.0,
        "linear R {r} G {g} B {b}"
    );
    for gains in [Gains::FromFile, Gains::Auto, Gains::GreyWorld] {
        let s = mosaic(MosaicPrep {
            tone: MosaicTone::Srgb,
            gains,
        });
        for &v in s.as_slice() {
            assert!((v - 128.0).abs() < 1.5, "{gains:?}: {v}");
        }
    }
    // a sampled mosaic is already sRGB: the tone does not apply
    let sampled = |prep| {
        DomainImage::from_rgb_via(&rgb, Domain::Mosaic, Cfa::Rggb, &InputPipeline::Sampled, 0, &prep).unwrap()
    };
    let px = |d: DomainImage| match d {
        DomainImage::Mosaic(m) => m.into_vec(),
        _ => unreachable!(),
    };
    assert_eq!(
        px(sampled(MosaicPrep::with_tone(MosaicTone::Srgb))),
        px(sampled(MosaicPrep::default()))
    );
}

#[test]
fn input_pipeline_names_parse_back() {
    for p in [
        InputPipeline::Sampled,
        InputPipeline::ReverseIsp { noise: None, seed: 3 },
        InputPipeline::ReverseIsp {
            noise: Some(NoiseLevel::High),
            seed: 3,
        },
    ] {
        assert_eq!(InputPipeline::parse(&p.name(), 3), Ok(p));
    }
    assert_eq!(
        InputPipeline::parse(" Medium ", 9),
        Ok(InputPipeline::ReverseIsp {
            noise: Some(NoiseLevel::Medium),
            seed: 9
        })
    );
    let e = InputPipeline::parse("raw-foggy", 1).unwrap_err();
    assert!(e.contains("raw-foggy") && e.contains("expected sampled"), "{e}");
}

/// 40 photos of two crops each (a crop and its mirror share the prefix) and 30 negative
/// images, by name only.
fn toy_files() -> (Vec<PathBuf>, Vec<PathBuf>) {
    let pos = (0..40)
        .flat_map(|k| ["a", "b"].map(|m| PathBuf::from(format!("crop{k:03}{m}.png"))))
        .collect();
    let neg = (0..30).map(|k| PathBuf::from(format!("neg{k}.jpg"))).collect();
    (pos, neg)
}

#[test]
fn inner_split_regroups_only_the_training_files() {
    let (pos, neg) = toy_files();
    let outer = Split {
        extra_train_neg: vec![PathBuf::from("extra.png")],
        ..split_lists(pos, neg, 1, 0.2, 0)
    };
    let inner = inner_split(&outer, 1, 0.2);
    // Training-only negatives stay on the training side.
    assert_eq!(inner.extra_train_neg, outer.extra_train_neg);
    let sorted = |v: &[PathBuf]| {
        let mut v = v.to_vec();
        v.sort();
        v
    };
    // Inner train + inner validation = outer train; nothing of the outer validation.
    let mut all_pos = inner.train_pos.clone();
    all_pos.extend(inner.val_pos.clone());
    assert_eq!(sorted(&all_pos), sorted(&outer.train_pos));
    let mut all_neg = inner.train_neg.clone();
    all_neg.extend(inner.val_neg.clone());
    assert_eq!(sorted(&all_neg), sorted(&outer.train_neg));
    assert!(!inner.val_pos.is_empty() && !inner.val_neg.is_empty());
    // Mirrors stay together.
    for p in &inner.val_pos {
        let pre = photo_prefix(p.to_str().unwrap());
        assert!(inner
            .train_pos
            .iter()
            .all(|q| photo_prefix(q.to_str().unwrap()) != pre));
    }
    // Deterministic.
    assert_eq!(inner_split(&outer, 1, 0.2).val_pos, inner.val_pos);
}

#[test]
fn training_on_every_file_still_selects_c_on_an_inner_split() {
    let (pos, neg) = toy_files();
    let all = split_lists(pos, neg, 1, 0.0, 0);
    assert!(all.val_pos.is_empty() && all.val_neg.is_empty());
    assert_eq!((all.train_pos.len(), all.train_neg.len()), (80, 30));
    assert_eq!(inner_val_fraction(0.0), 0.2);
    assert_eq!(inner_val_fraction(0.25), 0.25);
    let inner = inner_split(&all, 1, inner_val_fraction(0.0));
    assert_eq!((inner.val_pos.len(), inner.val_neg.len()), (16, 6));
}

#[test]
fn folds_are_disjoint_cover_everything_and_fold_zero_is_the_shipped_split() {
    // 23 photos of 1–3 crops each (mirrors share the prefix), 41 negative images.
    let pos: Vec<PathBuf> = (0..23)
        .flat_map(|i| {
            (0..1 + i % 3)
                .map(move |j| PathBuf::from(format!("crop{i:03}00{}.png", (b'a' + j as u8) as char)))
        })
        .collect();
    let neg: Vec<PathBuf> = (0..41).map(|i| PathBuf::from(format!("n{i:02}.jpg"))).collect();
    assert_eq!(fold_count(0.2), 5);
    assert_eq!(fold_count(0.25), 4);
    assert_eq!(fold_count(0.3), 3);
    let folds: Vec<Split> = (0..5)
        .map(|k| split_lists(pos.clone(), neg.clone(), 7, 0.2, k))
        .collect();
    // Fold 0 is what the split was before folds existed: the first round(f·n) of the shuffle.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut prefixes: Vec<String> = pos
        .iter()
        .map(|p| photo_prefix(p.to_str().unwrap()).to_string())
        .collect();
    prefixes.dedup();
    prefixes.shuffle(&mut rng);
    let mut shuffled = neg.clone();
    shuffled.shuffle(&mut rng);
    assert_eq!(folds[0].val_neg, shuffled[..8].to_vec());
    assert_eq!(folds[0].train_neg, shuffled[8..].to_vec());
    let first: std::collections::HashSet<&str> = prefixes[..5].iter().map(|s| s.as_str()).collect();
    assert!(folds[0]
        .val_pos
        .iter()
        .all(|p| first.contains(photo_prefix(p.to_str().unwrap()))));
    let mut seen_pos: Vec<PathBuf> = Vec::new();
    let mut seen_neg: Vec<PathBuf> = Vec::new();
    for f in &folds {
        assert_eq!(f.val_pos.len() + f.train_pos.len(), pos.len());
        assert_eq!(f.val_neg.len() + f.train_neg.len(), neg.len());
        assert!(!f.val_pos.is_empty() && !f.val_neg.is_empty());
        for p in &f.val_pos {
            let pre = photo_prefix(p.to_str().unwrap());
            assert!(f
                .train_pos
                .iter()
                .all(|q| photo_prefix(q.to_str().unwrap()) != pre));
        }
        seen_pos.extend(f.val_pos.iter().cloned());
        seen_neg.extend(f.val_neg.iter().cloned());
    }
    // Every photo and every negative image is held out exactly once.
    seen_pos.sort();
    seen_neg.sort();
    let (mut all_pos, mut all_neg) = (pos.clone(), neg.clone());
    all_pos.sort();
    all_neg.sort();
    assert_eq!(seen_pos, all_pos);
    assert_eq!(seen_neg, all_neg);
    // Out of range: a clear error naming the fold, before any file is read.
    let missing = Path::new("/nonexistent/mosaicd-data");
    match split_data(missing, 1, 0.2, 5) {
        Err(TrainError::BadOption { what, value, .. }) => {
            assert_eq!(what, "fold");
            assert!(value.starts_with('5'), "{value}");
        }
        other => panic!("{other:?}"),
    }
    for bad in [1.0, -0.1, f64::NAN] {
        assert!(matches!(
            split_data(missing, 1, bad, 0),
            Err(TrainError::BadOption {
                what: "val_fraction",
                ..
            })
        ));
    }
    // Nothing held out (train on everything) is fold 0 only.
    assert!(matches!(
        split_data(missing, 1, 0.0, 1),
        Err(TrainError::BadOption { what: "fold", .. })
    ));
    let all = split_lists(pos.clone(), neg.clone(), 7, 0.0, 0);
    assert!(all.val_pos.is_empty() && all.val_neg.is_empty());
    assert_eq!((all.train_pos.len(), all.train_neg.len()), (pos.len(), neg.len()));
    assert!(matches!(
        split_data(missing, 1, 0.0, 0),
        Err(TrainError::Data { .. })
    ));
    assert!(matches!(
        split_data(missing, 1, 0.2, 4),
        Err(TrainError::Data { .. })
    ));
}

#[test]
fn select_c_rejects_empty_and_non_positive_candidates_before_training() {
    // The files do not exist: a candidate list that got past the check would fail on them.
    let split = split_lists(
        vec![PathBuf::from("crop001a.png")],
        vec![PathBuf::from("neg.jpg")],
        1,
        0.2,
        0,
    );
    let o = TrainOptions::default();
    for (cands, shown) in [(&[][..], "[]"), (&[0.1, 0.0][..], "0"), (&[f64::NAN][..], "NaN")] {
        match select_c(&split, &o, cands, &mut |_| {}) {
            Err(TrainError::BadOption { what, value, .. }) => {
                assert_eq!(what, "C candidates");
                assert_eq!(value, shown);
            }
            other => panic!("{cands:?}: {other:?}"),
        }
    }
}

#[test]
fn negative_dirs_list_images_in_order_and_reject_empty_ones() {
    let dir = tempfile::tempdir().unwrap();
    let (d1, d2, empty) = (dir.path().join("1"), dir.path().join("2"), dir.path().join("e"));
    for d in [&d1, &d2, &empty] {
        std::fs::create_dir(d).unwrap();
    }
    for f in [
        d1.join("b.png"),
        d1.join("a.jpg"),
        d2.join("c.png"),
        d1.join("x.txt"),
    ] {
        std::fs::write(f, b"").unwrap();
    }
    let names: Vec<PathBuf> = list_negative_dirs(&[d2.clone(), d1.clone()]).unwrap();
    assert_eq!(names, [d2.join("c.png"), d1.join("a.jpg"), d1.join("b.png")]);
    let e = list_negative_dirs(&[d1.clone(), empty.clone()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no PNG or JPEG") && e.contains(empty.to_str().unwrap()),
        "{e}"
    );
    let e = list_negative_dirs(&[dir.path().join("missing")])
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing"), "{e}");
}

#[test]
fn a_bad_bias_scale_is_refused_before_training() {
    for b in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let o = TrainOptions {
            bias_scale: b,
            ..TrainOptions::default()
        };
        let e = train_on(&Split::default(), &o, &mut |_| {}).unwrap_err();
        assert!(e.to_string().contains("bias_scale"), "{b}: {e}");
    }
}

#[test]
fn prefixes_group_mirrors() {
    assert_eq!(photo_prefix("crop001001a.png"), photo_prefix("crop001001b.png"));
    assert_ne!(photo_prefix("crop001001a.png"), photo_prefix("crop001002a.png"));
}
