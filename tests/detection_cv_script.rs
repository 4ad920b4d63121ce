//! `scripts/detection_cv.py`, which turns the per-fold tables of `mosaicd eval detection --fold K`
//! into the cross-validated means and paired intervals quoted in docs/detection.md: checked on
//! tables with known values against hand-computed results (Student t, 4 degrees of freedom).

use std::path::Path;
use std::process::Command;

fn table(fold: usize, rows: &[(&str, &str, [f64; 3])]) -> String {
    let mut s = format!(
        "## Pedestrian detection: window protocol\n\n**Window protocol (held-out split, seed 1 fold {fold}, \
         374 positives, 88 negative images, svm f32)**\n\n| model (trained on) | input | pipeline | \
         negative windows | MR@1e-2 | MR@1e-3 | MR@1e-4 |\n|---|---|---|---|---|---|---|\n"
    );
    for (model, input, mr) in rows {
        s += &format!(
            "| out/cv/sampled/fold{fold}/{model}.json (X) | {input} | sampled | 1678784 | {:.3} | {:.3} | {:.3} |\n",
            mr[0], mr[1], mr[2]
        );
    }
    s
}

fn run(dir: &Path) -> std::process::Output {
    Command::new("python3")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/detection_cv.py"))
        .arg(dir)
        .output()
        .expect("python3 runs")
}

#[test]
fn per_fold_means_and_paired_t_intervals() {
    let dir = tempfile::tempdir().unwrap();
    let mosaic = [0.20, 0.22, 0.18, 0.25, 0.21];
    let colour = [0.18, 0.19, 0.17, 0.20, 0.20];
    for k in 0..5 {
        let d = dir.path().join(format!("fold{k}/eval"));
        std::fs::create_dir_all(&d).unwrap();
        let rows = [
            ("mosaic", "mosaic", [0.03, 0.09, mosaic[k]]),
            ("colour", "colour", [0.02, 0.07, colour[k]]),
            ("colour", "mosaic", [0.04, 0.12, 0.27]),
        ];
        std::fs::write(d.join("detection.md"), table(k, &rows)).unwrap();
    }
    let o = run(dir.path());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Differences 0.02, 0.03, 0.01, 0.05, 0.01: mean 0.024, s = 0.01673, t(0.975, 4) = 2.776,
    // half-width 2.776 · s / √5 = 0.0208.
    assert!(
        out.contains(
            "| MR@1e-4 | +0.020 | +0.030 | +0.010 | +0.050 | +0.010 | +0.024 [+0.003, +0.045] | 0 / 5 |"
        ),
        "{out}"
    );
    assert!(
        out.contains(
            "| MR@1e-2 | +0.010 | +0.010 | +0.010 | +0.010 | +0.010 | +0.010 [+0.010, +0.010] | 0 / 5 |"
        ),
        "{out}"
    );
    // Mean of the mosaic rows at 1e-4: 0.212; the transfer row has no pair and only a mean.
    assert!(
        out.contains(
            "| mosaic | mosaic | sampled | 0.200 | 0.220 | 0.180 | 0.250 | 0.210 | 0.030 | 0.090 | 0.212 ± "
        ),
        "{out}"
    );
    assert!(out.contains("| colour | mosaic | sampled |"), "{out}");
    assert_eq!(std::fs::read_to_string(dir.path().join("cv.md")).unwrap(), out);
}

#[test]
fn no_fold_tables_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(dir.path());
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no fold*/eval/detection.md"), "{err}");
}
