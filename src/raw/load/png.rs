//! 1-channel 8/16-bit PNG mosaics, and the `tEXt` description ([`PNG_TEXT_KEY`]) our own mosaic
//! PNGs carry (PNG: 16-bit samples are big-endian; the `png`/`image` crates return native values).

use std::path::Path;

use super::common::{format_err, io_err, mosaic_frame, MosaicFormat};
use super::rgb::decode_image;
use crate::raw::{Cfa, Levels, RawError, RawFrame, RawPixels};

/// Load a 1-channel 8- or 16-bit PNG as a mosaic.
pub fn load_png_mosaic(path: &Path, fmt: &MosaicFormat) -> Result<RawFrame, RawError> {
    png_mosaic_from_image(decode_image(path)?, fmt, path)
}

/// A decoded 1-channel 8- or 16-bit image as a mosaic (any other colour type is an error naming
/// `origin`).
pub(super) fn png_mosaic_from_image(
    img: image::DynamicImage,
    fmt: &MosaicFormat,
    origin: &Path,
) -> Result<RawFrame, RawError> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    match img {
        image::DynamicImage::ImageLuma8(g) => mosaic_frame(w, h, RawPixels::U8(g.into_raw()), 8, fmt, origin),
        image::DynamicImage::ImageLuma16(g) => {
            mosaic_frame(w, h, RawPixels::U16(g.into_raw()), 16, fmt, origin)
        }
        other => Err(format_err(
            origin,
            format!(
                "a mosaic PNG must be 1-channel 8- or 16-bit grey, this one is {:?}",
                other.color()
            ),
        )),
    }
}

/// Keyword of the PNG `tEXt` chunk in which [`write_png16`] records the pattern, bit depth and
/// levels, so that our own mosaic PNGs load without flags.
pub(super) const PNG_TEXT_KEY: &str = "mosaicd-mosaic";

/// What a mosaic PNG written by [`write_png16`] says about itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct PngMosaicMeta {
    /// Pattern at (0, 0).
    pub cfa: Cfa,
    /// Significant bits.
    pub bit_depth: u8,
    /// Levels.
    pub levels: Levels,
}

impl PngMosaicMeta {
    /// The text stored in the chunk: `cfa=RGGB bit_depth=14 black=600,600,600,600 white=15520`.
    #[cfg(test)]
    pub(super) fn to_text(self) -> String {
        let b = self.levels.black;
        format!(
            "cfa={} bit_depth={} black={},{},{},{} white={}",
            self.cfa, self.bit_depth, b[0], b[1], b[2], b[3], self.levels.white
        )
    }

    /// Parse [`PngMosaicMeta::to_text`]'s format; every field is required.
    pub(super) fn parse(text: &str) -> Option<Self> {
        let (mut cfa, mut bits, mut black, mut white) = (None, None, None, None);
        for field in text.split_whitespace() {
            let (k, v) = field.split_once('=')?;
            match k {
                "cfa" => cfa = v.parse::<Cfa>().ok(),
                "bit_depth" => bits = v.parse::<u8>().ok(),
                "black" => {
                    let b: Vec<u16> = v.split(',').map(|t| t.parse().ok()).collect::<Option<_>>()?;
                    black = <[u16; 4]>::try_from(b).ok();
                }
                "white" => white = v.parse::<u16>().ok(),
                _ => return None,
            }
        }
        Some(Self {
            cfa: cfa?,
            bit_depth: bits?,
            levels: Levels {
                black: black?,
                white: white?,
            },
        })
    }
}

/// Write a frame as a 16-bit grey PNG: values as stored (not scaled), with the pattern, bit depth
/// and levels in a `tEXt` chunk ([`PNG_TEXT_KEY`]) that [`super::load_input`] reads.
#[cfg(test)]
pub(super) fn write_png16(frame: &RawFrame, path: &Path) -> Result<(), RawError> {
    let (w, h) = (frame.width(), frame.height());
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(format_err(path, format!("frame {w}x{h} too large for PNG")));
    };
    let meta = PngMosaicMeta {
        cfa: frame.cfa(),
        bit_depth: frame.bit_depth(),
        levels: *frame.levels(),
    };
    let png_err = |e: png::EncodingError| match e {
        png::EncodingError::IoError(io) => io_err(path, io),
        other => format_err(path, format!("cannot write PNG: {other}")),
    };
    let file = std::fs::File::create(path).map_err(|e| io_err(path, e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w32, h32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Sixteen);
    enc.add_text_chunk(PNG_TEXT_KEY.to_string(), meta.to_text())
        .map_err(png_err)?;
    let mut writer = enc.write_header().map_err(png_err)?;
    let bytes: Vec<u8> = frame.to_u16_vec().iter().flat_map(|v| v.to_be_bytes()).collect();
    writer.write_image_data(&bytes).map_err(png_err)?;
    writer.finish().map_err(png_err)
}

/// Read a PNG's header without decoding the pixels: whether it is 1-channel grey, and our
/// [`PNG_TEXT_KEY`] description when it has one (a malformed description is an error).
pub(super) fn png_header(path: &Path) -> Result<(bool, Option<PngMosaicMeta>), RawError> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    png_header_from(std::io::BufReader::new(file), path)
}

