use super::pyramid::pyramid_on;
use super::*;
use crate::image::Image;

fn raw_spec() -> ChannelSpec {
    // no smoothing, no normalisation: every value can be computed by hand
    ChannelSpec::new(ChannelOptions {
        input_smooth: 0.0,
        norm_radius: 0.0,
        norm_const: 0.005,
        output_smooth: 0.0,
    })
    .unwrap()
}

/// A smooth colour scene with edges (deterministic).
fn scene(w: usize, h: usize) -> Image<[u8; 3]> {
    Image::from_fn(w, h, |x, y| {
        let fx = x as f32 / w as f32;
        let fy = y as f32 / h as f32;
        let disc = ((fx - 0.5).powi(2) + (fy - 0.4).powi(2)) < 0.04;
        let base = [60.0 + 120.0 * fx, 80.0 + 90.0 * fy, 200.0 - 100.0 * fx * fy];
        let p = if disc { [220.0, 40.0, 50.0] } else { base };
        p.map(|v: f32| v.round() as u8)
    })
}

fn mosaic_of(rgb: &Image<[u8; 3]>, cfa: Cfa) -> Image<f32> {
    Image::from_fn(rgb.width(), rgb.height(), |x, y| {
        let p = rgb.get(x, y);
        match cfa.colour_at(x, y) {
            Colour::Red => p[0] as f32,
            Colour::Green => p[1] as f32,
            Colour::Blue => p[2] as f32,
        }
    })
}

#[test]
fn shapes_and_errors() {
    let g = Image::<u8>::filled(37, 22, 100);
    let c = channels(&ChannelInput::GreyU8(g.view()), &ChannelSpec::default()).unwrap();
    assert_eq!((c.width(), c.height()), (9, 5));
    assert_eq!(c.as_slice().len(), N_CHANNELS * 9 * 5);
    assert_eq!(c.window(1, 1, 8, 4).unwrap().len(), N_CHANNELS * 32);
    assert!(c.window(2, 2, 8, 4).is_none());
    let m = Image::<f32>::filled(10, 7, 1.0);
    assert_eq!(
        channels(
            &ChannelInput::Mosaic {
                image: m.view(),
                cfa: Cfa::Rggb
            },
            &ChannelSpec::default()
        ),
        Err(ChannelsError::OddMosaic { width: 10, height: 7 })
    );
    let t = Image::<u8>::filled(3, 9, 0);
    assert!(matches!(
        channels(&ChannelInput::GreyU8(t.view()), &ChannelSpec::default()),
        Err(ChannelsError::TooSmall { width: 3, .. })
    ));
    for bad in [1.5f32, -1.0, 40.0, f32::NAN] {
        let o = ChannelOptions {
            output_smooth: bad,
            ..ChannelOptions::default()
        };
        assert!(
            matches!(
                ChannelSpec::new(o),
                Err(ChannelsError::BadOption {
                    name: "output_smooth",
                    ..
                })
            ),
            "{bad}"
        );
    }
}

#[test]
fn hand_computed_ramp() {
    // I(x) = 10x: gx = (10(x+1) − 10(x−1))/2/255 = 10/255 inside, 0 on the edge columns
    // (reflect-101), gy = 0, θ = 0 → bin 0. 8x4 pixels = 2x1 blocks; each block has three
    // non-zero columns out of four: mean = 12 · (10/255) / 16.
    let g = Image::from_fn(8, 4, |x, _| (10 * x) as u8);
    let c = channels(&ChannelInput::GreyU8(g.view()), &raw_spec()).unwrap();
    let want = 12.0 * (10.0 / 255.0) / 16.0;
    for bx in 0..2 {
        assert!(
            (c.get(MAG_CHANNEL, bx, 0) - want).abs() < 1e-7,
            "{}",
            c.get(MAG_CHANNEL, bx, 0)
        );
        assert_eq!(c.get(MAG_CHANNEL + 1, bx, 0), c.get(MAG_CHANNEL, bx, 0));
        for k in 2..=N_ORIENTS {
            assert_eq!(c.get(MAG_CHANNEL + k, bx, 0), 0.0);
        }
    }
    // L of the block mean: the mean of per-pixel L over x = 0..3, grey r = g = b.
    let mean_l: f32 = (0..4)
        .map(|x| {
            luv_from_rgb(
                10.0 * x as f32 / 255.0,
                10.0 * x as f32 / 255.0,
                10.0 * x as f32 / 255.0,
            )[0]
        })
        .sum::<f32>()
        / 4.0;
    assert!((c.get(0, 0, 0) - mean_l).abs() < 1e-6);
    // A vertical ramp lands in the 90° bin (index 3).
    let g = Image::from_fn(4, 8, |_, y| (10 * y) as u8);
    let c = channels(&ChannelInput::GreyU8(g.view()), &raw_spec()).unwrap();
    assert!(c.get(MAG_CHANNEL + 1 + 3, 0, 0) > 0.0);
    assert_eq!(c.get(MAG_CHANNEL + 1 + 3, 0, 0), c.get(MAG_CHANNEL, 0, 0));
}

