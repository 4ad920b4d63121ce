//! Real-file loader tests: every raw file in the shared data set (see ../shared/data/README.md).
//! A missing file fails with a message saying where to put the data.

use mosaicd::data::require;
use mosaicd::raw::{
    load_camera_raw, load_headerless, load_png_mosaic, rawloader_ifd_visits, MosaicFormat,
    MAX_TIFF_IFD_VISITS,
};
use mosaicd::raw::{
    load_input, Cfa, CfaChannel, Container, Endian, InputOptions, Levels, RawError, RawFormat, RawFrame,
};

fn nikon_format(cfa: Cfa) -> RawFormat {
    RawFormat::new(
        768,
        512,
        14,
        cfa,
        Container::U16,
        Endian::Little,
        Levels::uniform(600, 15520),
    )
}

fn nikon(name: &str, cfa: Cfa) -> RawFrame {
    let p = require(&format!("raw/nikon_dsc1339_isp/DSC_1339_768x512_{name}.raw"));
    load_headerless(&p, &nikon_format(cfa)).unwrap()
}

fn mean(f: &RawFrame) -> f64 {
    let v = f.to_u16_vec();
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

/// Mean of one CFA channel.
fn channel_mean(f: &RawFrame, ch: CfaChannel) -> f64 {
    let (ox, oy) = f.cfa().offset_of(ch);
    let (mut s, mut n) = (0.0, 0usize);
    for y in (oy..f.height()).step_by(2) {
        for x in (ox..f.width()).step_by(2) {
            s += f.value(x, y) as f64;
            n += 1;
        }
    }
    s / n as f64
}

#[test]
fn nikon_rose_rggb_14bit() {
    let f = nikon("rggb", Cfa::Rggb);
    assert_eq!(
        (f.width(), f.height(), f.bit_depth(), f.cfa()),
        (768, 512, 14, Cfa::Rggb)
    );
    let v = f.to_u16_vec();
    let (lo, hi) = (*v.iter().min().unwrap(), *v.iter().max().unwrap());
    // Measured: min 616 (just above black 600), max 16383 (clipped highlights), mean ~1693.
    assert!((600..700).contains(&lo), "min {lo}");
    assert_eq!(hi, 16383);
    let m = mean(&f);
    assert!((1500.0..1900.0).contains(&m), "mean {m}");
    // The two greens of a tile see the same light: their means agree closely.
    let (gr, gb) = (channel_mean(&f, CfaChannel::Gr), channel_mean(&f, CfaChannel::Gb));
    assert!((gr - gb).abs() < 0.02 * gr, "gr {gr} gb {gb}");
    // Read big-endian, the same bytes exceed 14 bits: refused.
    let p = require("raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw");
    let be = RawFormat {
        endian: Endian::Big,
        ..nikon_format(Cfa::Rggb)
    };
    assert!(matches!(
        load_headerless(&p, &be),
        Err(RawError::ValueOutOfRange { .. })
    ));
    // Wrong width: size mismatch.
    let wide = RawFormat {
        width: 770,
        ..nikon_format(Cfa::Rggb)
    };
    assert!(matches!(
        load_headerless(&p, &wide),
        Err(RawError::SizeMismatch { .. })
    ));
}

/// The author of the Nikon files did not crop: each re-phased file is the RGGB capture with the
/// four photosites of every 2x2 tile permuted so that each colour sits where the file's name
/// says. So read with its own pattern, every file has the same red and blue planes as the RGGB
/// file, and the same two green planes (for GBRG and BGGR the two greens swap rows, Gr <-> Gb).
#[test]
fn nikon_rephased_files_are_tile_permutations_of_rggb() {
    let base = nikon("rggb", Cfa::Rggb);
    let plane = |f: &RawFrame, ch: CfaChannel| -> Vec<u16> {
        let (ox, oy) = f.cfa().offset_of(ch);
        let mut out = Vec::new();
        for y in (oy..f.height()).step_by(2) {
            for x in (ox..f.width()).step_by(2) {
                out.push(f.value(x, y));
            }
        }
        out
    };
    for (name, cfa, greens_swapped) in [
        ("grbg", Cfa::Grbg, false),
        ("gbrg", Cfa::Gbrg, true),
        ("bggr", Cfa::Bggr, true),
    ] {
        let f = nikon(name, cfa);
        assert_eq!(plane(&f, CfaChannel::R), plane(&base, CfaChannel::R), "{name}: R");
        assert_eq!(plane(&f, CfaChannel::B), plane(&base, CfaChannel::B), "{name}: B");
        let (g1, g2) = if greens_swapped {
            (CfaChannel::Gb, CfaChannel::Gr)
        } else {
            (CfaChannel::Gr, CfaChannel::Gb)
        };
        assert_eq!(plane(&f, g1), plane(&base, CfaChannel::Gr), "{name}: Gr");
        assert_eq!(plane(&f, g2), plane(&base, CfaChannel::Gb), "{name}: Gb");
        // They are not crops of each other: an odd crop of the RGGB file differs.
        let c = base.crop(1, 0, 766, 512).unwrap();
        assert_eq!(c.cfa(), Cfa::Grbg);
        assert_ne!(c.to_u16_vec(), f.crop(0, 0, 766, 512).unwrap().to_u16_vec());
    }
}

#[test]
fn infinite_isp_8bit_grbg() {
    for name in ["Indoor1", "Outdoor1", "Outdoor2", "Outdoor3", "Outdoor4"] {
        let p = require(&format!("raw/infinite_isp_8bit/{name}_2592x1536_8bit_GRBG.raw"));
        let opts = InputOptions {
            width: Some(2592),
            height: Some(1536),
            bit_depth: Some(8),
            cfa: Some(Cfa::Grbg),
            black: Some([12; 4]),
            ..InputOptions::default()
        };
        let f = load_input(&p, &opts).unwrap().frame;
        assert_eq!(
            (f.width(), f.height(), f.bit_depth(), f.cfa()),
            (2592, 1536, 8, Cfa::Grbg)
        );
        assert_eq!(*f.levels(), Levels::uniform(12, 255));
        assert!(matches!(f.pixels(), mosaicd::raw::RawPixels::U8(_)));
        let v = f.to_u16_vec();
        // The 10-bit originals have black 50/1023, i.e. ~12.5 in 8 bits: nothing is below 12.
        assert!(*v.iter().min().unwrap() >= 12, "{name}");
        let m = mean(&f);
        assert!((20.0..120.0).contains(&m), "{name}: mean {m}");
        // As 16-bit, the file is half the needed size.
        let opts16 = InputOptions {
            bit_depth: Some(10),
            ..opts
        };
        assert!(matches!(
            load_input(&p, &opts16),
            Err(RawError::SizeMismatch { .. })
        ));
    }
}

#[test]
fn openisp_10bit_rggb() {
    let p = require("raw/openisp/test.RAW");
    let opts = InputOptions {
        width: Some(1920),
        height: Some(1080),
        bit_depth: Some(10),
        cfa: Some(Cfa::Rggb),
        ..InputOptions::default()
    };
    let f = load_input(&p, &opts).unwrap().frame;
    assert_eq!((f.width(), f.height(), f.bit_depth()), (1920, 1080, 10));
    assert_eq!(*f.levels(), Levels::uniform(0, 1023));
    let v = f.to_u16_vec();
    assert!(*v.iter().max().unwrap() <= 1023);
    let m = mean(&f);
    assert!((300.0..600.0).contains(&m), "mean {m}");
    // As 8-bit-in-u16 it overflows: the declared depth is checked.
    let opts8 = InputOptions {
        bit_depth: Some(9),
        ..opts
    };
    assert!(matches!(
        load_input(&p, &opts8),
        Err(RawError::ValueOutOfRange { .. })
    ));
}

/// `bayer_small.png` is documented as 10-bit 25/1023, but 3 of its values exceed 1023 (1026,
/// 1031, 1053): declared 10-bit it is refused; it loads as 11-bit with white 1023 (values above
/// white clamp in normalisation).
#[test]
fn halide_bayer_small_png_grbg() {
    let p = require("raw/halide/bayer_small.png");
    let ten = MosaicFormat {
        cfa: Cfa::Grbg,
        bit_depth: Some(10),
        black: [25; 4],
        white: Some(1023),
    };
    assert!(matches!(
        load_png_mosaic(&p, &ten),
        Err(RawError::ValueOutOfRange { value, bit_depth: 10, .. }) if value > 1023
    ));
    let opts = InputOptions {
        cfa: Some(Cfa::Grbg),
        bit_depth: Some(11),
        black: Some([25; 4]),
        white: Some(1023),
        ..InputOptions::default()
    };
    let l = load_input(&p, &opts).unwrap();
    assert!(l.rgb.is_none());
    let f = l.frame;
    assert_eq!((f.width(), f.height(), f.cfa()), (256, 344, Cfa::Grbg));
    let v = f.to_u16_vec();
    assert_eq!(v.iter().filter(|&&x| x > 1023).count(), 3);
    assert_eq!(*v.iter().max().unwrap(), 1053);
    // Green brighter than red and blue; greens agree.
    let (r, gr, gb, b) = (
        channel_mean(&f, CfaChannel::R),
        channel_mean(&f, CfaChannel::Gr),
        channel_mean(&f, CfaChannel::Gb),
        channel_mean(&f, CfaChannel::B),
    );
    assert!(gr > r && gr > b, "r {r} g {gr} b {b}");
    assert!((gr - gb).abs() < 0.05 * gr, "gr {gr} gb {gb}");
}

/// The Kodak DC50 KDC: rawloader 0.37 cannot decode it (no entry for the camera; the DC40/DC50
/// use Kodak's RADC compression), so the camera-raw loader identifies it by its TIFF make/model and
/// uses our RADC decoder (`src/raw/kodak_radc.rs`; pixel parity with LibRaw is `tests/raw_kdc.rs`).
/// Here: what the data README says — GRBG, 768x512, 14-bit range, 0 / 16383 — and a plausible
/// picture (values spread over the range, the two green planes alike).
#[test]
fn kodak_dc50_kdc_loads_as_grbg_768x512_14_bit() {
    let p = require("raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC");
    // Still refused by rawloader itself: when that changes, compare the two decoders here.
    match rawloader::decode_file(&p) {
        Err(e) => assert!(e.to_string().contains("DC50"), "{e}"),
        Ok(_) => panic!("rawloader now decodes the DC50: compare it with our RADC decoder"),
    }
    // rawloader's IFD walk of it, as counted before rawloader is called: far below the limit.
    let visits = rawloader_ifd_visits(&std::fs::read(&p).unwrap(), MAX_TIFF_IFD_VISITS);
    eprintln!("RAW_KODAK_DC50.KDC: {visits} IFD visits (limit {MAX_TIFF_IFD_VISITS})");
    assert!((1..=10).contains(&visits), "{visits}");
    let f = load_camera_raw(&p).unwrap();
    assert_eq!((f.width(), f.height()), (768, 512));
    assert_eq!(f.cfa(), Cfa::Grbg);
    assert_eq!(f.bit_depth(), 14);
    assert_eq!(*f.levels(), Levels::uniform(0, 16383));
    assert!(f.wb_gains.is_none());
    let v = f.to_u16_vec();
    let (min, max) = (*v.iter().min().unwrap(), *v.iter().max().unwrap());
    assert!(max <= 16383 && min < 1000 && max > 8000, "min {min} max {max}");
    let (gr, gb) = (channel_mean(&f, CfaChannel::Gr), channel_mean(&f, CfaChannel::Gb));
    assert!((gr - gb).abs() < 0.05 * gr, "gr {gr} gb {gb}");
    // The dispatcher sends it to the same place, and names the file in the frame's source.
    let l = load_input(&p, &InputOptions::default()).unwrap();
    assert_eq!(l.frame.to_u16_vec(), v);
    assert!(l.frame.meta.source.contains("RAW_KODAK_DC50.KDC"));
}

#[test]
fn kodak_png_resampled_to_every_pattern() {
    let p = require("kodak/kodim01.png");
    for cfa in Cfa::ALL {
        let l = load_input(
            &p,
            &InputOptions {
                cfa: Some(cfa),
                ..InputOptions::default()
            },
        )
        .unwrap();
        let rgb = l.rgb.as_ref().expect("rgb kept");
        assert_eq!((rgb.width(), rgb.height()), (768, 512));
        let f = &l.frame;
        assert_eq!((f.cfa(), f.bit_depth()), (cfa, 8));
        for (x, y) in [(0, 0), (1, 0), (0, 1), (1, 1), (767, 511), (300, 201)] {
            let c = match cfa.channel_at(x, y) {
                CfaChannel::R => 0,
                CfaChannel::Gr | CfaChannel::Gb => 1,
                CfaChannel::B => 2,
            };
            assert_eq!(f.value(x, y), rgb.get(x, y)[c] as u16);
        }
    }
}

/// BMP is read as an RGB image, sampled into a mosaic: a USC photograph (an 8-bit palette of
/// greys, which the decoder expands to equal R, G and B) becomes a mosaic of its own grey values
/// for any pattern, and an RGB BMP gives the same mosaic as the same picture in PNG. A file that is
/// neither an image nor a camera raw rawloader knows is refused saying what is supported.
#[test]
fn bmp_inputs_load_as_images_and_unknown_files_say_what_is_supported() {
    let usc = require("pedestrian/usc/USCPedestrianSetA/9Cup10.bmp");
    let grey = image::open(&usc).unwrap().to_luma8();
    let want: Vec<u16> = grey.as_raw().iter().map(|&v| u16::from(v)).collect();
    for cfa in [Cfa::Rggb, Cfa::Gbrg] {
        let opts = InputOptions {
            cfa: Some(cfa),
            ..InputOptions::default()
        };
        let l = load_input(&usc, &opts).unwrap();
        let f = l.frame;
        assert_eq!((f.width(), f.height(), f.cfa()), (424, 117, cfa));
        assert!(l.rgb.is_some());
        assert_eq!(f.to_u16_vec(), want);
    }

    let dir = tempfile::tempdir().unwrap();
    let png = require("kodak/kodim12.png");
    let bmp = dir.path().join("kodim12.bmp");
    image::open(&png).unwrap().to_rgb8().save(&bmp).unwrap();
    let from_bmp = load_input(&bmp, &InputOptions::default()).unwrap();
    let from_png = load_input(&png, &InputOptions::default()).unwrap();
    assert_eq!(from_bmp.frame.to_u16_vec(), from_png.frame.to_u16_vec());
    assert_eq!(from_bmp.frame.cfa(), Cfa::Rggb);

    let junk = dir.path().join("frame.dat");
    std::fs::write(&junk, [7u8; 4096]).unwrap();
    let e = load_input(&junk, &InputOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a supported input") && e.contains("bmp"), "{e}");
    assert!(!e.contains("raw.pixls.us"), "{e}");
}
