//! Demosaicing: a Bayer mosaic → an RGB image, five methods, all four patterns.
//!
//! This is the conventional path (the paper's pipeline 2 and Table IV) that mosaicd avoids; we need
//! it to measure what skipping it loses. The core works on `f32` mosaics; `u8` and `u16` wrappers
//! convert, demosaic and round/clamp back to the container range.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::isp::{rgb_from_mosaic, DemosaicMethod};
//! use mosaicd::raw::Cfa;
//! // a flat grey mosaic demosaics to a flat grey image with every method
//! let mosaic = Image::<f32>::filled(8, 8, 0.25);
//! for m in DemosaicMethod::all() {
//!     let rgb = rgb_from_mosaic(mosaic.view(), Cfa::Rggb, m).unwrap();
//!     assert!(rgb.as_slice().iter().all(|p| p.iter().all(|&c| (c - 0.25).abs() < 1e-6)));
//! }
//! ```
//!
//! ## Methods
//!
//! Notation: at a pixel, the missing channels are interpolated from the neighbours that carry them;
//! `G4, G6` are the left/right, `G2, G8` the up/down neighbours, `A` the pixel's own colour
//! (R or B), `A3, A7` two pixels left/right, `A1, A9` two pixels up/down.
//!
//! - **Nearest** ([`rgb_from_mosaic_nearest`]): every pixel takes R and B from the red and blue
//!   photosites of its own 2x2 tile (tiles start at even coordinates) and G from itself when
//!   green, else from the green of its tile that shares its row.
//! - **Bilinear** ([`rgb_from_mosaic_bilinear`]): the masked channel planes convolved with
//!   `H_G = [0 1 0; 1 4 1; 0 1 0]/4` and `H_RB = [1 2 1; 2 4 2; 1 2 1]/4` — the same as
//!   `colour_demosaicing.demosaicing_CFA_Bayer_bilinear` and OpenCV's `COLOR_Bayer*2RGB`.
//! - **Bicubic** ([`rgb_from_mosaic_bicubic`]): Keys' cubic convolution (a = −0.5, Catmull–Rom) on
//!   each channel's lattice. R and B live on a square lattice of spacing 2: separable weights
//!   `(−1, 9, 9, −1)/16` at offsets `−3, −1, 1, 3` along each axis where the channel is missing.
//!   G lives on a quincunx lattice, a square lattice rotated by 45°; the same cubic applied along
//!   the two diagonal axes gives the kernel `81/256` at the 4 direct neighbours, `−9/256` at the 8
//!   knight-move positions `(±1, ±2), (±2, ±1)` and `1/256` at `(±3, 0), (0, ±3)`.
//! - **Malvar–He–Cutler** ([`DemosaicMethod::Malvar`]): bilinear plus a Laplacian correction from
//!   the pixel's own channel, as four 5x5 kernels (gains α = 1/2, β = 5/8, γ = 3/4), identical to
//!   `colour_demosaicing.demosaicing_CFA_Bayer_Malvar2004`.
//! - **Hamilton–Adams** adaptive colour plane interpolation ([`rgb_from_mosaic_hamilton_adams`]),
//!   written from US patent 5,629,734. Green at an R/B pixel, with classifiers
//!   `ΔH = |G4 − G6| + |2A − A3 − A7|` and `ΔV = |G2 − G8| + |2A − A1 − A9|`:
//!   `ΔH < ΔV ⇒ G = (G4 + G6)/2 + (2A − A3 − A7)/4`; `ΔH > ΔV ⇒ G = (G2 + G8)/2 + (2A − A1 − A9)/4`;
//!   equal ⇒ the average of both (`(G2+G4+G6+G8)/4 + (4A − A1 − A3 − A7 − A9)/8`).
//!   Then red and blue by colour differences with the full green plane: at a green pixel from the
//!   two neighbours in the row (or column) that carry the colour, `C = (C_a + C_b)/2 + (2G − G_a − G_b)/2`;
//!   at a blue (red) pixel, red (blue) from the two diagonals with classifiers
//!   `ΔN = |C_nw − C_se| + |2G − G_nw − G_se|`, `ΔP = |C_ne − C_sw| + |2G − G_ne − G_sw|`, the
//!   smaller one's direction `C = (C_a + C_b)/2 + (2G − G_a − G_b)/2`, the average on a tie.
//!
//! ## Borders and range
//!
//! Neighbours outside the image are read by mirroring without repeating the edge sample
//! (`-1 → 1`), which keeps the CFA parity, so border pixels are interpolated from real samples of
//! the right colour. colour-demosaicing uses scipy's default `reflect` mode (`-1 → 0`), which
//! mixes colours at the border: the parity test compares away from the border (2 pixels for
//! Malvar, 1 for bilinear). The `f32` core does not clip (Malvar, bicubic and Hamilton–Adams can
//! overshoot); the integer wrappers round and clamp to the container range.
//!
//! ## References
//! - H. S. Malvar, L.-W. He, R. Cutler, "High-quality linear interpolation for demosaicing of
//!   Bayer-patterned color images", ICASSP 2004.
//! - J. F. Hamilton Jr., J. E. Adams Jr., "Adaptive color plan interpolation in single sensor
//!   color electronic camera", US patent 5,629,734 (1997).
//! - R. Keys, "Cubic convolution interpolation for digital image processing", IEEE TASSP 1981.
//! - colour-demosaicing (Colour Developers), `demosaicing_CFA_Bayer_bilinear`, `..._Malvar2004`.

use std::fmt;
use std::str::FromStr;

use rayon::prelude::*;

use super::{mirror, IspError};
use crate::image::{Image, ImageView};
use crate::raw::{Cfa, Colour};

