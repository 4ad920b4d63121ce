//! Camera profiles: the sensor parameters the reverse and forward ISP need.
//!
//! A [`CameraProfile`] holds a sensor's black and white level at its bit depth, its
//! white-balance gains (R, G, B), its 3x3 colour correction matrix (camera RGB → linear sRGB,
//! applied after white balance, rows = output channels) and its CFA pattern. Profiles live in
//! `config/cameras/*.toml`:
//!
//! ```toml
//! name = "infinite-isp-indoor1"
//! bit_depth = 10
//! black_level = 50
//! white_level = 1023
//! cfa = "GRBG"
//! wb_gains = [1.44921875, 1.0, 3.2421875]
//! ccm = [[2.203125, -1.08984375, -0.11328125],
//!        [-0.29296875, 1.30859375, -0.015625],
//!        [0.05859375, -0.88671875, 1.828125]]
//! ```
//!
//! ```
//! use mosaicd::isp::CameraProfile;
//! let p = CameraProfile::default();
//! assert_eq!(p.name, "infinite-isp-indoor1");
//! let inv = p.ccm_inverse().unwrap();
//! // ccm * ccm^-1 = identity
//! let e: f64 = (0..3).map(|k| p.ccm[0][k] * inv[k][0]).sum();
//! assert!((e - 1.0).abs() < 1e-9);
//! ```
//!
//! ## The shipped profiles and the default
//!
//! The numbers come from the tuning files of the Infinite-ISP reference model (10xEngineers,
//! Apache-2.0) for its 10-bit GRBG CMOS sensor (`raw/infinite_isp_8bit/*-configs.yml` in the shared
//! data): black level 50, saturation 1023, `white_balance.r_gain`/`b_gain` (green gain 1) and
//! `color_correction_matrix.corrected_{red,green,blue}` in units of 1/1024 (Infinite-ISP applies
//! `ccm >> 10`); we store them divided by 1024. Two tunings exist: `Indoor1` (rows sum to 1, so
//! white stays white) and the `Outdoor1..4` one (shared by all four outdoor scenes).
//!
//! [`CameraProfile::default`] is the **Indoor1** tuning of that sensor (`config/cameras/infinite_isp_indoor1.toml`
//! holds the same numbers; a test checks they agree). We chose it because it is real and its
//! matrix preserves white, so the reverse ISP maps in-gamut sRGB into `[0, 1]` camera RGB.
//!
//! ## References
//! - 10xEngineers, Infinite-ISP reference model, <https://github.com/10x-Engineers/Infinite-ISP>.
//! - M. Buckler, S. Jayasuriya, A. Sampson, "Reconfiguring the Imaging Pipeline for Computer
//!   Vision", ICCV 2017 (camera model used for reverse ISP).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::IspError;
use crate::raw::Cfa;

/// Determinant below which a colour matrix is refused as singular.
const MIN_CCM_DET: f64 = 1e-6;

/// A sensor's parameters for the reverse and forward ISP.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraProfile {
    /// A short name (`infinite-isp-indoor1`).
    pub name: String,
    /// Black level in raw units at `bit_depth`.
    pub black_level: u16,
    /// White (saturation) level in raw units at `bit_depth`.
    pub white_level: u16,
    /// Significant bits of the sensor's values (8..=16).
    pub bit_depth: u8,
    /// White-balance gains (R, G, B) applied to camera RGB (forward ISP multiplies by them).
    pub wb_gains: [f64; 3],
    /// Colour correction matrix, camera RGB (white balanced) → linear sRGB; `ccm[row][col]`,
    /// rows are the output channels R, G, B.
    pub ccm: [[f64; 3]; 3],
    /// The sensor's CFA pattern.
    pub cfa: Cfa,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProfileFile {
    name: String,
    black_level: u16,
    white_level: u16,
    bit_depth: u8,
    wb_gains: [f64; 3],
    ccm: [[f64; 3]; 3],
    cfa: String,
}

