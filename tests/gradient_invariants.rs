//! Invariants of the mosaic gradient operators and the fused kernel (that every kernel path equals
//! the scalar oracle bit for bit is the unit test `kernel_paths_equal_scalar_oracle_bit_for_bit` in
//! `features::gradient`, so that CI can run it under qemu with the library's tests): parallel equals serial, a flat mosaic gives
//! zero, a linear ramp a constant gradient, an R = G = B image gives a mosaic gradient identical to
//! its grey gradient, the fused magnitude stays within its stated bound of the float reference, and
//! black level cancels.

use mosaicd::features::gradient::{
    gradients_from_image, mag_bin_scalar, mag_bin_with_isa, Border, GradientSpec, MagBinOptions, MagBinSpec,
    Operator,
};
use mosaicd::image::{Image, ImageView};
use mosaicd::isp::grey_from_rgb_u8;
use mosaicd::kernels::{self, Isa};
use mosaicd::raw::{Cfa, Colour, RawView};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const OPS: [Operator; 2] = [Operator::Central, Operator::Sobel];
const BORDERS: [Border; 3] = [Border::Reflect101, Border::Replicate, Border::MosaicExtrapolate];

/// A seeded mosaic with smooth structure plus noise (so all orientations occur).
fn mosaic_u16(w: usize, h: usize, bits: u8, seed: u64) -> Image<u16> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let max = ((1u32 << bits) - 1) as f64;
    Image::from_fn(w, h, |x, y| {
        let s = 0.5 + 0.35 * ((x as f64 * 0.21).sin() * (y as f64 * 0.13).cos());
        let n: f64 = rng.random_range(-0.08..0.08);
        ((s + n).clamp(0.0, 1.0) * max).round() as u16
    })
}

fn run(src: RawView<'_>, bits: u8, spec: &MagBinSpec, isa: Isa) -> (Image<u16>, Image<u8>) {
    let (w, h) = (src.width(), src.height());
    let mut m = Image::new(w, h);
    let mut b = Image::new(w, h);
    mag_bin_with_isa(src, bits, spec, isa, &mut m.view_mut(), &mut b.view_mut()).unwrap();
    (m, b)
}