/// Rows per parallel strip.
pub(crate) const DEMOSAIC_STRIP_ROWS: usize = 16;

/// A demosaicing method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum DemosaicMethod {
    /// Copy from the 2x2 tile.
    Nearest,
    /// Bilinear (3x3 kernels).
    Bilinear,
    /// Bicubic (Keys a = −0.5) per channel lattice.
    Bicubic,
    /// Malvar–He–Cutler 2004 gradient-corrected bilinear.
    Malvar,
    /// Hamilton–Adams adaptive colour plane interpolation.
    HamiltonAdams,
}

impl DemosaicMethod {
    /// Every method, cheapest first.
    pub fn all() -> [DemosaicMethod; 5] {
        [
            DemosaicMethod::Nearest,
            DemosaicMethod::Bilinear,
            DemosaicMethod::Bicubic,
            DemosaicMethod::Malvar,
            DemosaicMethod::HamiltonAdams,
        ]
    }

    /// Short name (`nearest`, `bilinear`, `bicubic`, `malvar`, `hamilton-adams`).
    pub fn name(self) -> &'static str {
        match self {
            DemosaicMethod::Nearest => "nearest",
            DemosaicMethod::Bilinear => "bilinear",
            DemosaicMethod::Bicubic => "bicubic",
            DemosaicMethod::Malvar => "malvar",
            DemosaicMethod::HamiltonAdams => "hamilton-adams",
        }
    }
}

impl fmt::Display for DemosaicMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error parsing a demosaicing method name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown demosaicing method {0:?}: expected nearest, bilinear, bicubic, malvar or hamilton-adams")]
pub struct ParseDemosaicMethodError(pub String);

impl FromStr for DemosaicMethod {
    type Err = ParseDemosaicMethodError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().replace('_', "-").as_str() {
            "nearest" | "nn" => Ok(DemosaicMethod::Nearest),
            "bilinear" => Ok(DemosaicMethod::Bilinear),
            "bicubic" => Ok(DemosaicMethod::Bicubic),
            "malvar" | "malvar2004" | "mhc" => Ok(DemosaicMethod::Malvar),
            "hamilton-adams" | "hamiltonadams" | "ha" | "acpi" => Ok(DemosaicMethod::HamiltonAdams),
            _ => Err(ParseDemosaicMethodError(s.to_string())),
        }
    }
}

/// Read access to a mosaic at integer offsets around the pixel being computed.
trait Access {
    fn at(&self, x: isize, y: isize) -> f32;
}

/// Mirror-bordered read access (any position).
#[derive(Clone, Copy)]
struct Src<'a> {
    v: ImageView<'a, f32>,
    w: usize,
    h: usize,
}

/// Unmirrored read access, valid only where every tap lies inside the image (the interior fast
/// path; it returns exactly what [`Src`] returns there).
#[derive(Clone, Copy)]
struct Direct<'a> {
    data: &'a [f32],
    stride: usize,
}

impl Access for Direct<'_> {
    #[inline(always)]
    fn at(&self, x: isize, y: isize) -> f32 {
        debug_assert!(x >= 0 && y >= 0);
        self.data[y as usize * self.stride + x as usize]
    }
}

impl<'a> Src<'a> {
    fn direct(&self) -> Direct<'a> {
        Direct {
            data: self.v.as_slice(),
            stride: self.v.stride(),
        }
    }
}

impl Access for Src<'_> {
    #[inline]
    fn at(&self, x: isize, y: isize) -> f32 {
        let xi = if x >= 0 && (x as usize) < self.w {
            x as usize
        } else {
            mirror(x, self.w)
        };
        let yi = if y >= 0 && (y as usize) < self.h {
            y as usize
        } else {
            mirror(y, self.h)
        };
        self.v.get(xi, yi)
    }
}

#[inline]
fn ci(c: Colour) -> usize {
    match c {
        Colour::Red => 0,
        Colour::Green => 1,
        Colour::Blue => 2,
    }
}

/// Channel index (0 R, 1 G, 2 B) at a possibly negative position (parity only matters).
#[inline]
fn chan(cfa: Cfa, x: isize, y: isize) -> usize {
    ci(cfa.colour_at((x & 1) as usize, (y & 1) as usize))
}

/// Malvar–He–Cutler kernels `[dy + 2][dx + 2]`, over [`MALVAR_NORM`]: G at R/B sites.
const MALVAR_G_AT_RB: [[f32; 5]; 5] = [
    [0.0, 0.0, -1.0, 0.0, 0.0],
    [0.0, 0.0, 2.0, 0.0, 0.0],
    [-1.0, 2.0, 4.0, 2.0, -1.0],
    [0.0, 0.0, 2.0, 0.0, 0.0],
    [0.0, 0.0, -1.0, 0.0, 0.0],
];
/// R (B) at a green site whose row neighbours are R (B).
const MALVAR_ROW: [[f32; 5]; 5] = [
    [0.0, 0.0, 0.5, 0.0, 0.0],
    [0.0, -1.0, 0.0, -1.0, 0.0],
    [-1.0, 4.0, 5.0, 4.0, -1.0],
    [0.0, -1.0, 0.0, -1.0, 0.0],
    [0.0, 0.0, 0.5, 0.0, 0.0],
];
/// R (B) at a green site whose column neighbours are R (B) (transpose of [`MALVAR_ROW`]).
const MALVAR_COL: [[f32; 5]; 5] = [
    [0.0, 0.0, -1.0, 0.0, 0.0],
    [0.0, -1.0, 4.0, -1.0, 0.0],
    [0.5, 0.0, 5.0, 0.0, 0.5],
    [0.0, -1.0, 4.0, -1.0, 0.0],
    [0.0, 0.0, -1.0, 0.0, 0.0],
];
/// R at B sites and B at R sites.
const MALVAR_DIAG: [[f32; 5]; 5] = [
    [0.0, 0.0, -1.5, 0.0, 0.0],
    [0.0, 2.0, 0.0, 2.0, 0.0],
    [-1.5, 0.0, 6.0, 0.0, -1.5],
    [0.0, 2.0, 0.0, 2.0, 0.0],
    [0.0, 0.0, -1.5, 0.0, 0.0],
];
/// The Malvar kernels are divided by this.
const MALVAR_NORM: f32 = 8.0;

