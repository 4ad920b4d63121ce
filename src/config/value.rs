//! The keys written as one string and read as a typed value (`camera.cfa`, `camera.fourcc`,
//! `compute.detector`, `compute.svm`, `compute.mosaic_taps`, `compute.mosaic_tone`,
//! `compute.wb_gains`, `foxglove.listen`): each is parsed once, by serde, when the file is read,
//! with the library's own parser ([`Cfa`]'s, [`DetectorKind`]'s, [`ScorePrecision`]'s, …), and
//! written back by its name.
//!
//! A value a key refuses reaches the user as [`ConfigError::OutOfRange`], naming the key, the
//! value and the allowed values, like every range error of [`Config::validate`]: serde only
//! carries a message, so a refusal is the message [`Refused`] writes, and
//! [`ConfigError::from_toml`] finds its key (with the camera's index) at the span the TOML
//! parser reports for it.
//!
//! [`Config::validate`]: super::Config::validate

use std::fmt;
use std::net::SocketAddr;

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serializer};

use super::error::ConfigError;
use crate::detect::people::DetectorKind;
use crate::detect::ScorePrecision;
use crate::features::hog::MosaicTaps;
use crate::raw::levels::{Compression, Gains, NormaliseOptions};
use crate::raw::tone::MosaicTone;
use crate::raw::Cfa;

/// `compute.svm`: `"auto"` or a precision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SvmSetting {
    /// The precision measured faster on this process's kernel path ([`ScorePrecision::auto`]),
    /// resolved when the detector is built.
    #[default]
    Auto,
    /// This precision.
    Fixed(ScorePrecision),
}

impl SvmSetting {
    /// How [`SvmSetting::Auto`] is written.
    pub const AUTO: &'static str = "auto";

    /// The name in config files: `"auto"`, `"f32"` or `"i8"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => Self::AUTO,
            Self::Fixed(p) => p.name(),
        }
    }

    /// The precision the detector runs ([`ScorePrecision::auto`] for [`SvmSetting::Auto`]).
    pub fn precision(self) -> ScorePrecision {
        match self {
            Self::Auto => ScorePrecision::auto(),
            Self::Fixed(p) => p,
        }
    }
}

/// Between a refused value and its allowed values in [`Refused`]'s message (and in
/// [`ConfigError::OutOfRange`]'s).
const REFUSED: &str = " is out of range: allowed ";

/// A string a typed key refused: the message serde carries to [`ConfigError::from_toml`].
struct Refused {
    value: String,
    allowed: &'static str,
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}{REFUSED}{}", self.value, self.allowed)
    }
}

/// A string parsed by `parse`, or a [`Refused`] naming `allowed`.
fn parse_str<'de, D: Deserializer<'de>, T>(
    d: D,
    allowed: &'static str,
    parse: impl FnOnce(&str) -> Option<T>,
) -> Result<T, D::Error> {
    let value = String::deserialize(d)?;
    parse(&value).ok_or_else(|| D::Error::custom(Refused { value, allowed }))
}

impl ConfigError {
    /// The error of a TOML document `text` that did not deserialize: a typed key's refusal
    /// becomes [`ConfigError::OutOfRange`] with the dotted key found at the error's span (e.g.
    /// `camera[1].cfa`); anything else is [`ConfigError::Parse`] with the parser's message.
    pub(super) fn from_toml(text: &str, origin: &str, e: &toml::de::Error) -> Self {
        let refused = e
            .message()
            .rsplit_once(REFUSED)
            .zip(e.span())
            .and_then(|((_, allowed), span)| {
                let doc = toml::de::DeTable::parse(text).ok()?;
                let (key, value) = key_at(doc.get_ref(), &span, String::new())?;
                Some(ConfigError::OutOfRange {
                    key,
                    value: format!("{value:?}"),
                    allowed: allowed.to_string(),
                })
            });
        refused.unwrap_or_else(|| ConfigError::Parse {
            origin: origin.into(),
            message: e.to_string().trim().replace('\n', " "),
        })
    }
}

/// The dotted key (`compute.svm`, `camera[0].cfa`) of the string value at `span`, and the value.
fn key_at(
    table: &toml::de::DeTable<'_>,
    span: &std::ops::Range<usize>,
    prefix: String,
) -> Option<(String, String)> {
    table.iter().find_map(|(k, v)| {
        let key = if prefix.is_empty() {
            k.get_ref().to_string()
        } else {
            format!("{prefix}.{}", k.get_ref())
        };
        value_at(v, span, key)
    })
}

/// [`key_at`] for one value `v` of key `key`.
fn value_at(
    v: &toml::Spanned<toml::de::DeValue<'_>>,
    span: &std::ops::Range<usize>,
    key: String,
) -> Option<(String, String)> {
    // (not pruned by span: a table's span is its header's, not its keys')
    match v.get_ref() {
        toml::de::DeValue::String(s) if v.span() == *span => Some((key, s.to_string())),
        toml::de::DeValue::Table(t) => key_at(t, span, key),
        toml::de::DeValue::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| value_at(v, span, format!("{key}[{i}]"))),
        _ => None,
    }
}

/// `camera.cfa`: [`Cfa`], written by its name (`"RGGB"`, …; read in any case).
pub(super) fn cfa_de<'de, D: Deserializer<'de>>(d: D) -> Result<Cfa, D::Error> {
    parse_str(d, "one of RGGB, BGGR, GRBG, GBRG", |s| s.parse().ok())
}