/// [`png_header`] of a PNG read from `r`; `origin` names the source in errors.
pub(super) fn png_header_from<R: std::io::BufRead + std::io::Seek>(
    r: R,
    origin: &Path,
) -> Result<(bool, Option<PngMosaicMeta>), RawError> {
    let decoder = png::Decoder::new(r);
    let reader = decoder
        .read_info()
        .map_err(|e| format_err(origin, format!("cannot read PNG header: {e}")))?;
    let info = reader.info();
    let grey = matches!(info.color_type, png::ColorType::Grayscale);
    let meta = match info
        .uncompressed_latin1_text
        .iter()
        .find(|t| t.keyword == PNG_TEXT_KEY)
    {
        None => None,
        Some(t) => Some(PngMosaicMeta::parse(&t.text).ok_or_else(|| {
            format_err(
                origin,
                format!("malformed {PNG_TEXT_KEY} text chunk {:?}", t.text),
            )
        })?),
    };
    Ok((grey, meta))
}

/// Read the mosaic description [`write_png16`] stores in a PNG, if any.
#[cfg(test)]
pub(super) fn png_mosaic_meta(path: &Path) -> Result<Option<PngMosaicMeta>, RawError> {
    Ok(png_header(path)?.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::load::{load_input, InputOptions};

    #[test]
    fn png16_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let f = RawFrame::from_u16(
            2,
            3,
            vec![0, 1, 16383, 600, 9000, 5],
            Cfa::Gbrg,
            14,
            Levels::uniform(600, 15520),
        )
        .unwrap();
        let p = dir.path().join("m.png");
        write_png16(&f, &p).unwrap();
        let fmt = MosaicFormat {
            cfa: Cfa::Gbrg,
            bit_depth: Some(14),
            black: [600; 4],
            white: Some(15520),
        };
        let g = load_png_mosaic(&p, &fmt).unwrap();
        assert_eq!(g.to_u16_vec(), f.to_u16_vec());
        assert_eq!((g.width(), g.height(), g.cfa()), (2, 3, Cfa::Gbrg));
        // Impossible bit depths are errors, not panics.
        for bits in [0u8, 7, 17, 40] {
            let bad = MosaicFormat {
                bit_depth: Some(bits),
                white: None,
                ..fmt
            };
            assert!(
                matches!(load_png_mosaic(&p, &bad), Err(RawError::BitDepth { .. })),
                "{bits}"
            );
        }
        // Declaring too few bits is caught.
        let small = MosaicFormat {
            bit_depth: Some(10),
            white: None,
            ..fmt
        };
        assert!(matches!(
            load_png_mosaic(&p, &small),
            Err(RawError::ValueOutOfRange { .. })
        ));
        // Through the dispatcher, our own PNG describes itself: no flags needed.
        assert_eq!(
            png_mosaic_meta(&p).unwrap(),
            Some(PngMosaicMeta {
                cfa: Cfa::Gbrg,
                bit_depth: 14,
                levels: Levels::uniform(600, 15520)
            })
        );
        let l = load_input(&p, &InputOptions::default()).unwrap();
        assert_eq!(l.frame.to_u16_vec(), f.to_u16_vec());
        assert_eq!((l.frame.cfa(), l.frame.bit_depth()), (Cfa::Gbrg, 14));
        assert_eq!(*l.frame.levels(), Levels::uniform(600, 15520));
        // Flags override the description.
        let l = load_input(
            &p,
            &InputOptions {
                cfa: Some(Cfa::Rggb),
                white: Some(16000),
                ..InputOptions::default()
            },
        )
        .unwrap();
        assert_eq!(l.frame.cfa(), Cfa::Rggb);
        assert_eq!(*l.frame.levels(), Levels::uniform(600, 16000));
        // A grey PNG without the description needs its pattern.
        let plain = dir.path().join("plain.png");
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(2, 1, vec![1, 2])
            .unwrap()
            .save(&plain)
            .unwrap();
        assert!(matches!(
            load_input(&plain, &InputOptions::default()),
            Err(RawError::Format { .. })
        ));
        let opts = InputOptions {
            cfa: Some(Cfa::Gbrg),
            bit_depth: Some(14),
            black: Some([600; 4]),
            white: Some(15520),
            ..InputOptions::default()
        };
        let l = load_input(&p, &opts).unwrap();
        assert!(l.rgb.is_none());
        assert_eq!(l.frame.to_u16_vec(), f.to_u16_vec());
        assert_eq!(*l.frame.levels(), Levels::uniform(600, 15520));
    }

    #[test]
    fn png_description_round_trips_and_rejects_garbage() {
        let m = PngMosaicMeta {
            cfa: Cfa::Bggr,
            bit_depth: 12,
            levels: Levels {
                black: [1, 2, 3, 4],
                white: 4000,
            },
        };
        assert_eq!(m.to_text(), "cfa=BGGR bit_depth=12 black=1,2,3,4 white=4000");
        assert_eq!(PngMosaicMeta::parse(&m.to_text()), Some(m));
        for bad in [
            "",
            "cfa=BGGR bit_depth=12 black=1,2,3 white=4000",
            "cfa=XYZW bit_depth=12 black=1,2,3,4 white=4000",
            "cfa=BGGR bit_depth=12 black=1,2,3,4",
            "cfa=BGGR bit_depth=12 black=1,2,3,4 white=4000 extra=1",
        ] {
            assert_eq!(PngMosaicMeta::parse(bad), None, "{bad:?}");
        }
    }
}