/// Keys cubic (a = −0.5) weights at distances 1/2 and 3/2: `9/16` and `−1/16`.
const CUBIC_NEAR: f32 = 9.0 / 16.0;
const CUBIC_FAR: f32 = -1.0 / 16.0;
/// Quincunx (green) bicubic taps `(dx, dy, weight)`: products of the diagonal cubic weights.
const BICUBIC_G: [(isize, isize, f32); 16] = {
    const N: f32 = 81.0 / 256.0;
    const K: f32 = -9.0 / 256.0;
    const F: f32 = 1.0 / 256.0;
    [
        (-1, 0, N),
        (1, 0, N),
        (0, -1, N),
        (0, 1, N),
        (-2, -1, K),
        (-2, 1, K),
        (2, -1, K),
        (2, 1, K),
        (-1, -2, K),
        (1, -2, K),
        (-1, 2, K),
        (1, 2, K),
        (-3, 0, F),
        (3, 0, F),
        (0, -3, F),
        (0, 3, F),
    ]
};

/// Non-zero taps `(dx, dy, weight)` of a 5x5 kernel, zero-padded to [`MAX_TAPS`].
const MAX_TAPS: usize = 12;
type Taps = ([(isize, isize, f32); MAX_TAPS], usize);

const fn taps_of(k: &[[f32; 5]; 5]) -> Taps {
    let mut out = [(0isize, 0isize, 0f32); MAX_TAPS];
    let mut n = 0;
    let mut dy = 0;
    while dy < 5 {
        let mut dx = 0;
        while dx < 5 {
            if k[dy][dx] != 0.0 {
                out[n] = (dx as isize - 2, dy as isize - 2, k[dy][dx]);
                n += 1;
            }
            dx += 1;
        }
        dy += 1;
    }
    (out, n)
}

const TAPS_G_AT_RB: Taps = taps_of(&MALVAR_G_AT_RB);
const TAPS_ROW: Taps = taps_of(&MALVAR_ROW);
const TAPS_COL: Taps = taps_of(&MALVAR_COL);
const TAPS_DIAG: Taps = taps_of(&MALVAR_DIAG);

#[inline(always)]
fn conv5<A: Access>(s: &A, x: isize, y: isize, taps: &Taps) -> f32 {
    let mut acc = 0.0;
    for &(dx, dy, w) in &taps.0[..taps.1] {
        acc += w * s.at(x + dx, y + dy);
    }
    acc / MALVAR_NORM
}

fn px_nearest<A: Access>(s: &A, cfa: Cfa, x: isize, y: isize) -> [f32; 3] {
    let (tx, ty) = (x & !1, y & !1);
    let own = chan(cfa, x, y);
    let mut out = [0.0; 3];
    for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        let c = chan(cfa, tx + dx, ty + dy);
        if c != 1 {
            out[c] = s.at(tx + dx, ty + dy);
        }
    }
    out[1] = if own == 1 {
        s.at(x, y)
    } else {
        // the green of the tile on this row
        let gx = if x == tx { tx + 1 } else { tx };
        s.at(gx, y)
    };
    out
}

fn px_bilinear<A: Access>(s: &A, cfa: Cfa, x: isize, y: isize) -> [f32; 3] {
    // The masked-plane convolution with H_G = [0 1 0; 1 4 1; 0 1 0]/4 and
    // H_RB = [1 2 1; 2 4 2; 1 2 1]/4, written per site (taps summed in kernel order).
    let own = chan(cfa, x, y);
    let v = s.at(x, y);
    let (l, r, u, d) = (s.at(x - 1, y), s.at(x + 1, y), s.at(x, y - 1), s.at(x, y + 1));
    let mut out = [0.0; 3];
    out[own] = v;
    if own == 1 {
        let row_c = chan(cfa, x + 1, y);
        out[row_c] = (l + r) / 2.0;
        out[2 - row_c] = (u + d) / 2.0;
    } else {
        out[1] = (u + l + r + d) / 4.0;
        let diag = s.at(x - 1, y - 1) + s.at(x + 1, y - 1) + s.at(x - 1, y + 1) + s.at(x + 1, y + 1);
        out[2 - own] = diag / 4.0;
    }
    out
}

fn px_bicubic<A: Access>(s: &A, cfa: Cfa, x: isize, y: isize) -> [f32; 3] {
    let own = chan(cfa, x, y);
    let mut out = [0.0; 3];
    out[own] = s.at(x, y);
    // green
    if own != 1 {
        out[1] = BICUBIC_G
            .iter()
            .map(|&(dx, dy, w)| w * s.at(x + dx, y + dy))
            .sum();
    }
    // red and blue on their spacing-2 lattices
    const TAPS: [(isize, f32); 4] = [(-3, CUBIC_FAR), (-1, CUBIC_NEAR), (1, CUBIC_NEAR), (3, CUBIC_FAR)];
    for c in [0usize, 2] {
        if c == own {
            continue;
        }
        let (cx, cy) = if c == 0 {
            cfa.red_offset()
        } else {
            cfa.blue_offset()
        };
        let xs: &[(isize, f32)] = if (x & 1) as usize == cx {
            &[(0, 1.0)]
        } else {
            &TAPS
        };
        let ys: &[(isize, f32)] = if (y & 1) as usize == cy {
            &[(0, 1.0)]
        } else {
            &TAPS
        };
        let mut acc = 0.0;
        for &(dy, wy) in ys {
            for &(dx, wx) in xs {
                acc += wy * wx * s.at(x + dx, y + dy);
            }
        }
        out[c] = acc;
    }
    out
}

