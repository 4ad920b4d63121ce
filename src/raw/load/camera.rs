//! Camera raw files: Kodak DC40/DC50 KDC through [`crate::raw::kodak_radc`], everything else
//! through `rawloader`.

use std::path::Path;

use super::common::{bits_for, format_err, meta_for, read_at_most, too_large};
use super::tiff_walk::{
    is_x3f, mrw_length_wrap, rawloader_ifd_visits, sony_srf_size, MAX_TIFF_IFD_VISITS, SRF_DATA_OFFSET,
};
use crate::raw::kodak_radc;
use crate::raw::{Cfa, FrameLimits, Levels, RawError, RawFrame, RawPixels};

/// Map rawloader's 2x2 pattern name to ours.
fn cfa_from_rawloader(name: &str, origin: &Path) -> Result<Cfa, RawError> {
    name.parse::<Cfa>().map_err(|_| {
        format_err(
            origin,
            format!("CFA pattern {name:?} is not one of the 2x2 Bayer patterns RGGB, BGGR, GRBG, GBRG"),
        )
    })
}

/// Room for a camera raw file's metadata and embedded previews on top of its samples, bytes.
pub(super) const CAMERA_RAW_SLACK_BYTES: u64 = 64 << 20;

/// The largest camera raw file accepted under `limits`: the samples of the largest frame (16 bits
/// each; compressed files are smaller) plus [`CAMERA_RAW_SLACK_BYTES`].
pub(super) fn max_camera_raw_bytes(limits: FrameLimits) -> u64 {
    limits.max_sample_bytes().saturating_add(CAMERA_RAW_SLACK_BYTES)
}

/// `rawloader::decode` with the panics it catches kept off stderr
/// ([`crate::quiet_panic::call_quietly`]): rawloader wraps its decoders in `catch_unwind` and
/// turns a panic into an error ("Caught a panic while decoding").
fn decode_quietly(bytes: &[u8]) -> Result<rawloader::RawImage, rawloader::RawLoaderError> {
    crate::quiet_panic::call_quietly("rawloader", || {
        rawloader::decode(&mut std::io::Cursor::new(bytes))
    })
}

/// Load a camera raw file: a Kodak DC40/DC50 KDC (identified by its TIFF make and model, see
/// [`crate::raw::kodak_radc`]) through our RADC decoder, anything else through `rawloader`.
///
/// The file is `stat`ed first: one larger than `max_camera_raw_bytes` is
/// [`RawError::FileTooLarge`] before it is read; a decoded frame beyond the frame-size limit is
/// [`RawError::TooLarge`] (rawloader allocates the frame its header describes while decoding:
/// that allocation is bounded by rawloader, not by us). Before rawloader is called, three
/// structures it cannot bound are refused: a TIFF structure whose IFD walks inside rawloader
/// (the file's TIFF tree, an MRW's TIFF block, a Sony file's private and SR2 IFDs, a Canon
/// CIFF's heaps) would exceed
/// [`MAX_TIFF_IFD_VISITS`] IFDs (counted by [`rawloader_ifd_visits`]) is [`RawError::TiffWalk`];
/// an MRW length that wraps rawloader's 32-bit arithmetic (`mrw_length_wrap`) is
/// [`RawError::MrwLength`]; a Sigma X3F (`is_x3f`: rawloader walks its TIFF and then decodes
/// none) is [`RawError::Format`]; a Sony SRF (`sony_srf_size`) whose declared image exceeds the
/// frame-size limit or does not fit in the file after `SRF_DATA_OFFSET` is
/// [`RawError::SrfSize`] (rawloader reserves `width * height * 2` bytes for it before reading
/// any: a failed reservation aborts the process).
pub fn load_camera_raw(path: &Path) -> Result<RawFrame, RawError> {
    let limits = FrameLimits::process();
    let bytes = read_at_most(path, max_camera_raw_bytes(limits), "a camera raw file")?;
    camera_raw_from_bytes(&bytes, path)
}

