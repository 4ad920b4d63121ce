//! Tests of the HOG stages (the approximation's are in `approx`).

use super::blocks::{block_rows_with, blocks_in_bands};
use super::cells::cells_from_planes_with;
use super::input::planes_from_input;
use super::kernels::portable::gamma_in_place_generic;
use super::kernels::{self, CellKernel};
use super::types::cell_len;
use super::*;
use crate::image::{Image, ImageView};
use crate::kernels::Isa;

fn spec() -> HogSpec {
    HogSpec::new(&HogOptions::default()).unwrap()
}

#[test]
fn default_geometry_matches_opencv() {
    let s = spec();
    assert_eq!(s.blocks_per_window(), (7, 15));
    assert_eq!(s.block_len(), 36);
    assert_eq!(s.descriptor_len(), 3780);
    assert_eq!(s.win_sigma(), 4.0);
}

#[test]
fn profiles_are_gaussian_times_bilinear() {
    let s = spec();
    // Pixel j = 0 of the block: cell coordinate -7/16, only cell 0, bilinear weight 9/16.
    let g0 = (-(64.0f32) / 32.0).exp();
    assert!((s.profile[0][0] - g0 * 9.0 / 16.0).abs() < 1e-7);
    assert_eq!(s.profile[2][0], 0.0); // block cell 1 gets nothing from j = 0
                                      // j = 8 (cell offset 1, k = 0): coordinate 9/16 → cell 0 weight 7/16, cell 1 weight 9/16.
    assert!((s.profile[1][0] - 7.0 / 16.0).abs() < 1e-7);
    assert!((s.profile[3][0] - 9.0 / 16.0).abs() < 1e-7);
}

#[test]
fn bad_options_are_refused() {
    let o = HogOptions {
        win_width: 60,
        ..Default::default()
    };
    assert!(matches!(
        HogSpec::new(&o),
        Err(HogError::BadWindow { width: 60, .. })
    ));
    let o = HogOptions {
        nbins: 1,
        ..Default::default()
    };
    assert_eq!(HogSpec::new(&o), Err(HogError::BadBins(1)));
    let o = HogOptions {
        l2hys_threshold: 0.0,
        ..Default::default()
    };
    assert!(HogSpec::new(&o).is_err());
}

#[test]
fn image_smaller_than_window_is_an_error() {
    let img = Image::<u8>::new(63, 128);
    let e = block_grid_from_input(&spec(), &HogInput::GreyU8(img.view())).unwrap_err();
    assert!(matches!(
        e,
        HogError::ImageTooSmall {
            width: 63,
            height: 128,
            ..
        }
    ));
    let img = Image::<u8>::new(0, 0);
    assert!(block_grid_from_input(&spec(), &HogInput::GreyU8(img.view())).is_err());
    let img = Image::<f32>::new(65, 128);
    assert_eq!(
        block_grid_from_input(&spec(), &HogInput::Mosaic(img.view())).unwrap_err(),
        HogError::OddMosaic {
            width: 65,
            height: 128
        }
    );
}

#[test]
fn atan_matches_std_within_opencv_accuracy() {
    for k in 0..3600 {
        let t = k as f32 * 0.1f32.to_radians();
        let (y, x) = (t.sin() * 3.0, t.cos() * 3.0);
        let mut want = y.atan2(x).to_degrees();
        if want < 0.0 {
            want += 360.0;
        }
        let got = fast_atan2_deg(y, x);
        let d = (got - want).abs();
        assert!(d < 0.02 || (d - 360.0).abs() < 0.02, "{k}: {got} vs {want}");
    }
}

#[test]
fn flat_image_gives_zero_descriptor() {
    let img = Image::<u8>::filled(64, 128, 77);
    let d = descriptor_from_window(&spec(), &HogInput::GreyU8(img.view())).unwrap();
    assert!(d.iter().all(|&v| v == 0.0));
}