fn px_malvar<A: Access>(s: &A, cfa: Cfa, x: isize, y: isize) -> [f32; 3] {
    let own = chan(cfa, x, y);
    let v = s.at(x, y);
    match own {
        1 => {
            // which colour shares this row?
            let row_c = chan(cfa, x + 1, y);
            let col_c = 2 - row_c;
            let mut out = [0.0, v, 0.0];
            out[row_c] = conv5(s, x, y, &TAPS_ROW);
            out[col_c] = conv5(s, x, y, &TAPS_COL);
            out
        }
        c => {
            let mut out = [0.0; 3];
            out[c] = v;
            out[1] = conv5(s, x, y, &TAPS_G_AT_RB);
            out[2 - c] = conv5(s, x, y, &TAPS_DIAG);
            out
        }
    }
}

/// Hamilton–Adams green at a non-green site.
fn ha_green<A: Access>(s: &A, x: isize, y: isize) -> f32 {
    let a = s.at(x, y);
    let (g4, g6, g2, g8) = (s.at(x - 1, y), s.at(x + 1, y), s.at(x, y - 1), s.at(x, y + 1));
    let (a3, a7, a1, a9) = (s.at(x - 2, y), s.at(x + 2, y), s.at(x, y - 2), s.at(x, y + 2));
    let lap_h = 2.0 * a - a3 - a7;
    let lap_v = 2.0 * a - a1 - a9;
    let dh = (g4 - g6).abs() + lap_h.abs();
    let dv = (g2 - g8).abs() + lap_v.abs();
    let h = (g4 + g6) / 2.0 + lap_h / 4.0;
    let v = (g2 + g8) / 2.0 + lap_v / 4.0;
    if dh < dv {
        h
    } else if dv < dh {
        v
    } else {
        (h + v) / 2.0
    }
}

/// Hamilton–Adams full-colour pixel given the full green plane `g`.
fn px_hamilton_adams<A: Access>(s: &A, g: &A, cfa: Cfa, x: isize, y: isize) -> [f32; 3] {
    let own = chan(cfa, x, y);
    let gc = g.at(x, y);
    let mut out = [0.0; 3];
    out[1] = gc;
    // colour difference along one pair of neighbours
    let pair = |(ax, ay): (isize, isize), (bx, by): (isize, isize)| {
        (s.at(ax, ay) + s.at(bx, by)) / 2.0 + (2.0 * gc - g.at(ax, ay) - g.at(bx, by)) / 2.0
    };
    if own == 1 {
        let row_c = chan(cfa, x + 1, y);
        out[row_c] = pair((x - 1, y), (x + 1, y));
        out[2 - row_c] = pair((x, y - 1), (x, y + 1));
    } else {
        out[own] = s.at(x, y);
        let (nw, se, ne, sw) = ((x - 1, y - 1), (x + 1, y + 1), (x + 1, y - 1), (x - 1, y + 1));
        let cls = |(ax, ay): (isize, isize), (bx, by): (isize, isize)| {
            (s.at(ax, ay) - s.at(bx, by)).abs() + (2.0 * gc - g.at(ax, ay) - g.at(bx, by)).abs()
        };
        let (dn, dp) = (cls(nw, se), cls(ne, sw));
        let n = pair(nw, se);
        let p = pair(ne, sw);
        out[2 - own] = if dn < dp {
            n
        } else if dp < dn {
            p
        } else {
            (n + p) / 2.0
        };
    }
    out
}

fn check(src: &ImageView<'_, f32>, dst: &Image<[f32; 3]>) -> Result<(), IspError> {
    let (w, h) = (src.width(), src.height());
    if w < 2 || h < 2 {
        return Err(IspError::Empty { width: w, height: h });
    }
    if dst.dimensions() != (w, h) {
        return Err(IspError::SizeMismatch {
            src_w: w,
            src_h: h,
            dst_w: dst.width(),
            dst_h: dst.height(),
        });
    }
    Ok(())
}

/// Run `edge(x, y)` for pixels within `radius` of the border and `inner(x, y)` elsewhere, for
/// every pixel into `dst`, in parallel strips (or serially).
fn fill<T: Copy + Send + Sync>(
    dst: &mut Image<T>,
    parallel: bool,
    radius: usize,
    edge: impl Fn(isize, isize) -> T + Sync,
    inner: impl Fn(isize, isize) -> T + Sync,
) {
    let (w, h) = dst.dimensions();
    let strip = |(s, rows): (usize, &mut [T])| {
        for (r, row) in rows.chunks_mut(w).enumerate() {
            let y = s * DEMOSAIC_STRIP_ROWS + r;
            let yi = y as isize;
            if y < radius || y + radius >= h || w <= 2 * radius {
                for (x, d) in row.iter_mut().enumerate() {
                    *d = edge(x as isize, yi);
                }
                continue;
            }
            for (x, d) in row.iter_mut().enumerate() {
                let interior = x >= radius && x + radius < w;
                *d = if interior {
                    inner(x as isize, yi)
                } else {
                    edge(x as isize, yi)
                };
            }
        }
    };
    if parallel {
        dst.as_mut_slice()
            .par_chunks_mut(w * DEMOSAIC_STRIP_ROWS)
            .enumerate()
            .for_each(strip);
    } else {
        dst.as_mut_slice()
            .chunks_mut(w * DEMOSAIC_STRIP_ROWS)
            .enumerate()
            .for_each(strip);
    }
}