#[test]
fn luv_known_values() {
    // white: Y = 0.222015 + 0.706655 + 0.071330 = 1 → L = 100/270
    let [l, u, v] = luv_from_rgb(1.0, 1.0, 1.0);
    assert!((l - 100.0 / 270.0).abs() < 1e-5, "{l}");
    // black: L = 0 and u, v the offsets
    let [l0, u0, v0] = luv_from_rgb(0.0, 0.0, 0.0);
    assert_eq!(l0, 0.0);
    assert!((u0 - 88.0 / 270.0).abs() < 1e-6 && (v0 - 134.0 / 270.0).abs() < 1e-6);
    assert!(u.is_finite() && v.is_finite());
}

#[test]
fn flat_colour_mosaic_has_no_gradient_and_its_colour() {
    // Same-colour taps: a mosaic of a flat colour is piecewise constant per site, and every
    // difference subtracts equal values, with any smoothing and any CFA.
    for cfa in [Cfa::Rggb, Cfa::Bggr, Cfa::Grbg, Cfa::Gbrg] {
        let rgb = Image::filled(24, 16, [200u8, 100, 50]);
        let m = mosaic_of(&rgb, cfa);
        let spec = ChannelSpec::new(ChannelOptions {
            input_smooth: 1.0,
            ..ChannelOptions::default()
        })
        .unwrap();
        let c = channels(&ChannelInput::Mosaic { image: m.view(), cfa }, &spec).unwrap();
        let want = luv_from_rgb(200.0 / 255.0, 100.0 / 255.0, 50.0 / 255.0);
        for y in 0..c.height() {
            for x in 0..c.width() {
                for (k, w) in want.iter().enumerate() {
                    assert!((c.get(k, x, y) - w).abs() < 1e-5, "{cfa:?} {k} {x} {y}");
                }
                for k in MAG_CHANNEL..N_CHANNELS {
                    assert_eq!(c.get(k, x, y), 0.0, "{cfa:?} channel {k}");
                }
            }
        }
    }
}

#[test]
fn orientation_channels_sum_to_magnitude() {
    let rgb = scene(64, 48);
    let spec = ChannelSpec::default();
    for input in [
        ChannelInput::Rgb8(rgb.view()),
        ChannelInput::Mosaic {
            image: mosaic_of(&rgb, Cfa::Grbg).view(),
            cfa: Cfa::Grbg,
        },
    ] {
        let c = channels_unsmoothed(&input, &spec).unwrap();
        for i in 0..c.width() * c.height() {
            let s: f32 = (1..=N_ORIENTS).map(|k| c.plane(MAG_CHANNEL + k)[i]).sum();
            assert!((s - c.plane(MAG_CHANNEL)[i]).abs() < 1e-5);
        }
    }
}

