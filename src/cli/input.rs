//! Shared input options for the one-frame subcommands (`gradients`, `detect`, `sift`): one flag
//! set, one loader ([`mosaicd::raw::load_input`]), so every command reads every input alike.
//!
//! Subcommands embed [`InputArgs`] with `#[command(flatten)]` and call [`InputArgs::load`]:
//!
//! ```text
//! mosaicd gradients DSC_1339_768x512_rggb.raw --width 768 --height 512 --bit-depth 14 \
//!     --cfa RGGB --black 600 --white 15520
//! mosaicd gradients bayer_small.png --cfa GRBG --bit-depth 10 --black 25 --white 1023
//! mosaicd gradients kodim01.png --cfa GRBG        # RGB resampled to a GRBG mosaic
//! mosaicd gradients RAW_KODAK_DC50.KDC            # camera raw (rawloader; Kodak DC40/DC50 RADC by our decoder)
//! ```

use std::path::PathBuf;

use anyhow::Context;

use mosaicd::raw::{load_input, Cfa, Container, Endian, InputOptions, LoadedInput};

/// Parse `--black`: one value for every tile position, or four comma-separated values in tile
/// order (0,0), (1,0), (0,1), (1,1).
fn parse_black(s: &str) -> Result<[u16; 4], String> {
    let vals: Result<Vec<u16>, _> = s.split(',').map(|v| v.trim().parse::<u16>()).collect();
    match vals.map_err(|e| format!("{s:?}: {e}"))?.as_slice() {
        [b] => Ok([*b; 4]),
        [a, b, c, d] => Ok([*a, *b, *c, *d]),
        v => Err(format!("expected 1 or 4 comma-separated values, got {}", v.len())),
    }
}

/// Input file and how to interpret it.
#[derive(clap::Args, Debug, Clone)]
pub struct InputArgs {
    /// Input: headerless raw (.raw/.bin or with --width/--height), grey PNG/PGM mosaic, RGB PNG/JPEG/BMP
    /// (resampled to --cfa), or a camera raw file (anything else: rawloader, or our Kodak RADC decoder).
    pub input: PathBuf,
    /// Width in pixels of a headerless raw file.
    #[arg(long)]
    pub width: Option<usize>,
    /// Height in pixels of a headerless raw file.
    #[arg(long)]
    pub height: Option<usize>,
    /// Significant bits per sample (8..=16) of a headerless file or grey PNG/PGM mosaic.
    #[arg(long, value_parser = clap::value_parser!(u8).range(8..=16))]
    pub bit_depth: Option<u8>,
    /// Physical CFA pattern (RGGB = red at (0,0)) of a headerless/PNG/PGM mosaic (required for
    /// those), or the pattern an RGB image is resampled into (default RGGB).
    #[arg(long)]
    pub cfa: Option<Cfa>,
    /// Black level: one value, or four comma-separated values per tile position. Default 0.
    #[arg(long, value_parser = parse_black)]
    pub black: Option<[u16; 4]>,
    /// White (saturation) level. Default 2^bit_depth - 1.
    #[arg(long)]
    pub white: Option<u16>,
    /// Byte order of 16-bit samples in a headerless file.
    #[arg(long, value_enum, default_value = "little")]
    pub endian: Endian,
    /// Row stride of a headerless file in bytes (default: no padding).
    #[arg(long = "stride")]
    pub stride_bytes: Option<usize>,
    /// Sample container of a headerless file (default: u8 for 8-bit, u16 above).
    #[arg(long, value_enum)]
    pub container: Option<Container>,
}

impl InputArgs {
    /// The loader options these arguments describe.
    pub fn options(&self) -> InputOptions {
        InputOptions {
            width: self.width,
            height: self.height,
            bit_depth: self.bit_depth,
            cfa: self.cfa,
            black: self.black,
            white: self.white,
            endian: self.endian,
            stride_bytes: self.stride_bytes,
            container: self.container,
        }
    }