/// Tap radius of each method (how far from the pixel it reads).
const RADIUS_NEAREST: usize = 1;
const RADIUS_BILINEAR: usize = 1;
const RADIUS_BICUBIC: usize = 3;
const RADIUS_MALVAR: usize = 2;
const RADIUS_HA_GREEN: usize = 2;
const RADIUS_HA_RB: usize = 1;

/// How [`demosaic_impl`] runs: the production path, or serial / all-mirrored twins for tests.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
struct Mode {
    parallel: bool,
    /// Use the mirrored accessor everywhere (the oracle for the interior fast path).
    mirror_everywhere: bool,
}

const FAST: Mode = Mode {
    parallel: true,
    mirror_everywhere: false,
};

fn demosaic_impl(
    src: ImageView<'_, f32>,
    cfa: Cfa,
    method: DemosaicMethod,
    dst: &mut Image<[f32; 3]>,
    mode: Mode,
) -> Result<(), IspError> {
    check(&src, dst)?;
    let s = Src {
        v: src,
        w: src.width(),
        h: src.height(),
    };
    let d = s.direct();
    let par = mode.parallel;
    let r = |radius: usize| {
        if mode.mirror_everywhere {
            usize::MAX / 4
        } else {
            radius
        }
    };
    match method {
        DemosaicMethod::Nearest => fill(
            dst,
            par,
            r(RADIUS_NEAREST),
            |x, y| px_nearest(&s, cfa, x, y),
            |x, y| px_nearest(&d, cfa, x, y),
        ),
        DemosaicMethod::Bilinear => fill(
            dst,
            par,
            r(RADIUS_BILINEAR),
            |x, y| px_bilinear(&s, cfa, x, y),
            |x, y| px_bilinear(&d, cfa, x, y),
        ),
        DemosaicMethod::Bicubic => fill(
            dst,
            par,
            r(RADIUS_BICUBIC),
            |x, y| px_bicubic(&s, cfa, x, y),
            |x, y| px_bicubic(&d, cfa, x, y),
        ),
        DemosaicMethod::Malvar => fill(
            dst,
            par,
            r(RADIUS_MALVAR),
            |x, y| px_malvar(&s, cfa, x, y),
            |x, y| px_malvar(&d, cfa, x, y),
        ),
        DemosaicMethod::HamiltonAdams => {
            let mut green = Image::<f32>::new(s.w, s.h);
            fill(
                &mut green,
                par,
                r(RADIUS_HA_GREEN),
                |x, y| {
                    if chan(cfa, x, y) == 1 {
                        s.at(x, y)
                    } else {
                        ha_green(&s, x, y)
                    }
                },
                |x, y| {
                    if chan(cfa, x, y) == 1 {
                        d.at(x, y)
                    } else {
                        ha_green(&d, x, y)
                    }
                },
            );
            let g = Src {
                v: green.view(),
                w: s.w,
                h: s.h,
            };
            let gd = g.direct();
            fill(
                dst,
                par,
                r(RADIUS_HA_RB),
                |x, y| px_hamilton_adams(&s, &g, cfa, x, y),
                |x, y| px_hamilton_adams(&d, &gd, cfa, x, y),
            );
        }
    }
    Ok(())
}

/// Demosaic an `f32` mosaic of pattern `cfa` into `dst` (same size, at least 2x2) with `method`.
pub(crate) fn demosaic_into(
    src: ImageView<'_, f32>,
    cfa: Cfa,
    method: DemosaicMethod,
    dst: &mut Image<[f32; 3]>,
) -> Result<(), IspError> {
    demosaic_impl(src, cfa, method, dst, FAST)
}

/// Demosaic an `f32` mosaic with `method` (allocating).
pub fn rgb_from_mosaic(
    src: ImageView<'_, f32>,
    cfa: Cfa,
    method: DemosaicMethod,
) -> Result<Image<[f32; 3]>, IspError> {
    let mut dst = Image::new(src.width(), src.height());
    demosaic_into(src, cfa, method, &mut dst)?;
    Ok(dst)
}

/// Nearest-neighbour demosaicing (2x2 tile copy).
#[cfg(test)]
pub(crate) fn rgb_from_mosaic_nearest(
    src: ImageView<'_, f32>,
    cfa: Cfa,
) -> Result<Image<[f32; 3]>, IspError> {
    rgb_from_mosaic(src, cfa, DemosaicMethod::Nearest)
}

/// Bilinear demosaicing.
pub fn rgb_from_mosaic_bilinear(src: ImageView<'_, f32>, cfa: Cfa) -> Result<Image<[f32; 3]>, IspError> {
    rgb_from_mosaic(src, cfa, DemosaicMethod::Bilinear)
}

/// Bicubic (Keys a = −0.5) demosaicing.
#[cfg(test)]
pub(crate) fn rgb_from_mosaic_bicubic(
    src: ImageView<'_, f32>,
    cfa: Cfa,
) -> Result<Image<[f32; 3]>, IspError> {
    rgb_from_mosaic(src, cfa, DemosaicMethod::Bicubic)
}

/// Hamilton–Adams adaptive colour plane interpolation.
#[cfg(test)]
pub(crate) fn rgb_from_mosaic_hamilton_adams(
    src: ImageView<'_, f32>,
    cfa: Cfa,
) -> Result<Image<[f32; 3]>, IspError> {
    rgb_from_mosaic(src, cfa, DemosaicMethod::HamiltonAdams)
}