impl Default for CameraProfile {
    /// The Infinite-ISP sensor's Indoor1 tuning (see the module docs).
    fn default() -> Self {
        Self {
            name: "infinite-isp-indoor1".to_string(),
            black_level: 50,
            white_level: 1023,
            bit_depth: 10,
            wb_gains: [1.449_218_75, 1.0, 3.242_187_5],
            ccm: [
                [2256.0 / 1024.0, -1116.0 / 1024.0, -116.0 / 1024.0],
                [-300.0 / 1024.0, 1340.0 / 1024.0, -16.0 / 1024.0],
                [60.0 / 1024.0, -908.0 / 1024.0, 1872.0 / 1024.0],
            ],
            cfa: Cfa::Grbg,
        }
    }
}

impl CameraProfile {
    /// Load and validate a profile from a TOML file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, IspError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| IspError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml_str(&text, path)
    }

    /// Parse and validate a profile from TOML text; `origin` names it in errors.
    pub fn from_toml_str(text: &str, origin: impl AsRef<Path>) -> Result<Self, IspError> {
        let origin: PathBuf = origin.as_ref().to_path_buf();
        let f: ProfileFile = toml::from_str(text).map_err(|e| IspError::ProfileSyntax {
            path: origin.clone(),
            source: Box::new(e),
        })?;
        let cfa: Cfa = f.cfa.parse().map_err(|source| IspError::Cfa {
            path: origin.clone(),
            source,
        })?;
        let p = Self {
            name: f.name,
            black_level: f.black_level,
            white_level: f.white_level,
            bit_depth: f.bit_depth,
            wb_gains: f.wb_gains,
            ccm: f.ccm,
            cfa,
        };
        p.validate()?;
        Ok(p)
    }

    /// A profile from the repository's `config/cameras/` directory by file stem
    /// (e.g. `"infinite_isp_indoor1"`).
    pub fn shipped(stem: &str) -> Result<Self, IspError> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("config/cameras")
            .join(format!("{stem}.toml"));
        Self::load(path)
    }

    /// Check every value: bit depth 8..=16, `black < white <= 2^bit_depth - 1`, finite positive
    /// gains, a finite invertible colour matrix.
    pub fn validate(&self) -> Result<(), IspError> {
        if self.name.trim().is_empty() {
            return Err(IspError::Param {
                name: "name",
                value: 0.0,
                why: "must not be empty",
            });
        }
        if !(8..=16).contains(&self.bit_depth) {
            return Err(IspError::Param {
                name: "bit_depth",
                value: self.bit_depth as f64,
                why: "must be in 8..=16",
            });
        }
        let max = (1u32 << self.bit_depth) - 1;
        if self.white_level as u32 > max {
            return Err(IspError::Param {
                name: "white_level",
                value: self.white_level as f64,
                why: "must fit in bit_depth bits",
            });
        }
        if self.black_level >= self.white_level {
            return Err(IspError::Param {
                name: "black_level",
                value: self.black_level as f64,
                why: "must be below white_level",
            });
        }
        const GAIN_NAMES: [&str; 3] = ["wb_gains[0]", "wb_gains[1]", "wb_gains[2]"];
        for (g, name) in self.wb_gains.iter().zip(GAIN_NAMES) {
            if !g.is_finite() || *g <= 0.0 {
                return Err(IspError::Param {
                    name,
                    value: *g,
                    why: "white-balance gains must be finite and > 0",
                });
            }
        }
        for v in self.ccm.iter().flatten() {
            if !v.is_finite() {
                return Err(IspError::Param {
                    name: "ccm",
                    value: *v,
                    why: "colour matrix entries must be finite",
                });
            }
        }
        self.ccm_inverse().map(|_| ())
    }

    /// The inverse colour matrix (linear sRGB → white-balanced camera RGB).
    pub fn ccm_inverse(&self) -> Result<[[f64; 3]; 3], IspError> {
        invert3(&self.ccm)
    }

    /// Black and white level rescaled to another bit depth: `v · (2^to − 1) / (2^from − 1)`,
    /// rounded. Returns `(black, white)`.
    pub fn levels_at(&self, bit_depth: u8) -> (u16, u16) {
        let from = ((1u32 << self.bit_depth) - 1) as f64;
        let to = ((1u32 << bit_depth.clamp(1, 16)) - 1) as f64;
        let s = to / from;
        let black = (self.black_level as f64 * s).round() as u16;
        let white = (self.white_level as f64 * s).round() as u16;
        (black, white)
    }
}