    /// Load the input.
    pub fn load(&self) -> anyhow::Result<LoadedInput> {
        let loaded = load_input(&self.input, &self.options())
            .with_context(|| format!("loading input {}", self.input.display()))?;
        let f = &loaded.frame;
        tracing::info!(
            input = %self.input.display(),
            width = f.width(),
            height = f.height(),
            cfa = %f.cfa(),
            bit_depth = f.bit_depth(),
            black = ?f.levels().black,
            white = f.levels().white,
            wb_gains = %f.wb_gains.map_or("none".to_string(), |[r, g, b]| format!("{r},{g},{b}")),
            rgb = loaded.rgb.is_some(),
            "loaded input"
        );
        Ok(loaded)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        input: InputArgs,
    }

    #[test]
    fn loads_the_demo_frame() {
        let p = mosaicd::data::require("raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw");
        let c = Cli::try_parse_from([
            "x".as_ref(),
            p.as_os_str(),
            "--width".as_ref(),
            "768".as_ref(),
            "--height".as_ref(),
            "512".as_ref(),
            "--bit-depth".as_ref(),
            "14".as_ref(),
            "--cfa".as_ref(),
            "RGGB".as_ref(),
            "--black".as_ref(),
            "600".as_ref(),
            "--white".as_ref(),
            "15520".as_ref(),
        ])
        .unwrap();
        let l = c.input.load().unwrap();
        assert_eq!(
            (l.frame.width(), l.frame.height(), l.frame.bit_depth()),
            (768, 512, 14)
        );
        assert_eq!(l.frame.cfa(), Cfa::Rggb);
        assert!(l.rgb.is_none());
        // A wrong size is one clear error naming the file.
        let c = Cli::try_parse_from([
            "x".as_ref(),
            p.as_os_str(),
            "--width".as_ref(),
            "700".as_ref(),
            "--height".as_ref(),
            "512".as_ref(),
            "--bit-depth".as_ref(),
            "14".as_ref(),
            "--cfa".as_ref(),
            "RGGB".as_ref(),
        ])
        .unwrap();
        let e = format!("{:#}", c.input.load().unwrap_err());
        assert!(
            e.contains("DSC_1339_768x512_rggb.raw") && e.contains("786432"),
            "{e}"
        );
    }

    #[test]
    fn parses_demo_flags() {
        let c = Cli::try_parse_from([
            "x",
            "f.raw",
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
            "--endian",
            "big",
            "--stride",
            "1600",
            "--container",
            "u16",
        ])
        .unwrap();
        let o = c.input.options();
        assert_eq!(o.width, Some(768));
        assert_eq!(o.cfa, Some(Cfa::Rggb));
        assert_eq!(o.black, Some([600; 4]));
        assert_eq!(o.white, Some(15520));
        assert_eq!(o.endian, Endian::Big);
        assert_eq!(o.stride_bytes, Some(1600));
        assert_eq!(o.container, Some(Container::U16));
        let c = Cli::try_parse_from(["x", "f.png", "--black", "1,2,3,4", "--cfa", "gbrg"]).unwrap();
        assert_eq!(c.input.black, Some([1, 2, 3, 4]));
        assert_eq!(c.input.cfa, Some(Cfa::Gbrg));
        // No command normalises with gains or compression from the command line: refused, not
        // accepted and ignored.
        assert!(Cli::try_parse_from(["x", "f", "--gains", "1.5,1,2"]).is_err());
        assert!(Cli::try_parse_from(["x", "f", "--compress", "sqrt"]).is_err());
        assert!(Cli::try_parse_from(["x", "f", "--bit-depth", "17"]).is_err());
        assert!(Cli::try_parse_from(["x", "f", "--black", "1,2"]).is_err());
        assert!(Cli::try_parse_from(["x", "f", "--cfa", "RGBG"]).is_err());
    }
}