/// Demosaic a raw frame into linear camera RGB: each value is first normalised with the frame's
/// levels to `y = (v − black) / (white − black)` (no white balance, no colour matrix), then
/// demosaiced with `method` (unclipped `f32`).
#[cfg(test)]
pub(crate) fn rgb_from_raw(
    frame: &crate::raw::RawFrame,
    method: DemosaicMethod,
) -> Result<Image<[f32; 3]>, IspError> {
    let lin = super::noise::linear_from_raw(frame);
    rgb_from_mosaic(lin.view(), frame.cfa(), method)
}

/// Demosaic an 8-bit mosaic; results are rounded and clamped to `0..=255`.
pub fn rgb_from_mosaic_u8(
    src: ImageView<'_, u8>,
    cfa: Cfa,
    method: DemosaicMethod,
) -> Result<Image<[u8; 3]>, IspError> {
    let f = Image::from_fn(src.width(), src.height(), |x, y| src.get(x, y) as f32);
    let rgb = rgb_from_mosaic(f.view(), cfa, method)?;
    Ok(rgb.map(|p| p.map(|c| c.round().clamp(0.0, u8::MAX as f32) as u8)))
}

/// Demosaic a 16-bit mosaic; results are rounded and clamped to `0..=max` (e.g. the white level
/// or `2^bit_depth − 1`).
#[cfg(test)]
pub(crate) fn rgb_from_mosaic_u16(
    src: ImageView<'_, u16>,
    cfa: Cfa,
    method: DemosaicMethod,
    max: u16,
) -> Result<Image<[u16; 3]>, IspError> {
    let f = Image::from_fn(src.width(), src.height(), |x, y| src.get(x, y) as f32);
    let rgb = rgb_from_mosaic(f.view(), cfa, method)?;
    Ok(rgb.map(|p| p.map(|c| c.round().clamp(0.0, max as f32) as u16)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::RawFrame;

    /// Mosaic a full-colour image (test helper).
    fn mosaic_of(rgb: &Image<[f32; 3]>, cfa: Cfa) -> Image<f32> {
        Image::from_fn(rgb.width(), rgb.height(), |x, y| {
            rgb.get(x, y)[ci(cfa.colour_at(x, y))]
        })
    }

    fn smooth_rgb(w: usize, h: usize) -> Image<[f32; 3]> {
        Image::from_fn(w, h, |x, y| {
            let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
            [0.2 + 0.5 * u, 0.3 + 0.2 * u + 0.3 * v, 0.6 - 0.4 * v]
        })
    }

    #[test]
    fn flat_mosaic_gives_flat_image_all_methods_all_patterns() {
        let m = Image::<f32>::filled(9, 7, 0.37);
        for cfa in Cfa::ALL {
            for method in DemosaicMethod::all() {
                let rgb = rgb_from_mosaic(m.view(), cfa, method).unwrap();
                for p in rgb.as_slice() {
                    for c in p {
                        assert!((c - 0.37).abs() < 1e-6, "{cfa} {method}: {p:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn known_samples_are_kept() {
        // every method returns the measured channel unchanged at its own site
        let rgb = smooth_rgb(16, 12);
        for cfa in Cfa::ALL {
            let m = mosaic_of(&rgb, cfa);
            for method in DemosaicMethod::all() {
                let out = rgb_from_mosaic(m.view(), cfa, method).unwrap();
                for y in 0..12 {
                    for x in 0..16 {
                        let c = ci(cfa.colour_at(x, y));
                        assert_eq!(out.get(x, y)[c], m.get(x, y), "{cfa} {method} ({x},{y})");
                    }
                }
            }
        }
    }

    #[test]
    fn linear_ramps_are_reproduced_in_the_interior() {
        // bilinear, bicubic, Malvar and Hamilton-Adams are exact on planes (away from borders);
        // the colour differences here are planes too, so colour-difference corrections vanish.
        let rgb = smooth_rgb(20, 16);
        for cfa in Cfa::ALL {
            let m = mosaic_of(&rgb, cfa);
            for method in [
                DemosaicMethod::Bilinear,
                DemosaicMethod::Bicubic,
                DemosaicMethod::Malvar,
                DemosaicMethod::HamiltonAdams,
            ] {
                let out = rgb_from_mosaic(m.view(), cfa, method).unwrap();
                for y in 4..12 {
                    for x in 4..16 {
                        for c in 0..3 {
                            let (a, b) = (out.get(x, y)[c], rgb.get(x, y)[c]);
                            assert!((a - b).abs() < 1e-5, "{cfa} {method} ({x},{y}) c{c}: {a} vs {b}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn bicubic_reproduces_quadratics_where_bilinear_does_not() {
        // Keys' cubic (a = -1/2) reproduces polynomials up to degree 2, on the square R/B lattices
        // and (in rotated coordinates) on the green quincunx.
        let q = |x: f32, y: f32, k: f32| 0.2 + 0.003 * k * (x * x) - 0.002 * (x * y) + 0.001 * (y * y);
        let rgb = Image::from_fn(24, 20, |x, y| {
            let (x, y) = (x as f32, y as f32);
            [q(x, y, 1.0), q(x, y, 2.0), q(x, y, 0.5)]
        });
        for cfa in Cfa::ALL {
            let m = mosaic_of(&rgb, cfa);
            let bc = rgb_from_mosaic_bicubic(m.view(), cfa).unwrap();
            let bl = rgb_from_mosaic_bilinear(m.view(), cfa).unwrap();
            let (mut bc_err, mut bl_err) = (0f32, 0f32);
            for y in 3..17 {
                for x in 3..21 {
                    for c in 0..3 {
                        bc_err = bc_err.max((bc.get(x, y)[c] - rgb.get(x, y)[c]).abs());
                        bl_err = bl_err.max((bl.get(x, y)[c] - rgb.get(x, y)[c]).abs());
                    }
                }
            }
            assert!(bc_err < 2e-5, "{cfa}: bicubic error {bc_err}");
            assert!(bl_err > 1e-3, "{cfa}: bilinear error {bl_err}");
        }
    }

    #[test]
    fn bilinear_hand_computed() {
        // RGGB 4x4 mosaic with values = index; at B (1,1): R = mean of the 4 diagonal R
        // (0,0)=0,(2,0)=2,(0,2)=8,(2,2)=10 -> 5; G = mean of (1,0)=1,(0,1)=4,(2,1)=6,(1,2)=9 -> 5
        let m = Image::from_fn(4, 4, |x, y| (y * 4 + x) as f32);
        let out = rgb_from_mosaic_bilinear(m.view(), Cfa::Rggb).unwrap();
        assert_eq!(out.get(1, 1), [5.0, 5.0, 5.0]);
        // at Gr (1,0): R = mean of (0,0)=0 and (2,0)=2 -> 1; B = mean of (1,1)=5 and (1,-1)->(1,1)=5 -> 5
        assert_eq!(out.get(1, 0), [1.0, 1.0, 5.0]);
    }

    #[test]
    fn nearest_hand_computed() {
        let m = Image::from_fn(4, 2, |x, y| (y * 4 + x) as f32);
        // GRBG: tile (0..2, 0..2): G(0,0)=0 R(1,0)=1 B(0,1)=4 G(1,1)=5
        let out = rgb_from_mosaic_nearest(m.view(), Cfa::Grbg).unwrap();
        assert_eq!(out.get(0, 0), [1.0, 0.0, 4.0]);
        assert_eq!(out.get(1, 0), [1.0, 0.0, 4.0]); // R site takes the green of its row
        assert_eq!(out.get(0, 1), [1.0, 5.0, 4.0]);
        assert_eq!(out.get(3, 1), [3.0, 7.0, 6.0]);
    }

    #[test]
    fn hamilton_adams_hand_computed_green() {
        // RGGB, R site at (2,2) in a 5x5 patch: horizontal greens 10/30 (ΔH large),
        // vertical greens 20/20, red column flat -> vertical interpolation: G = 20 + 0.
        let mut m = Image::<f32>::filled(5, 5, 0.0);
        for (x, y, v) in [(1, 2, 10.0), (3, 2, 30.0), (2, 1, 20.0), (2, 3, 20.0)] {
            m.set(x, y, v);
        }
        for (x, y) in [(0, 2), (2, 2), (4, 2), (2, 0), (2, 4)] {
            m.set(x, y, 8.0);
        }
        let s = Src {
            v: m.view(),
            w: 5,
            h: 5,
        };
        // ΔH = |10-30| + |16-16| = 20, ΔV = 0 -> G = (20+20)/2 + 0
        assert_eq!(ha_green(&s, 2, 2), 20.0);
        // now make the red row curved: A3 = A7 = 4, A = 8 -> lap_h = 8, ΔH = 20 + 8
        m.set(0, 2, 4.0);
        m.set(4, 2, 4.0);
        let s = Src {
            v: m.view(),
            w: 5,
            h: 5,
        };
        assert_eq!(ha_green(&s, 2, 2), 20.0);
        // tie: equal classifiers -> average of both estimates
        let mut t = Image::<f32>::filled(5, 5, 0.0);
        for (x, y, v) in [
            (1, 2, 10.0),
            (3, 2, 14.0),
            (2, 1, 30.0),
            (2, 3, 34.0),
            (2, 2, 6.0),
        ] {
            t.set(x, y, v);
        }
        let s = Src {
            v: t.view(),
            w: 5,
            h: 5,
        };
        // ΔH = 4 + |12 - 0| = 16 = ΔV = 4 + 12 ; H = 12 + 3 = 15, V = 32 + 3 = 35 -> 25
        assert_eq!(ha_green(&s, 2, 2), 25.0);
    }

    /// A sharp vertical edge: left half dark, right half bright, grey (R = G = B).
    fn vertical_edge(w: usize, h: usize, edge: usize) -> Image<[f32; 3]> {
        Image::from_fn(w, h, |x, _| if x < edge { [0.1; 3] } else { [0.9; 3] })
    }

    #[test]
    fn hamilton_adams_interpolates_along_a_vertical_edge() {
        for cfa in Cfa::ALL {
            for edge in [7, 8] {
                let truth = vertical_edge(16, 12, edge);
                let m = mosaic_of(&truth, cfa);
                let ha = rgb_from_mosaic_hamilton_adams(m.view(), cfa).unwrap();
                let bl = rgb_from_mosaic_bilinear(m.view(), cfa).unwrap();
                let (mut ha_err, mut bl_err) = (0f32, 0f32);
                for y in 2..10 {
                    for x in 2..14 {
                        // green is interpolated vertically: exact everywhere, also at the edge
                        assert!(
                            (ha.get(x, y)[1] - truth.get(x, y)[1]).abs() < 1e-6,
                            "{cfa} edge {edge} ({x},{y})"
                        );
                        for c in 0..3 {
                            ha_err = ha_err.max((ha.get(x, y)[c] - truth.get(x, y)[c]).abs());
                            bl_err = bl_err.max((bl.get(x, y)[c] - truth.get(x, y)[c]).abs());
                        }
                    }
                }
                // no zipper: every HA channel is exact on a grey edge; bilinear smears by 0.2+
                assert!(ha_err < 1e-6, "{cfa} edge {edge}: HA max error {ha_err}");
                assert!(bl_err > 0.19, "{cfa} edge {edge}: bilinear max error {bl_err}");
            }
        }
    }

    #[test]
    fn hamilton_adams_horizontal_edge_too() {
        let truth = Image::from_fn(12, 16, |_, y| if y < 7 { [0.2; 3] } else { [0.8; 3] });
        for cfa in Cfa::ALL {
            let m = mosaic_of(&truth, cfa);
            let ha = rgb_from_mosaic_hamilton_adams(m.view(), cfa).unwrap();
            for y in 2..14 {
                for x in 2..10 {
                    for c in 0..3 {
                        assert!((ha.get(x, y)[c] - truth.get(x, y)[c]).abs() < 1e-6);
                    }
                }
            }
        }
    }

    #[test]
    fn parallel_equals_serial_and_fast_path_equals_mirrored() {
        let rgb = Image::from_fn(37, 53, |x, y| {
            let v = ((x * 7 + y * 13) % 17) as f32 / 17.0;
            [v, 1.0 - v, (x as f32 * 0.1).sin().abs()]
        });
        for cfa in Cfa::ALL {
            let m = mosaic_of(&rgb, cfa);
            for method in DemosaicMethod::all() {
                let mut a = Image::new(37, 53);
                let mut b = Image::new(37, 53);
                let mut c = Image::new(37, 53);
                demosaic_impl(m.view(), cfa, method, &mut a, FAST).unwrap();
                let serial = Mode {
                    parallel: false,
                    mirror_everywhere: false,
                };
                demosaic_impl(m.view(), cfa, method, &mut b, serial).unwrap();
                assert_eq!(a, b, "{cfa} {method}: parallel != serial");
                let mirrored = Mode {
                    parallel: false,
                    mirror_everywhere: true,
                };
                demosaic_impl(m.view(), cfa, method, &mut c, mirrored).unwrap();
                assert_eq!(a, c, "{cfa} {method}: interior fast path != mirrored path");
            }
        }
    }

    #[test]
    fn crop_at_any_offset_with_rephased_pattern_matches_the_full_result() {
        // Demosaicing a crop (pattern re-phased by Cfa::shifted) equals cropping the full result,
        // away from the crop's border (3 pixels: the largest tap radius). Nearest only at even
        // offsets: its tiles are aligned to the image origin.
        let rgb = Image::from_fn(30, 26, |x, y| {
            let v = ((x * 5 + y * 11) % 13) as f32 / 13.0;
            [v, (x as f32 * 0.3).cos().abs(), 1.0 - v * 0.5]
        });
        for cfa in Cfa::ALL {
            let m = mosaic_of(&rgb, cfa);
            for method in DemosaicMethod::all() {
                let full = rgb_from_mosaic(m.view(), cfa, method).unwrap();
                for (ox, oy) in [(1, 0), (0, 1), (1, 1), (3, 2), (2, 4)] {
                    if method == DemosaicMethod::Nearest && (ox % 2 == 1 || oy % 2 == 1) {
                        continue; // nearest copies from 2x2 tiles aligned to even coordinates
                    }
                    let crop = m.view().crop(ox, oy, 20, 18).unwrap();
                    let part = rgb_from_mosaic(crop, cfa.shifted(ox, oy), method).unwrap();
                    for y in 3..15 {
                        for x in 3..17 {
                            assert_eq!(
                                part.get(x, y),
                                full.get(x + ox, y + oy),
                                "{cfa} {method} +({ox},{oy})"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn raw_frames_are_normalised_before_demosaicing() {
        use crate::raw::Levels;
        // flat raw 600 with black 100, white 1100 -> 0.5 everywhere
        let f = RawFrame::from_u16(6, 4, vec![600; 24], Cfa::Gbrg, 12, Levels::uniform(100, 1100)).unwrap();
        let rgb = rgb_from_raw(&f, DemosaicMethod::HamiltonAdams).unwrap();
        assert!(rgb.as_slice().iter().all(|p| *p == [0.5; 3]));
    }

    #[test]
    fn integer_wrappers_round_and_clamp() {
        // Malvar overshoots on an impulse; the u8 wrapper clamps at 0 and 255
        let mut m = Image::<u8>::filled(8, 8, 0);
        m.set(4, 4, 255);
        let out = rgb_from_mosaic_u8(m.view(), Cfa::Rggb, DemosaicMethod::Malvar).unwrap();
        assert_eq!(out.get(4, 4)[0], 255);
        let m16 = Image::<u16>::filled(6, 6, 1000);
        let out = rgb_from_mosaic_u16(m16.view(), Cfa::Bggr, DemosaicMethod::Bicubic, 1023).unwrap();
        assert!(out.as_slice().iter().all(|p| *p == [1000; 3]));
    }

    #[test]
    fn rejects_bad_sizes_and_parses_names() {
        let m = Image::<f32>::filled(1, 5, 0.0);
        assert!(matches!(
            rgb_from_mosaic(m.view(), Cfa::Rggb, DemosaicMethod::Bilinear),
            Err(IspError::Empty { .. })
        ));
        let m = Image::<f32>::filled(4, 4, 0.0);
        let mut d = Image::new(3, 4);
        assert!(matches!(
            demosaic_into(m.view(), Cfa::Rggb, DemosaicMethod::Malvar, &mut d),
            Err(IspError::SizeMismatch { .. })
        ));
        for method in DemosaicMethod::all() {
            assert_eq!(method.name().parse::<DemosaicMethod>().unwrap(), method);
        }
        assert!("ahd".parse::<DemosaicMethod>().is_err());
    }
}
