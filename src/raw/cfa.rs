//! Colour filter array (Bayer) patterns.
//!
//! A Bayer sensor repeats a 2x2 tile of colour filters. We name patterns **physically**, by the
//! colours of the tile read left to right, top to bottom, starting at pixel (0, 0):
//!
//! ```text
//!   RGGB      BGGR      GRBG      GBRG
//!   R G       B G       G R       G B
//!   G B       G R       B G       R G
//! ```
//!
//! OpenCV names its conversion codes after the colours of the second row's second and third pixels,
//! so its names are shifted by one: an **RGGB** sensor is `COLOR_BayerBG2BGR` in OpenCV, BGGR is
//! `BayerRG`, GRBG is `BayerGB` and GBRG is `BayerGR`. [`Cfa::opencv_code_name`] gives the mapping;
//! every place where a pattern name meets OpenCV goes through it.
//!
//! Cropping a mosaic at an odd offset changes which colour sits at (0, 0); [`Cfa::shifted`]
//! re-phases the pattern (the same idea as rawler's `CFA::shift`).
//!
//! ```
//! use mosaicd::raw::{Cfa, Colour};
//! assert_eq!(Cfa::Rggb.colour_at(0, 0), Colour::Red);
//! assert_eq!(Cfa::Rggb.colour_at(1, 1), Colour::Blue);
//! // Cropping one column off an RGGB frame leaves a GRBG frame.
//! assert_eq!(Cfa::Rggb.shifted(1, 0), Cfa::Grbg);
//! assert_eq!(Cfa::Rggb.opencv_code_name(), "BayerBG");
//! ```

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// A colour of the filter over one photosite.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Colour {
    /// Red filter.
    Red,
    /// Green filter.
    Green,
    /// Blue filter.
    Blue,
}

/// One of the four photosites of the 2x2 tile, distinguishing the two greens.
///
/// `Gr` is the green that shares a row with red, `Gb` the green that shares a row with blue.
/// The super-pixel planes (R, G1, G2, B in the paper) are these four, in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CfaChannel {
    /// Red.
    R,
    /// Green on a red row (the paper's G1).
    Gr,
    /// Green on a blue row (the paper's G2).
    Gb,
    /// Blue.
    B,
}

impl CfaChannel {
    /// All four channels in plane order R, Gr, Gb, B.
    pub const ALL: [CfaChannel; 4] = [CfaChannel::R, CfaChannel::Gr, CfaChannel::Gb, CfaChannel::B];

    /// Index of this channel in plane order (R = 0, Gr = 1, Gb = 2, B = 3).
    pub fn index(self) -> usize {
        match self {
            CfaChannel::R => 0,
            CfaChannel::Gr => 1,
            CfaChannel::Gb => 2,
            CfaChannel::B => 3,
        }
    }

    /// The filter colour of this channel.
    pub fn colour(self) -> Colour {
        match self {
            CfaChannel::R => Colour::Red,
            CfaChannel::Gr | CfaChannel::Gb => Colour::Green,
            CfaChannel::B => Colour::Blue,
        }
    }
}

/// A 2x2 Bayer pattern, named physically by the tile starting at pixel (0, 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Cfa {
    /// R at (0,0), B at (1,1).
    Rggb,
    /// B at (0,0), R at (1,1).
    Bggr,
    /// G at (0,0), R at (1,0), B at (0,1).
    Grbg,
    /// G at (0,0), B at (1,0), R at (0,1).
    Gbrg,
}

/// Error parsing a pattern name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown CFA pattern {0:?}: expected one of RGGB, BGGR, GRBG, GBRG")]
pub struct ParseCfaError(pub String);

impl Cfa {
    /// All four patterns.
    pub const ALL: [Cfa; 4] = [Cfa::Rggb, Cfa::Bggr, Cfa::Grbg, Cfa::Gbrg];

    /// Position (x, y) of the red photosite inside the 2x2 tile.
    pub fn red_offset(self) -> (usize, usize) {
        match self {
            Cfa::Rggb => (0, 0),
            Cfa::Bggr => (1, 1),
            Cfa::Grbg => (1, 0),
            Cfa::Gbrg => (0, 1),
        }
    }

    /// Position (x, y) of the blue photosite inside the 2x2 tile.
    pub fn blue_offset(self) -> (usize, usize) {
        let (rx, ry) = self.red_offset();
        (rx ^ 1, ry ^ 1)
    }

    /// The pattern whose red photosite sits at `(rx, ry)` of the tile (each 0 or 1).
    pub fn from_red_offset(rx: usize, ry: usize) -> Cfa {
        match (rx & 1, ry & 1) {
            (0, 0) => Cfa::Rggb,
            (1, 1) => Cfa::Bggr,
            (1, 0) => Cfa::Grbg,
            _ => Cfa::Gbrg,
        }
    }

    /// The channel (R, Gr, Gb, B) of the photosite at (x, y).
    #[inline]
    pub fn channel_at(self, x: usize, y: usize) -> CfaChannel {
        let (rx, ry) = self.red_offset();
        let on_red_col = (x & 1) == rx;
        let on_red_row = (y & 1) == ry;
        match (on_red_col, on_red_row) {
            (true, true) => CfaChannel::R,
            (false, true) => CfaChannel::Gr,
            (true, false) => CfaChannel::Gb,
            (false, false) => CfaChannel::B,
        }
    }

    /// The filter colour at (x, y).
    #[inline]
    pub fn colour_at(self, x: usize, y: usize) -> Colour {
        self.channel_at(x, y).colour()
    }