#[test]
fn parallel_equals_serial() {
    let img = mosaic_u16(333, 101, 12, 7);
    for op in OPS {
        let par = MagBinSpec::new(MagBinOptions {
            operator: op,
            ..Default::default()
        })
        .unwrap();
        let ser = MagBinSpec::new(MagBinOptions {
            operator: op,
            serial: true,
            ..Default::default()
        })
        .unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
        let a = pool.install(|| run(RawView::U16(img.view()), 12, &par, kernels::isa()));
        let b = run(RawView::U16(img.view()), 12, &ser, kernels::isa());
        assert_eq!(a, b);
        let fpar = gradients_from_image(
            &img.view(),
            &GradientSpec {
                operator: op,
                ..Default::default()
            },
        )
        .unwrap();
        let fser = gradients_from_image(
            &img.view(),
            &GradientSpec {
                operator: op,
                serial: true,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(fpar, fser);
    }
}

#[test]
fn flat_gives_zero_and_ramp_gives_constant() {
    for op in OPS {
        let flat = Image::filled(9, 8, 1234u16);
        let g = gradients_from_image(
            &flat.view(),
            &GradientSpec {
                operator: op,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(g.gx.as_slice().iter().chain(g.gy.as_slice()).all(|&v| v == 0.0));
        let spec = MagBinSpec::new(MagBinOptions {
            operator: op,
            ..Default::default()
        })
        .unwrap();
        let (m, b) = run(RawView::U16(flat.view()), 12, &spec, kernels::isa());
        assert!(m.as_slice().iter().all(|&v| v == 0) && b.as_slice().iter().all(|&v| v == 0));

        // Ramp I = 7x + 2y + 100: inside, gx = 7 * ramp_gain, gy = 2 * ramp_gain; with the
        // mosaic-aware border, everywhere.
        let ramp = Image::from_fn(12, 10, |x, y| (7 * x + 2 * y + 100) as u16);
        let k = op.ramp_gain() as f32;
        for border in BORDERS {
            let g = gradients_from_image(
                &ramp.view(),
                &GradientSpec {
                    operator: op,
                    border,
                    serial: false,
                },
            )
            .unwrap();
            let whole = border == Border::MosaicExtrapolate;
            for y in 0..10 {
                for x in 0..12 {
                    if whole || (x > 0 && x < 11 && y > 0 && y < 9) {
                        assert_eq!(
                            (g.gx.get(x, y), g.gy.get(x, y)),
                            (7.0 * k, 2.0 * k),
                            "{op:?} {border:?} ({x},{y})"
                        );
                    }
                }
            }
        }
        let spec = MagBinSpec::new(MagBinOptions {
            operator: op,
            border: Border::MosaicExtrapolate,
            ..Default::default()
        })
        .unwrap();
        let (m, b) = run(RawView::U16(ramp.view()), 12, &spec, kernels::isa());
        let want = ((49.0f32 + 4.0).sqrt() * k).round() as u16;
        assert!(m.as_slice().iter().all(|&v| v == want));
        // atan2(2, 7) = 15.9° -> bin 0 of 9 over 180°.
        assert!(b.as_slice().iter().all(|&v| v == 0));
    }
}

/// Sample an RGB image to a mosaic: each pixel keeps the channel its filter passes.
fn mosaic_from_rgb(rgb: &Image<[u8; 3]>, cfa: Cfa) -> Image<u8> {
    Image::from_fn(rgb.width(), rgb.height(), |x, y| {
        let p = rgb.get(x, y);
        match cfa.colour_at(x, y) {
            Colour::Red => p[0],
            Colour::Green => p[1],
            Colour::Blue => p[2],
        }
    })
}

#[test]
fn equal_channels_give_mosaic_gradient_identical_to_grey() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let rgb = Image::from_fn(40, 30, |x, y| {
        let v = ((x * 5 + y * 3) % 200) as u8 + rng.random_range(0..50u8);
        [v, v, v]
    });
    let grey = grey_from_rgb_u8(&rgb.view());
    for cfa in Cfa::ALL {
        let mosaic = mosaic_from_rgb(&rgb, cfa);
        assert_eq!(mosaic, grey, "R = G = B: mosaic equals grey for {cfa:?}");
        for op in OPS {
            for border in BORDERS {
                let spec = GradientSpec {
                    operator: op,
                    border,
                    serial: false,
                };
                let gm = gradients_from_image(&mosaic.view(), &spec).unwrap();
                let gg = gradients_from_image(&grey.view(), &spec).unwrap();
                assert_eq!(gm, gg);
            }
        }
    }
    // And when channels differ the mosaic gradient is NOT the grey one (the test can fail).
    let rgb2 = rgb.map(|p| [p[0] / 2, p[1], p[2] / 3]);
    let m2 = mosaic_from_rgb(&rgb2, Cfa::Rggb);
    let g2 = grey_from_rgb_u8(&rgb2.view());
    assert_ne!(
        gradients_from_image(&m2.view(), &GradientSpec::default()).unwrap(),
        gradients_from_image(&g2.view(), &GradientSpec::default()).unwrap()
    );
}

#[test]
fn fused_magnitude_within_bound_of_float_reference() {
    let img = mosaic_u16(200, 50, 14, 3);
    for op in OPS {
        for border in BORDERS {
            let spec = MagBinSpec::new(MagBinOptions {
                operator: op,
                border,
                ..Default::default()
            })
            .unwrap();
            let shift = spec.mag_shift(14);
            let (m, _) = run(RawView::U16(img.view()), 14, &spec, kernels::isa());
            let g = gradients_from_image(
                &img.view(),
                &GradientSpec {
                    operator: op,
                    border,
                    serial: false,
                },
            )
            .unwrap();
            for y in 0..50 {
                for x in 0..200 {
                    let (gx, gy) = (g.gx.get(x, y) as f64, g.gy.get(x, y) as f64);
                    let exact = (gx * gx + gy * gy).sqrt() / f64::from(1u32 << shift);
                    // Stated bound: 0.5 (rounding) + 2^-10 relative (f32 evaluation).
                    let err = (m.get(x, y) as f64 - exact).abs();
                    assert!(
                        err <= 0.5 + exact / 1024.0,
                        "{op:?} {border:?} ({x},{y}): {} vs {exact}",
                        m.get(x, y)
                    );
                }
            }
        }
    }
}

#[test]
fn per_position_black_level_cancels() {
    // Adding a different constant at each of the four tile positions (a per-position black level)
    // changes nothing, because every difference is between two pixels of one tile position.
    let img = mosaic_u16(64, 48, 12, 11);
    let black = [60u16, 64, 61, 66];
    let lifted = Image::from_fn(64, 48, |x, y| img.get(x, y) + black[(y & 1) * 2 + (x & 1)]);
    for op in OPS {
        for border in [Border::Reflect101, Border::MosaicExtrapolate] {
            let spec = MagBinSpec::new(MagBinOptions {
                operator: op,
                border,
                ..Default::default()
            })
            .unwrap();
            let a = run(RawView::U16(img.view()), 12, &spec, kernels::isa());
            let b = run(RawView::U16(lifted.view()), 12, &spec, kernels::isa());
            assert_eq!(a, b, "{op:?} {border:?}");
        }
    }
    // Replicate mixes colours at the border, so there it does NOT cancel.
    let spec = MagBinSpec::new(MagBinOptions {
        border: Border::Replicate,
        ..Default::default()
    })
    .unwrap();
    let a = run(RawView::U16(img.view()), 12, &spec, kernels::isa());
    let b = run(RawView::U16(lifted.view()), 12, &spec, kernels::isa());
    assert_ne!(a, b);
}

#[test]
fn strided_views_are_read_correctly() {
    let img = mosaic_u16(50, 20, 12, 5);
    // Embed in a wider buffer (stride 64).
    let mut buf = vec![0u16; 64 * 20];
    for y in 0..20 {
        buf[y * 64..y * 64 + 50].copy_from_slice(img.row(y));
    }
    let view = ImageView::new(&buf, 50, 20, 64).unwrap();
    let spec = MagBinSpec::new(MagBinOptions::default()).unwrap();
    let a = run(RawView::U16(view), 12, &spec, kernels::isa());
    let mut m = Image::new(50, 20);
    let mut b = Image::new(50, 20);
    mag_bin_scalar(
        RawView::U16(img.view()),
        12,
        &spec,
        &mut m.view_mut(),
        &mut b.view_mut(),
    )
    .unwrap();
    assert_eq!(a, (m, b));
}