#[test]
fn vertical_edge_votes_bin_for_zero_degrees() {
    // A step along x: gradient along +x, angle 0 → a = -0.5 → bins 8 and 0 equally.
    let img = Image::<u8>::from_fn(64, 128, |x, _| if x < 20 { 10 } else { 200 });
    let spec = spec();
    let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
    let b = grid.block(1, 3); // pixels x 8..24 covers the edge at 19/20
    let mut energy = [0.0f32; 9];
    for c in 0..4 {
        for k in 0..9 {
            energy[k] += b[c * 9 + k];
        }
    }
    assert!(
        energy[0] > 0.1 && (energy[0] - energy[8]).abs() < 1e-5,
        "{energy:?}"
    );
    assert!(energy[1..8].iter().all(|&v| v == 0.0));
    // Normalised: L2 norm ≈ 1 (minus epsilon effects).
    let n: f32 = b.iter().map(|v| v * v).sum::<f32>().sqrt();
    assert!(n > 0.9 && n <= 1.0 + 1e-6, "{n}");
}

#[test]
fn parallel_equals_serial() {
    let img = Image::<u8>::from_fn(301, 277, |x, y| ((x * x + 3 * y * x + y) % 251) as u8);
    let spec = spec();
    let inp = HogInput::GreyU8(img.view());
    let (mut a, mut b) = (BlockGrid::empty(), BlockGrid::empty());
    block_grid(&spec, &inp, Exec::Parallel, &mut a).unwrap();
    block_grid(&spec, &inp, Exec::Serial, &mut b).unwrap();
    assert_eq!(a, b);
    assert_eq!((a.blocks_x(), a.blocks_y()), (36, 33));
}

fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn kernel_paths_cells_and_blocks_equal_the_scalar_oracle() {
    // Bit for bit (the kernels make the scalar code's fused multiply-adds in its order): every
    // cell kernel of every path this CPU has, the block rows of every path, and cells and blocks
    // fused in bands, for one and two AVX2 registers per histogram (4, 9, 16 bins) and more than
    // the register kernels hold (18).
    let grey = Image::<u8>::from_fn(204, 150, |x, y| ((x * x + 3 * y * x + y) % 251) as u8);
    let mosaic = grey.map(|v| v as f32 * 0.93);
    let rgb = Image::<[u8; 3]>::from_fn(204, 150, |x, y| {
        [(x % 256) as u8, ((y * 3) % 256) as u8, ((x ^ y) % 256) as u8]
    });
    for nbins in [9, 4, 16, 18] {
        let spec = HogSpec::new(&HogOptions {
            nbins,
            ..Default::default()
        })
        .unwrap();
        for inp in [
            HogInput::GreyU8(grey.view()),
            HogInput::Mosaic(mosaic.view()),
            HogInput::Rgb8(rgb.view()),
        ] {
            let owned = planes_from_input(&spec, &inp).unwrap();
            let planes = owned.view();
            let mut want = CellGrid::empty();
            cells_from_planes_with(&spec, &planes, Exec::Serial, CellKernel::Scalar, &mut want);
            let mut bw = BlockGrid::empty();
            block_rows_with(&spec, &want, Exec::Serial, Isa::Scalar, &mut bw);
            for k in CellKernel::available(&spec) {
                let mut got = CellGrid::empty();
                cells_from_planes_with(&spec, &planes, Exec::Parallel, k, &mut got);
                assert!(same_bits(&got.data, &want.data), "{k:?} nbins {nbins}");
            }
            for isa in Isa::available() {
                let mut bg = BlockGrid::empty();
                block_rows_with(&spec, &want, Exec::Parallel, isa, &mut bg);
                assert!(same_bits(&bg.data, &bw.data), "{isa} nbins {nbins}");
            }
            // Cells and blocks fused in bands (two bands here in parallel, one serially), every
            // cell kernel and path.
            assert!(bw.nby > BAND_BLOCK_ROWS);
            for k in CellKernel::available(&spec) {
                for isa in Isa::available() {
                    for exec in [Exec::Parallel, Exec::Serial] {
                        let mut bf = BlockGrid::empty();
                        blocks_in_bands(&spec, &planes, exec, k, isa, &mut bf);
                        assert_eq!((bf.nbx, bf.nby), (bw.nbx, bw.nby));
                        assert!(
                            same_bits(&bf.data, &bw.data),
                            "bands {k:?} {isa} {exec:?} nbins {nbins}"
                        );
                    }
                }
            }
            // The kernel of each path is the one documented in `kernels`.
            for isa in Isa::available() {
                let k = CellKernel::for_isa(isa, &spec);
                let regs = nbins <= 16;
                let expect = match isa {
                    Isa::Scalar => CellKernel::Scalar,
                    Isa::Avx2 if regs => CellKernel::Avx2,
                    Isa::Avx512 if regs => CellKernel::Avx512,
                    Isa::Neon if regs => CellKernel::Neon,
                    Isa::Neon => CellKernel::Scalar,
                    _ => CellKernel::Avx2Portable,
                };
                assert_eq!(k, expect, "{isa} nbins {nbins}");
            }
        }
    }
    // Gamma rows.
    let src: Vec<f32> = (0..77).map(|i| i as f32 * 3.3 - 20.0).collect();
    for gamma in [true, false] {
        let mut want = src.clone();
        gamma_in_place_generic(&mut want, gamma);
        for isa in Isa::available() {
            let mut got = src.clone();
            kernels::gamma_in_place(isa, &mut got, gamma);
            assert!(same_bits(&got, &want), "{isa}");
        }
        let mut got = src.clone();
        gamma_in_place(&mut got, gamma);
        assert_eq!(got, want);
    }
}