pub(super) fn cfa_ser<S: Serializer>(v: &Cfa, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.name())
}

/// `camera.fourcc` (optional): 4 ASCII characters, as bytes
/// ([`crate::capture::v4l2_formats::parse_fourcc`]).
pub(super) fn fourcc_de<'de, D: Deserializer<'de>>(d: D) -> Result<Option<[u8; 4]>, D::Error> {
    parse_str(d, "4 ASCII characters, e.g. \"pRAA\" or \"RGGB\"", |s| {
        s.is_ascii()
            .then(|| crate::capture::v4l2_formats::parse_fourcc(s))
            .flatten()
    })
    .map(Some)
}

pub(super) fn fourcc_ser<S: Serializer>(v: &Option<[u8; 4]>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(f) => s.serialize_str(&fourcc_text(*f)),
        None => s.serialize_none(),
    }
}

/// The FourCC as written (its bytes are ASCII: the parser checked them).
pub(super) fn fourcc_text(f: [u8; 4]) -> String {
    f.iter().map(|&b| b as char).collect()
}

/// `compute.detector`: [`DetectorKind`], written by its name.
pub(super) fn detector_de<'de, D: Deserializer<'de>>(d: D) -> Result<DetectorKind, D::Error> {
    parse_str(d, "one of \"hog\", \"acf\"", |s| s.parse().ok())
}

pub(super) fn detector_ser<S: Serializer>(v: &DetectorKind, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.name())
}

/// `compute.svm`: what the config asks for, `"auto"` or a precision ([`SvmSetting`]).
pub(super) fn svm_de<'de, D: Deserializer<'de>>(d: D) -> Result<SvmSetting, D::Error> {
    parse_str(d, "one of \"f32\", \"i8\", \"auto\"", |s| {
        if s.eq_ignore_ascii_case(SvmSetting::AUTO) {
            Some(SvmSetting::Auto)
        } else {
            s.parse::<ScorePrecision>().ok().map(SvmSetting::Fixed)
        }
    })
}

pub(super) fn svm_ser<S: Serializer>(v: &SvmSetting, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.name())
}

/// How `"model"` (the model file's own setting, `None`) is written in `compute.mosaic_taps` and
/// `compute.mosaic_tone`.
const MODEL: &str = "model";

/// A `"model"`-or-value key: `None` for `"model"`, else the value parsed by `T`'s `FromStr`.
fn model_or<'de, D: Deserializer<'de>, T: std::str::FromStr>(
    d: D,
    allowed: &'static str,
) -> Result<Option<T>, D::Error> {
    parse_str(d, allowed, |s| match s {
        MODEL => Some(None),
        s => s.parse().ok().map(Some),
    })
}

/// `compute.mosaic_taps`: `None` for `"model"`, else [`MosaicTaps`].
pub(super) fn mosaic_taps_de<'de, D: Deserializer<'de>>(d: D) -> Result<Option<MosaicTaps>, D::Error> {
    model_or(d, "one of \"model\", \"same-site\", \"paper\"")
}

pub(super) fn mosaic_taps_ser<S: Serializer>(v: &Option<MosaicTaps>, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.map_or(MODEL, MosaicTaps::name))
}

/// `compute.mosaic_tone`: `None` for `"model"`, else [`MosaicTone`].
pub(super) fn mosaic_tone_de<'de, D: Deserializer<'de>>(d: D) -> Result<Option<MosaicTone>, D::Error> {
    model_or(d, "one of \"model\", \"linear\", \"srgb\"")
}

pub(super) fn mosaic_tone_ser<S: Serializer>(v: &Option<MosaicTone>, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.map_or(MODEL, MosaicTone::name))
}

/// `compute.wb_gains`: [`Gains`] ([`Gains`]' `FromStr`), fixed gains finite, > 0 and < 16 (what
/// [`NormaliseOptions::build`] accepts).
pub(super) fn wb_gains_de<'de, D: Deserializer<'de>>(d: D) -> Result<Gains, D::Error> {
    parse_str(
        d,
        "\"auto\", \"file\", \"grey-world\", \"none\" or \"R,G,B\" (each finite, > 0 and < 16)",
        |s| {
            let gains: Gains = s.parse().ok()?;
            NormaliseOptions {
                gains,
                compression: Compression::None,
            }
            .build()
            .ok()?;
            Some(gains)
        },
    )
}

pub(super) fn wb_gains_ser<S: Serializer>(v: &Gains, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&wb_gains_text(*v))
}

/// The gains as a config writes them (what the parser reads back to the same value).
pub(super) fn wb_gains_text(g: Gains) -> String {
    match g {
        Gains::Auto => "auto".into(),
        Gains::FromFile => "file".into(),
        Gains::GreyWorld => "grey-world".into(),
        Gains::None => "none".into(),
        Gains::Fixed([r, g, b]) => format!("{r},{g},{b}"),
    }
}

/// `foxglove.listen` (optional): a [`SocketAddr`].
pub(super) fn listen_de<'de, D: Deserializer<'de>>(d: D) -> Result<Option<SocketAddr>, D::Error> {
    parse_str(
        d,
        "an IP address and port, e.g. \"127.0.0.1:8765\" or \"[::1]:8765\"",
        |s| s.parse().ok(),
    )
    .map(Some)
}

pub(super) fn listen_ser<S: Serializer>(v: &Option<SocketAddr>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(a) => s.serialize_str(&a.to_string()),
        None => s.serialize_none(),
    }
}