#[test]
fn mosaic_colour_channels_follow_the_colour_image() {
    // The mosaic's colour comes from measured super-pixels; on a smooth scene it is close to the
    // colour image's (which averages per-pixel LUV of all three values).
    let rgb = scene(96, 64);
    let spec = ChannelSpec::default();
    let cc = channels(&ChannelInput::Rgb8(rgb.view()), &spec).unwrap();
    let m = mosaic_of(&rgb, Cfa::Rggb);
    let cm = channels(
        &ChannelInput::Mosaic {
            image: m.view(),
            cfa: Cfa::Rggb,
        },
        &spec,
    )
    .unwrap();
    let mut worst = 0.0f32;
    for k in 0..3 {
        for (a, b) in cc.plane(k).iter().zip(cm.plane(k)) {
            worst = worst.max((a - b).abs());
        }
    }
    // at the disc's edge a block mixes colours differently; elsewhere they agree closely
    assert!(worst < 0.08, "worst {worst}");
    let mean_diff: f32 = cc
        .plane(0)
        .iter()
        .zip(cm.plane(0))
        .map(|(a, b)| (a - b).abs())
        .sum::<f32>()
        / cc.plane(0).len() as f32;
    assert!(mean_diff < 0.005, "{mean_diff}");
}

#[test]
fn triangle_filter_taps_borders_and_planes() {
    for r in [0.5f32, 1.0, 2.0, 5.0] {
        let t = triangle_taps(r);
        assert!((t.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        assert_eq!(t.len() % 2, 1);
    }
    assert_eq!(triangle_taps(1.0), vec![0.25, 0.5, 0.25]);
    // impulse in the middle → the taps (separable: outer product)
    let (w, h) = (9, 9);
    let mut src = vec![0.0f32; w * h];
    src[4 * w + 4] = 1.0;
    let mut d = Vec::new();
    triangle_filter(&src, w, h, 2.0, 1, &mut d);
    let t = triangle_taps(2.0);
    for y in 0..h {
        for x in 0..w {
            let want = if (2..=6).contains(&x) && (2..=6).contains(&y) {
                t[x - 2] * t[y - 2]
            } else {
                0.0
            };
            assert!((d[y * w + x] - want).abs() < 1e-7);
        }
    }
    // a constant stays constant (symmetric borders)
    let c = vec![3.0f32; 7 * 5];
    triangle_filter(&c, 7, 5, 5.0, 1, &mut d);
    assert!(d.iter().all(|v| (v - 3.0).abs() < 1e-5));
    // step 2 never mixes phases: a 2x2 checker of two values stays as it is
    let chk: Vec<f32> = (0..8 * 6).map(|i| ((i % 8 + i / 8) % 2) as f32).collect();
    triangle_filter(&chk, 8, 6, 1.0, 2, &mut d);
    assert_eq!(d, chk);
}

#[test]
fn parallel_equals_serial() {
    let rgb = scene(130, 90);
    let m = mosaic_of(&rgb, Cfa::Rggb);
    let input = ChannelInput::Mosaic {
        image: m.view(),
        cfa: Cfa::Rggb,
    };
    let run = |t: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| channels(&input, &ChannelSpec::default()).unwrap())
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn pyramid_levels_exact_and_approximated() {
    let rgb = scene(256, 320);
    let m = mosaic_of(&rgb, Cfa::Rggb);
    let input = ChannelInput::Mosaic {
        image: m.view(),
        cfa: Cfa::Rggb,
    };
    let spec = ChannelSpec::default();
    let o = PyramidOptions::default();
    let p = pyramid(&input, &spec, &o).unwrap();
    // min(256/64, 320/128) = 2.5 → ⌊8·log2 2.5⌋ + 1 = 11 levels; exact: 0 and 8
    assert_eq!(p.levels.len(), 11);
    let exact: Vec<usize> = (0..11).filter(|&i| p.levels[i].exact).collect();
    assert_eq!(exact, vec![0, 8]);
    // level 0 is the image's own channels
    assert_eq!(p.levels[0].channels, channels(&input, &spec).unwrap());
    for l in &p.levels {
        assert_eq!(
            l.channels.width() * SHRINK,
            (256.0 * l.scale / 4.0).round() as usize * 4
        );
        assert!(l.channels.width() >= 16 && l.channels.height() >= 32);
    }
    // an approximated level stays close to the exact one in the mean of each channel (the power
    // law is a statistical model of natural images; this synthetic scene, mostly smooth ramps and
    // one disc, follows it within 20 %)
    let all = pyramid(&input, &spec, &PyramidOptions { approx: 0, ..o }).unwrap();
    assert!(all.levels.iter().all(|l| l.exact));
    for i in [1, 4, 7] {
        let (a, e) = (&p.levels[i].channels, &all.levels[i].channels);
        assert_eq!((a.width(), a.height()), (e.width(), e.height()));
        // colour and magnitude (single orientation bins of a synthetic ramp shift with the
        // resampling; their sum is the magnitude)
        for c in 0..=MAG_CHANNEL {
            let mean = |x: &Channels| x.plane(c).iter().sum::<f32>() / x.plane(c).len() as f32;
            let (ma, me) = (mean(a), mean(e));
            assert!(
                (ma - me).abs() <= 0.2 * me.abs() + 2e-3,
                "level {i} channel {c}: {ma} vs {me}"
            );
        }
    }
    // too small
    let small = Image::<u8>::filled(60, 100, 0);
    assert!(matches!(
        pyramid(&ChannelInput::GreyU8(small.view()), &spec, &o),
        Err(ChannelsError::TooSmall { .. })
    ));
}

#[test]
fn orientation_bins_agree_with_atan2() {
    let edges = bin_edges();
    let mut n = 0;
    for i in 0..3600 {
        let t = (i as f32 * 0.1 + 0.05).to_radians();
        for m in [0.01f32, 1.0, 300.0] {
            let (gx, gy) = (m * t.cos(), m * t.sin());
            let mut th = gy.atan2(gx);
            if th < 0.0 {
                th += std::f32::consts::PI;
            }
            let want = ((th * 6.0 / std::f32::consts::PI + 0.5) as usize % N_ORIENTS) as u8;
            assert_eq!(
                orient_bin(gx, gy, &edges),
                want,
                "angle {}°",
                i as f32 * 0.1 + 0.05
            );
            n += 1;
        }
    }
    assert_eq!(n, 10800);
    assert_eq!(orient_bin(0.0, 0.0, &edges), 0);
}

#[test]
fn lambdas_measured_on_scenes() {
    // Colour means do not change with scale (λ ≈ 0); gradient channels lose energy when an
    // image with fine detail is downsampled (λ > 0).
    let imgs: Vec<Image<[u8; 3]>> = (0..3)
        .map(|k| {
            Image::from_fn(96, 160, |x, y| {
                let v = ((x * (3 + k) + y * 5 + (x * y) % (7 + k)) % 97) as u8;
                [v + 60, 2 * v, 200 - v]
            })
        })
        .collect();
    let inputs: Vec<ChannelInput> = imgs.iter().map(|i| ChannelInput::Rgb8(i.view())).collect();
    let l = measure_lambdas(&inputs, &ChannelSpec::default(), 4, 2).unwrap();
    assert!(l[0].abs() < 0.1, "{l:?}");
    assert!(l[1] > 0.0 && l[2] > 0.0, "{l:?}");
}

/// A scene as every input kind: a GBRG mosaic, colour, grey bytes and grey floats.
struct Scenes {
    rgb: Image<[u8; 3]>,
    mosaic: Image<f32>,
    grey: Image<u8>,
    greyf: Image<f32>,
}

impl Scenes {
    fn new() -> Self {
        let rgb = scene(206, 150);
        Self {
            mosaic: mosaic_of(&rgb, Cfa::Gbrg),
            grey: rgb.map(|p| p[1]),
            greyf: rgb.map(|p| p[0] as f32 * 0.7 + 3.0),
            rgb,
        }
    }

    fn inputs(&self) -> [ChannelInput<'_>; 4] {
        [
            ChannelInput::Mosaic {
                image: self.mosaic.view(),
                cfa: Cfa::Gbrg,
            },
            ChannelInput::Rgb8(self.rgb.view()),
            ChannelInput::GreyU8(self.grey.view()),
            ChannelInput::GreyF32(self.greyf.view()),
        ]
    }
}

/// Every option that changes the channel pass: the defaults, none, input smoothing, another
/// normalisation radius and output smoothing.
fn option_sets() -> [ChannelSpec; 4] {
    [
        ChannelSpec::default(),
        raw_spec(),
        ChannelSpec::new(ChannelOptions {
            input_smooth: 1.0,
            ..ChannelOptions::default()
        })
        .unwrap(),
        ChannelSpec::new(ChannelOptions {
            norm_radius: 2.0,
            output_smooth: 1.0,
            ..ChannelOptions::default()
        })
        .unwrap(),
    ]
}

/// Pyramid options down to levels of 16x32 pixels (18 levels of the 206x150 scene).
fn small_levels() -> PyramidOptions {
    PyramidOptions {
        min_size: (16, 32),
        ..PyramidOptions::default()
    }
}

/// Every value of every level, as bits.
fn pyramid_bits(p: &ChannelPyramid) -> Vec<u32> {
    p.levels
        .iter()
        .flat_map(|l| l.channels.as_slice().iter().map(|v| v.to_bits()))
        .collect()
}

#[test]
fn kernel_paths_give_the_same_channels_and_pyramid() {
    // every input kind, every option that changes the pass (input smoothing, the normalisation
    // radius, none), sizes that are not multiples of a block or of a band: all paths of this CPU
    // give the scalar oracle's values bit for bit
    let s = Scenes::new();
    let inputs = s.inputs();
    let specs = option_sets();
    let opts = small_levels();
    for spec in &specs {
        for input in &inputs {
            let want = pyramid_on(crate::kernels::Isa::Scalar, input, spec, &opts).unwrap();
            assert_eq!(want.levels.len(), 18);
            for isa in crate::kernels::Isa::available() {
                let got = pyramid_on(isa, input, spec, &opts).unwrap();
                assert!(pyramid_bits(&got) == pyramid_bits(&want), "{isa}: {spec:?}");
            }
        }
    }
}

#[test]
fn grey_is_colour_with_equal_planes() {
    // "the same features on colour and grey images": a grey image and the colour image with
    // r = g = b have the same channels and pyramid bit for bit on every path (the strongest of
    // three equal gradients is the one gradient; LUV of equal values either way)
    let s = Scenes::new();
    let rgb = s.grey.map(|v| [v, v, v]);
    let opts = small_levels();
    for spec in &option_sets() {
        for isa in crate::kernels::Isa::available() {
            let g = pyramid_on(isa, &ChannelInput::GreyU8(s.grey.view()), spec, &opts).unwrap();
            let c = pyramid_on(isa, &ChannelInput::Rgb8(rgb.view()), spec, &opts).unwrap();
            assert_eq!(g.levels.len(), 18);
            assert!(pyramid_bits(&g) == pyramid_bits(&c), "{isa}: {spec:?}");
        }
    }
}

#[test]
fn stale_pool_buffers_change_no_value() {
    // the channel pass and the smoothing take pooled buffers without zeroing them: every value
    // must be written. Fill the pool with NaN buffers of many sizes and compare with the
    // channels and pyramids computed before, bit for bit, for every input kind and option set.
    let s = Scenes::new();
    let inputs = s.inputs();
    let specs = option_sets();
    let opts = small_levels();
    let bits = |v: &[f32]| -> Vec<u32> { v.iter().map(|v| v.to_bits()).collect() };
    let run = || -> Vec<Vec<u32>> {
        let mut out = vec![];
        for spec in &specs {
            for input in &inputs {
                out.push(bits(channels(input, spec).unwrap().as_slice()));
                let p = super::pyramid::pyramid(input, spec, &opts).unwrap();
                out.extend(p.levels.iter().map(|l| bits(l.channels.as_slice())));
            }
        }
        out
    };
    let want = run();
    for _ in 0..3 {
        let mut cap = 16.0f64;
        while cap < 400_000.0 {
            super::pool::give(vec![f32::NAN; cap as usize]);
            cap *= 1.25;
        }
        assert!(run() == want, "a stale pooled value reached the channels");
    }
}
