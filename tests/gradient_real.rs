//! Real-data checks of the mosaic gradients and of `mosaicd gradients` on the Nikon D750 raw
//! (`raw/nikon_dsc1339_isp`, 768x512, 14-bit RGGB, black 600, white 15520).

use std::process::Command;

use mosaicd::data::require;
use mosaicd::features::gradient::{
    mag_bin_from_raw, AngleRange, Border, MagBinOptions, MagBinSpec, Operator,
};
use mosaicd::raw::{Cfa, Levels, RawFrame};

const NIKON: &str = "raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw";

fn nikon() -> RawFrame {
    let bytes = std::fs::read(require(NIKON)).expect("read the Nikon raw");
    assert_eq!(bytes.len(), 768 * 512 * 2, "unexpected size of {NIKON}");
    let px = bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    RawFrame::from_u16(768, 512, px, Cfa::Rggb, 14, Levels::uniform(600, 15520)).unwrap()
}

#[test]
fn odd_crop_gives_the_same_gradients_inside() {
    // Gradients never look at the pattern, and every tap has the colour of its partner, so a crop at
    // an odd offset (re-phased to another pattern) gives the same interior values.
    let f = nikon();
    let c = f.crop(101, 77, 301, 203).unwrap();
    assert_eq!(c.cfa(), Cfa::Bggr);
    for op in [Operator::Central, Operator::Sobel] {
        let spec = MagBinSpec::new(MagBinOptions {
            operator: op,
            bins: 36,
            range: AngleRange::Signed,
            ..Default::default()
        })
        .unwrap();
        let a = mag_bin_from_raw(&f, &spec).unwrap();
        let b = mag_bin_from_raw(&c, &spec).unwrap();
        for y in 1..202 {
            for x in 1..300 {
                assert_eq!(b.mag.get(x, y), a.mag.get(x + 101, y + 77));
                assert_eq!(b.bin.get(x, y), a.bin.get(x + 101, y + 77));
            }
        }
        // The scene has structure: not all zero, and the 14-bit Sobel magnitude is halved.
        assert!(a.mag.as_slice().iter().any(|&m| m > 1000));
        assert_eq!(a.mag_shift, if op == Operator::Sobel { 1 } else { 0 });
    }
}

#[test]
fn mosaic_extrapolate_border_fills_the_edge_columns() {
    // Reflect-101 zeroes gx in the first and last column; same-colour extrapolation gives a
    // non-zero, colour-correct value there.
    let f = nikon();
    let spec = |border| {
        MagBinSpec::new(MagBinOptions {
            border,
            ..Default::default()
        })
        .unwrap()
    };
    let r = mag_bin_from_raw(&f, &spec(Border::Reflect101)).unwrap();
    let e = mag_bin_from_raw(&f, &spec(Border::MosaicExtrapolate)).unwrap();
    let col_sum =
        |m: &mosaicd::image::Image<u16>, x: usize| (0..512).map(|y| m.get(x, y) as u64).sum::<u64>();
    assert!(col_sum(&e.mag, 0) > col_sum(&r.mag, 0));
    // Interior identical.
    for y in 1..511 {
        assert_eq!(&r.mag.row(y)[1..767], &e.mag.row(y)[1..767]);
    }
}

#[test]
fn cli_writes_maps_and_summary() {
    let out = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(["gradients"])
        .arg(require(NIKON))
        .args([
            "--width",
            "768",
            "--height",
            "512",
            "--bit-depth",
            "14",
            "--cfa",
            "RGGB",
            "--black",
            "600",
            "--white",
            "15520",
            "--operator",
            "sobel",
            "--out",
        ])
        .arg(out.path())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let line = String::from_utf8_lossy(&o.stdout);
    assert!(line.contains("768x512 14-bit RGGB operator=Sobel"), "{line}");
    for f in ["magnitude.png", "magnitude16.png", "orientation.png"] {
        assert!(out.path().join(f).exists(), "{f} missing");
    }
    // The 16-bit map holds exactly the library's magnitude.
    let png = image::open(out.path().join("magnitude16.png"))
        .unwrap()
        .to_luma16();
    let spec = MagBinSpec::new(MagBinOptions {
        operator: Operator::Sobel,
        bins: 36,
        range: AngleRange::Signed,
        ..Default::default()
    })
    .unwrap();
    let lib = mag_bin_from_raw(&nikon(), &spec).unwrap();
    assert_eq!(png.as_raw().as_slice(), lib.mag.as_slice());
    // A mis-sized raw is refused with a message, non-zero exit.
    let o = Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(["gradients"])
        .arg(require(NIKON))
        .args([
            "--width",
            "768",
            "--height",
            "500",
            "--bit-depth",
            "14",
            "--cfa",
            "RGGB",
            "--out",
        ])
        .arg(out.path())
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("bytes"));
}