/// Decode the bytes of a camera raw file already in memory: everything [`load_camera_raw`] does
/// after its read (it calls this), with the same checks and errors; `path` names the source in
/// errors and in the frame's metadata. The caller bounds the bytes' length
/// (`max_camera_raw_bytes` is the file loader's bound).
pub fn camera_raw_from_bytes(bytes: &[u8], path: &Path) -> Result<RawFrame, RawError> {
    let limits = FrameLimits::process();
    if let Some(info) = kodak_radc::identify(bytes) {
        return load_kodak_radc(path, bytes, &info);
    }
    if is_x3f(bytes) {
        return Err(format_err(
            path,
            "Sigma X3F is not supported: rawloader 0.37 decodes no X3F image, and X3F holds three \
             colours per pixel, not a Bayer mosaic"
                .into(),
        ));
    }
    if let Some((offset, len)) = mrw_length_wrap(bytes) {
        return Err(RawError::MrwLength {
            path: path.to_path_buf(),
            offset,
            len,
        });
    }
    let visits = rawloader_ifd_visits(bytes, MAX_TIFF_IFD_VISITS);
    if visits > MAX_TIFF_IFD_VISITS {
        return Err(RawError::TiffWalk {
            path: path.to_path_buf(),
            visits,
            limit: MAX_TIFF_IFD_VISITS,
        });
    }
    if let Some((w, h)) = sony_srf_size(bytes) {
        let (width, height) = (u64::from(w), u64::from(h));
        let needed = width
            .saturating_mul(height)
            .saturating_mul(2)
            .saturating_add(SRF_DATA_OFFSET);
        let file_len = bytes.len() as u64;
        if limits.check(width, height).is_err() || needed > file_len {
            return Err(RawError::SrfSize {
                path: path.to_path_buf(),
                width,
                height,
                data_offset: SRF_DATA_OFFSET,
                needed,
                file_len,
                max_pixels: limits.max_pixels(),
                max_side: crate::raw::limits::MAX_SIDE as u64,
            });
        }
    }
    let raw = decode_quietly(bytes).map_err(|e| {
        let e = e.to_string();
        let first = e.lines().next().unwrap_or_default().trim().to_string();
        if first.contains("find a decoder") {
            // rawloader's own text goes on to ask for samples on its web site: not for our users.
            format_err(
                path,
                format!(
                    "not a supported input: no camera raw decoder knows this file (rawloader: {first}), \
                     and its extension is none of png, pgm, jpg, jpeg, bmp (images), raw, bin \
                     (headerless, with --width/--height or a sidecar)"
                ),
            )
        } else {
            // Only the first line: the rest of rawloader's messages asks for samples on its site.
            format_err(path, format!("rawloader: {first}"))
        }
    })?;
    let data = match raw.data {
        rawloader::RawImageData::Integer(ref d) => d,
        rawloader::RawImageData::Float(_) => {
            return Err(format_err(
                path,
                "floating-point raw data is not supported".into(),
            ))
        }
    };
    if raw.cpp != 1 {
        return Err(format_err(
            path,
            format!("{} components per pixel: not a Bayer mosaic", raw.cpp),
        ));
    }
    if raw.cfa.width != 2 || raw.cfa.height != 2 {
        return Err(format_err(
            path,
            format!(
                "CFA pattern {:?} is {}x{}, only 2x2 Bayer patterns are supported",
                raw.cfa.name, raw.cfa.width, raw.cfa.height
            ),
        ));
    }
    let full_cfa = cfa_from_rawloader(&raw.cfa.name, path)?;
    let (w, h) = (raw.width, raw.height);
    limits.check_usize(w, h).map_err(|l| too_large(path, l))?;
    if data.len() < w * h {
        return Err(format_err(
            path,
            format!("rawloader returned {} samples for {w}x{h}", data.len()),
        ));
    }
    // Black levels are given per colour (R, G, B, E); ours are per tile position.
    let mut black = [0u16; 4];
    for (i, b) in black.iter_mut().enumerate() {
        let (x, y) = (i & 1, i >> 1);
        *b = raw.blacklevels[raw.cfa.color_at(y, x).min(3)];
    }
    let white = *raw.whitelevels.iter().max().unwrap_or(&0);
    let max_value = data.iter().copied().max().unwrap_or(0);
    let bit_depth = bits_for(white.max(max_value) as u32);
    let levels = Levels { black, white };
    let full = RawFrame::new(w, h, w, RawPixels::U16(data.clone()), full_cfa, bit_depth, levels)?;
    let [top, right, bottom, left] = raw.crops;
    let cw = w.saturating_sub(left.saturating_add(right));
    let ch = h.saturating_sub(top.saturating_add(bottom));
    let mut frame = if (top, right, bottom, left) == (0, 0, 0, 0) {
        full
    } else {
        full.crop(left, top, cw, ch)?
    };
    let g = raw.wb_coeffs[1];
    let gains = [raw.wb_coeffs[0] / g, 1.0, raw.wb_coeffs[2] / g];
    if gains.iter().all(|v| v.is_finite() && *v > 0.0) {
        frame.wb_gains = Some(gains);
    }
    frame.meta = meta_for(path);
    Ok(frame)
}

/// A Kodak DC40/DC50 RADC file: 768x512 GRBG, linear 14-bit values, black 0, white 16383, no
/// white-balance gains in the file.
fn load_kodak_radc(path: &Path, bytes: &[u8], info: &kodak_radc::RadcInfo) -> Result<RawFrame, RawError> {
    let px = kodak_radc::decode(bytes, info).map_err(|e| {
        format_err(
            path,
            format!("{} {} (Kodak RADC): {e}", info.make, info.model_name),
        )
    })?;
    let levels = Levels::uniform(kodak_radc::BLACK, kodak_radc::WHITE);
    let frame = RawFrame::new(
        info.width,
        info.height,
        info.width,
        RawPixels::U16(px),
        kodak_radc::CFA,
        kodak_radc::BIT_DEPTH,
        levels,
    )?;
    Ok(frame.with_meta(meta_for(path)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_raw_garbage_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.nef");
        std::fs::write(&p, b"not a raw file at all").unwrap();
        assert!(matches!(load_camera_raw(&p), Err(RawError::Format { .. })));
    }
}