#[test]
fn kernel_paths_block_rows_are_bit_identical() {
    // xorshift32: cell values of every magnitude, with zeros, -0, all-zero blocks and values
    // whose squares overflow.
    let mut state = 0x9e37_79b9u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    };
    for nbins in [9, 2, 3, 4, 16, 18] {
        for thresh in [DEFAULT_L2HYS_THRESHOLD, 1.0, 0.05] {
            let spec = HogSpec::new(&HogOptions {
                nbins,
                l2hys_threshold: thresh,
                ..Default::default()
            })
            .unwrap();
            let cl = cell_len(nbins);
            for ncx in [2, 3, 8, 9, 10, 16, 17, 25, 40, 71] {
                for kind in 0..6 {
                    let mut cell = |cx: usize| -> f32 {
                        let r = next();
                        let u = (r >> 8) as f32 / (1 << 24) as f32;
                        match (kind, r % 16) {
                            // Cells 3 and 4 zero: block 3 is all zeros.
                            (_, _) if (3..5).contains(&cx) && kind != 5 => 0.0,
                            (0, _) => u * 3.0,
                            (1, 0..=5) => 0.0,
                            (1, 6) => -0.0,
                            (1, _) => u * 1e-3,
                            (2, 0) => 1e20 * u,
                            (2, _) => u * 100.0,
                            (3, _) => f32::from_bits(r % 0x0100_0000), // subnormal to tiny
                            (4, 0..=7) => 0.0,
                            (4, _) => u * 1e18,
                            _ => u * 1e-2,
                        }
                    };
                    let mut cells = || -> Vec<f32> { (0..ncx * cl).map(|i| cell(i / cl)).collect() };
                    let (top, bottom) = (cells(), cells());
                    let n = (ncx - 1) * spec.block_len();
                    let (mut want, mut got) = (vec![f32::NAN; n], vec![f32::NAN; n]);
                    kernels::block_row(Isa::Scalar, &spec, ncx, &top, &bottom, &mut want);
                    assert!(want.iter().all(|v| v.is_finite()));
                    for isa in Isa::available() {
                        got.fill(f32::NAN);
                        kernels::block_row(isa, &spec, ncx, &top, &bottom, &mut got);
                        assert!(
                            same_bits(&got, &want),
                            "{isa} nbins {nbins} thresh {thresh} ncx {ncx} kind {kind}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn gamma_plane_entry_points_equal_the_linear_ones() {
    let spec = spec();
    let grey = Image::<u8>::from_fn(150, 290, |x, y| ((x * x + 3 * y * x + y) % 251) as u8);
    let mosaic = grey.map(|v| v as f32 * 0.93 - 2.0);
    let rgb = [0, 1, 2].map(|c| grey.map(|v| ((v as usize * (c + 2)) % 256) as f32));
    let g = |v: ImageView<'_, f32>| {
        let mut o = Image::new(0, 0);
        gamma_plane_into(v, true, &mut o);
        o
    };
    let gm = g(mosaic.view());
    let gc = [g(rgb[2].view()), g(rgb[1].view()), g(rgb[0].view())];
    for (lin, gam) in [
        (HogInput::Mosaic(mosaic.view()), GammaPlanes::Mosaic(gm.view())),
        (
            HogInput::ColourF32([rgb[0].view(), rgb[1].view(), rgb[2].view()]),
            GammaPlanes::Colour([gc[0].view(), gc[1].view(), gc[2].view()]),
        ),
    ] {
        let mut want = BlockGrid::empty();
        block_grid(&spec, &lin, Exec::Serial, &mut want).unwrap();
        let mut cells = CellGrid::empty();
        cell_grid_from_gamma_planes(&spec, &gam, Exec::Parallel, &mut cells).unwrap();
        let mut got = BlockGrid::empty();
        blocks_from_cells(&spec, &cells, Exec::Parallel, &mut got);
        assert_eq!(got, want);
        // A reused, larger buffer is resized, not appended to.
        let mut fused = want.clone();
        fused.data.extend([1.0; 100]);
        block_grid_from_gamma_planes(&spec, &gam, Exec::Parallel, &mut fused).unwrap();
        assert_eq!(fused, want);
        // The unfused, timed diagnostic gives the same grid and times each stage.
        let mut timed = BlockGrid::empty();
        let t = block_grid_stage_times(&spec, &gam, &mut timed).unwrap();
        assert_eq!(timed, want);
        assert!(t.gradients > std::time::Duration::ZERO && t.blocks > std::time::Duration::ZERO);
    }
    let small = Image::<f32>::new(60, 200);
    assert!(matches!(
        block_grid_from_gamma_planes(
            &spec,
            &GammaPlanes::Grey(small.view()),
            Exec::Serial,
            &mut BlockGrid::empty()
        ),
        Err(HogError::ImageTooSmall { .. })
    ));
}

#[test]
fn window_descriptor_equals_descriptor_of_the_crop_interior() {
    // Blocks that do not touch the crop border see identical gradients, so their values agree.
    let img = Image::<u8>::from_fn(160, 200, |x, y| ((x * 13 + y * 7 + x * y / 5) % 256) as u8);
    let spec = spec();
    let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
    let d = grid.window_descriptor(&spec, 3, 2).unwrap();
    let crop = img.view().crop(24, 16, 64, 128).unwrap().to_image();
    let d2 = descriptor_from_window(&spec, &HogInput::GreyU8(crop.view())).unwrap();
    // Block (bx=1, by=1) of the window is interior.
    let o = (15 + 1) * 36;
    for k in 0..36 {
        assert!((d[o + k] - d2[o + k]).abs() < 1e-6);
    }
}

#[test]
fn mosaic_of_grey_scene_matches_half_resolution_trend() {
    // A flat-colour mosaic (each CFA site constant) has zero mosaic gradient: taps are same-colour.
    let img = Image::<f32>::from_fn(64, 128, |x, y| [10.0, 80.0, 120.0, 30.0][(y & 1) * 2 + (x & 1)]);
    let d = descriptor_from_window(&spec(), &HogInput::Mosaic(img.view())).unwrap();
    assert!(d.iter().all(|&v| v == 0.0));
    let paper = HogSpec::new(&HogOptions {
        mosaic_taps: MosaicTaps::Paper,
        ..Default::default()
    })
    .unwrap();
    let d = descriptor_from_window(&paper, &HogInput::Mosaic(img.view())).unwrap();
    assert!(d.iter().all(|&v| v == 0.0));
}

#[test]
fn mosaic_taps_paper_is_the_grey_operator_on_the_raw_mosaic_and_same_site_is_not() {
    // The paper's point: [-1, 0, 1] applied to the mosaic as if it were grey.
    let img = Image::<f32>::from_fn(96, 160, |x, y| {
        let c = [1.0, 0.6, 0.6, 0.3][(y & 1) * 2 + (x & 1)];
        c * (40.0 + ((x * 7 + y * 3) % 50) as f32 + (x as f32 / 9.0).sin() * 30.0)
    });
    let paper = HogSpec::new(&HogOptions {
        mosaic_taps: MosaicTaps::Paper,
        ..Default::default()
    })
    .unwrap();
    let mosaic = block_grid_from_input(&paper, &HogInput::Mosaic(img.view())).unwrap();
    let grey = block_grid_from_input(&paper, &HogInput::GreyF32(img.view())).unwrap();
    let d = mosaic.window_descriptor(&paper, 2, 3).unwrap();
    assert_eq!(d, grey.window_descriptor(&paper, 2, 3).unwrap());
    let same_site = spec();
    let s = block_grid_from_input(&same_site, &HogInput::Mosaic(img.view())).unwrap();
    let ds = s.window_descriptor(&same_site, 2, 3).unwrap();
    assert!(d.iter().zip(&ds).map(|(a, b)| (a - b).abs()).sum::<f32>() > 1.0);
    assert_eq!(MosaicTaps::default(), MosaicTaps::SameSite);
    assert_eq!(
        (MosaicTaps::Paper.distance(), MosaicTaps::SameSite.distance()),
        (1, 2)
    );
    for t in [MosaicTaps::Paper, MosaicTaps::SameSite] {
        assert_eq!(t.name().parse::<MosaicTaps>(), Ok(t));
        assert_eq!(serde_json::to_value(t).unwrap(), t.name());
    }
    assert!("Paper"
        .parse::<MosaicTaps>()
        .unwrap_err()
        .contains("paper, same-site"));
}

#[test]
fn hostile_window_geometry_is_refused_before_any_size_is_computed() {
    // A crafted model's geometry: the descriptor length used to wrap (2305843009213693971) and
    // pass the weights' length check.
    let o = HogOptions {
        win_width: 32,
        win_height: 6148914691236517216,
        nbins: 2,
        ..Default::default()
    };
    let e = HogSpec::new(&o).unwrap_err();
    assert_eq!(
        e,
        HogError::WindowTooLarge {
            width: 32,
            height: 6148914691236517216,
            max: MAX_WINDOW_SIDE
        }
    );
    let msg = e.to_string();
    assert!(
        msg.contains("32x6148914691236517216") && msg.contains("1024"),
        "{msg}"
    );
    // Both sides, and bins, are bounded; the largest accepted geometry has a small descriptor.
    for (w, h) in [
        (MAX_WINDOW_SIDE + 8, 128),
        (64, MAX_WINDOW_SIDE + 8),
        (usize::MAX - 7, 64),
    ] {
        let o = HogOptions {
            win_width: w,
            win_height: h,
            ..Default::default()
        };
        assert!(
            matches!(HogSpec::new(&o), Err(HogError::WindowTooLarge { .. })),
            "{w}x{h}"
        );
    }
    for nbins in [0, 1, MAX_NBINS + 1, usize::MAX] {
        let o = HogOptions {
            nbins,
            ..Default::default()
        };
        assert_eq!(HogSpec::new(&o), Err(HogError::BadBins(nbins)));
    }
    let big = HogSpec::new(&HogOptions {
        win_width: MAX_WINDOW_SIDE,
        win_height: MAX_WINDOW_SIDE,
        nbins: MAX_NBINS,
        ..Default::default()
    })
    .unwrap();
    assert_eq!(big.descriptor_len(), 127 * 127 * 4 * 255);
    let (bx, by) = big.blocks_per_window();
    assert_eq!(bx * by * big.block_len(), big.descriptor_len());
}