    /// The channel at each position of the 2x2 tile, indexed `[(y & 1) * 2 + (x & 1)]`.
    pub fn tile(self) -> [CfaChannel; 4] {
        [
            self.channel_at(0, 0),
            self.channel_at(1, 0),
            self.channel_at(0, 1),
            self.channel_at(1, 1),
        ]
    }

    /// Position (x, y) inside the tile of a channel.
    pub fn offset_of(self, ch: CfaChannel) -> (usize, usize) {
        let (rx, ry) = self.red_offset();
        match ch {
            CfaChannel::R => (rx, ry),
            CfaChannel::Gr => (rx ^ 1, ry),
            CfaChannel::Gb => (rx, ry ^ 1),
            CfaChannel::B => (rx ^ 1, ry ^ 1),
        }
    }

    /// The pattern seen by a crop whose top-left corner is at (dx, dy) of this one.
    pub fn shifted(self, dx: usize, dy: usize) -> Cfa {
        let (rx, ry) = self.red_offset();
        Cfa::from_red_offset((rx + dx) & 1, (ry + dy) & 1)
    }

    /// The pattern after mirroring the image left-right (`width` is the image width).
    pub fn flipped_horizontally(self, width: usize) -> Cfa {
        let (rx, ry) = self.red_offset();
        // Only the parity matters; wrapping keeps width 0 from panicking (2^64 is even).
        Cfa::from_red_offset(width.wrapping_sub(1).wrapping_sub(rx) & 1, ry)
    }

    /// OpenCV's (shifted) name for this physical pattern, as used in `COLOR_<name>2BGR`.
    pub fn opencv_code_name(self) -> &'static str {
        match self {
            Cfa::Rggb => "BayerBG",
            Cfa::Bggr => "BayerRG",
            Cfa::Grbg => "BayerGB",
            Cfa::Gbrg => "BayerGR",
        }
    }

    /// The physical name, e.g. `"RGGB"`.
    pub fn name(self) -> &'static str {
        match self {
            Cfa::Rggb => "RGGB",
            Cfa::Bggr => "BGGR",
            Cfa::Grbg => "GRBG",
            Cfa::Gbrg => "GBRG",
        }
    }

    /// Foxglove `RawImage` encoding for 8-bit (`bayer_rggb8`) or 16-bit (`bayer_rggb16`) data.
    pub fn foxglove_encoding(self, sixteen_bit: bool) -> &'static str {
        match (self, sixteen_bit) {
            (Cfa::Rggb, false) => "bayer_rggb8",
            (Cfa::Bggr, false) => "bayer_bggr8",
            (Cfa::Grbg, false) => "bayer_grbg8",
            (Cfa::Gbrg, false) => "bayer_gbrg8",
            (Cfa::Rggb, true) => "bayer_rggb16",
            (Cfa::Bggr, true) => "bayer_bggr16",
            (Cfa::Grbg, true) => "bayer_grbg16",
            (Cfa::Gbrg, true) => "bayer_gbrg16",
        }
    }
}

impl fmt::Display for Cfa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Cfa {
    type Err = ParseCfaError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_uppercase().as_str() {
            "RGGB" => Ok(Cfa::Rggb),
            "BGGR" => Ok(Cfa::Bggr),
            "GRBG" => Ok(Cfa::Grbg),
            "GBRG" => Ok(Cfa::Gbrg),
            _ => Err(ParseCfaError(s.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_match_names() {
        use CfaChannel::*;
        assert_eq!(Cfa::Rggb.tile(), [R, Gr, Gb, B]);
        assert_eq!(Cfa::Bggr.tile(), [B, Gb, Gr, R]);
        assert_eq!(Cfa::Grbg.tile(), [Gr, R, B, Gb]);
        assert_eq!(Cfa::Gbrg.tile(), [Gb, B, R, Gr]);
        for cfa in Cfa::ALL {
            let name: String = cfa
                .tile()
                .iter()
                .map(|c| match c.colour() {
                    Colour::Red => 'R',
                    Colour::Green => 'G',
                    Colour::Blue => 'B',
                })
                .collect();
            assert_eq!(name, cfa.name());
            assert_eq!(cfa.name().parse::<Cfa>().unwrap(), cfa);
        }
    }

    #[test]
    fn shift_rephases_for_all_patterns_and_offsets() {
        for cfa in Cfa::ALL {
            for dy in 0..4 {
                for dx in 0..4 {
                    let s = cfa.shifted(dx, dy);
                    for y in 0..4 {
                        for x in 0..4 {
                            assert_eq!(s.channel_at(x, y), cfa.channel_at(x + dx, y + dy));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn offsets_round_trip() {
        for cfa in Cfa::ALL {
            for ch in CfaChannel::ALL {
                let (x, y) = cfa.offset_of(ch);
                assert_eq!(cfa.channel_at(x, y), ch);
            }
        }
    }

    #[test]
    fn opencv_names_are_shifted() {
        // OpenCV names the pattern by the second row's 2nd and 3rd pixels.
        for cfa in Cfa::ALL {
            let s = cfa.shifted(1, 1);
            let expect = format!("Bayer{}{}", &s.name()[0..1], &s.name()[1..2]);
            assert_eq!(cfa.opencv_code_name(), expect);
        }
    }

    #[test]
    fn horizontal_flip_rephases_and_never_panics() {
        for cfa in Cfa::ALL {
            for width in 1..6 {
                let f = cfa.flipped_horizontally(width);
                for y in 0..2 {
                    for x in 0..width {
                        assert_eq!(f.colour_at(x, y), cfa.colour_at(width - 1 - x, y));
                    }
                }
            }
            let _ = cfa.flipped_horizontally(0);
        }
    }

    #[test]
    fn parse_rejects_unknown() {
        assert!("RGBG".parse::<Cfa>().is_err());
    }
}