/// Invert a 3x3 matrix by cofactors.
pub(crate) fn invert3(m: &[[f64; 3]; 3]) -> Result<[[f64; 3]; 3], IspError> {
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let det = m[0][0] * c(1, 1, 2, 2) - m[0][1] * c(1, 0, 2, 2) + m[0][2] * c(1, 0, 2, 1);
    if !det.is_finite() || det.abs() < MIN_CCM_DET {
        return Err(IspError::SingularCcm { det });
    }
    let inv = [
        [c(1, 1, 2, 2) / det, -c(0, 1, 2, 2) / det, c(0, 1, 1, 2) / det],
        [-c(1, 0, 2, 2) / det, c(0, 0, 2, 2) / det, -c(0, 0, 1, 2) / det],
        [c(1, 0, 2, 1) / det, -c(0, 0, 2, 1) / det, c(0, 0, 1, 1) / det],
    ];
    Ok(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_of_hand_matrix() {
        // diag(2, 4, 5) with one off-diagonal: [[2,0,0],[0,4,0],[1,0,5]]
        let m = [[2.0, 0.0, 0.0], [0.0, 4.0, 0.0], [1.0, 0.0, 5.0]];
        let inv = invert3(&m).unwrap();
        let want = [[0.5, 0.0, 0.0], [0.0, 0.25, 0.0], [-0.1, 0.0, 0.2]];
        for r in 0..3 {
            for c in 0..3 {
                assert!((inv[r][c] - want[r][c]).abs() < 1e-12, "{r},{c}");
            }
        }
        assert!(matches!(
            invert3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]),
            Err(IspError::SingularCcm { .. })
        ));
    }

    #[test]
    fn default_profile_is_valid_and_white_preserving() {
        let p = CameraProfile::default();
        p.validate().unwrap();
        for row in p.ccm {
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn rejects_bad_values_with_the_key() {
        let good = CameraProfile::default();
        let mut p = good.clone();
        p.black_level = 1023;
        assert!(matches!(
            p.validate(),
            Err(IspError::Param {
                name: "black_level",
                ..
            })
        ));
        let mut p = good.clone();
        p.white_level = 2000;
        assert!(matches!(
            p.validate(),
            Err(IspError::Param {
                name: "white_level",
                ..
            })
        ));
        let mut p = good.clone();
        p.wb_gains[2] = 0.0;
        assert!(matches!(
            p.validate(),
            Err(IspError::Param {
                name: "wb_gains[2]",
                ..
            })
        ));
        let mut p = good.clone();
        p.bit_depth = 17;
        assert!(matches!(
            p.validate(),
            Err(IspError::Param {
                name: "bit_depth",
                ..
            })
        ));
        let mut p = good;
        p.ccm[1] = p.ccm[0];
        assert!(matches!(p.validate(), Err(IspError::SingularCcm { .. })));
    }

    #[test]
    fn parse_errors_name_the_problem() {
        let text = "name = \"x\"\nblack_level = 0\nwhite_level = 255\nbit_depth = 8\nwb_gains = [1.0, 1.0, 1.0]\nccm = [[1.0,0.0,0.0],[0.0,1.0,0.0],[0.0,0.0,1.0]]\ncfa = \"RGBG\"\n";
        assert!(matches!(
            CameraProfile::from_toml_str(text, "t.toml"),
            Err(IspError::Cfa { .. })
        ));
        let ok = text.replace("RGBG", "bggr");
        let p = CameraProfile::from_toml_str(&ok, "t.toml").unwrap();
        assert_eq!(p.cfa, Cfa::Bggr);
        let missing = ok.replace("bit_depth = 8\n", "");
        assert!(matches!(
            CameraProfile::from_toml_str(&missing, "t.toml"),
            Err(IspError::ProfileSyntax { .. })
        ));
    }

    #[test]
    fn levels_rescale_between_depths() {
        let p = CameraProfile::default();
        assert_eq!(p.levels_at(10), (50, 1023));
        // 50 * 16383 / 1023 = 800.7
        assert_eq!(p.levels_at(14), (801, 16383));
    }
}
