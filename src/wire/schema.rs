//! Message schemas of mosaicd recordings, and their encoders / decoders.
//!
//! A recording holds up to seven channels per camera (`<camera>` defaults to `camera`):
//!
//! | topic | schema name | schema encoding | message encoding | content |
//! |---|---|---|---|---|
//! | `/<camera>/raw` | `mosaicd.RawFrame` | `mosaicd.rawframe` | `mosaicd.rawframe.v1` | lossless raw frame, full bit depth |
//! | `/<camera>/preview` | `foxglove.RawImage` | `jsonschema` | `json` | 8-bit `bayer_*8` preview, maybe decimated |
//! | `/<camera>/annotations` | `foxglove.ImageAnnotations` | `jsonschema` | `json` | boxes (LINE_LOOP) + scores (texts), preview coordinates |
//! | `/<camera>/detections` | `mosaicd.Detections` | `jsonschema` | `json` | boxes in full-frame coordinates |
//! | `/<camera>/stats` | `mosaicd.Stats` | `jsonschema` | `json` | free-form pipeline statistics |
//! | `/<camera>/keypoints` | `foxglove.ImageAnnotations` | `jsonschema` | `json` | with `compute.keypoints`: mosaic SIFT keypoints as one POINTS annotation, preview coordinates |
//! | `/<camera>/sift` | `mosaicd.SiftFeatures` | `jsonschema` | `json` | with `compute.keypoints`: the keypoints in full-frame coordinates (x, y, size, angle, response, octave, layer), strongest first, and with `compute.keypoint_descriptors` their 128-byte descriptors (base64) |
//!
//! The `foxglove.*` JSON schemas are not written here: they are derived from the `foxglove`
//! crate's own definitions of those types ([`foxglove_json_schema`]), the SDK whose WebSocket
//! server the live view uses (it sends the same annotations protobuf-encoded:
//! `From<&ImageAnnotations> for foxglove::messages::ImageAnnotations`). The messages stay JSON,
//! byte for byte as before, so recordings read as they did.
//!
//! ## `mosaicd.RawFrame` (message encoding `mosaicd.rawframe.v1`)
//!
//! ```text
//! offset  size  content
//! 0       4     magic "MRF1"
//! 4       4     H = header length in bytes, u32 little-endian
//! 8       H     header: UTF-8 JSON object (RawFrameHeader, below)
//! 8+H     N     pixels, row-major, contiguous (no row padding):
//!               container_bits 8:  width*height bytes
//!               container_bits 16: width*height u16 little-endian, LSB-aligned values
//! ```
//!
//! The header is `{"sequence", "sensor_sequence" (null or integer), "timestamp_ns", "source",
//! "width", "height", "cfa" (physical name "RGGB" | "BGGR" | "GRBG" | "GBRG", R at (0,0) for RGGB),
//! "bit_depth" (8..=16), "container_bits" (8 | 16), "black" ([4] per 2x2 tile position
//! `(y&1)*2 + (x&1)`), "white", "wb_gains" (null or [R, G, B])}`. Nothing in it depends on the
//! wall clock: `timestamp_ns` is the frame's capture timestamp, which is also the MCAP log time.
//!
//! ```
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! use mosaicd::wire::schema::{decode_raw_frame, encode_raw_frame};
//! let f = RawFrame::from_u16(2, 2, vec![1, 2, 3, 4095], Cfa::Grbg, 12, Levels::uniform(64, 4095)).unwrap();
//! let mut buf = Vec::new();
//! encode_raw_frame(&f, &mut buf);
//! assert_eq!(&buf[..4], b"MRF1");
//! assert_eq!(decode_raw_frame(&buf).unwrap(), f);
//! ```

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::detect::Detection;
use crate::features::sift::Keypoint;
use crate::raw::{Cfa, FrameMeta, Levels, RawError, RawFrame, RawPixels, RawView};

/// Magic bytes opening every `mosaicd.RawFrame` message.
pub const RAW_FRAME_MAGIC: &[u8; 4] = b"MRF1";
/// Schema name of the raw-frame channel.
pub const RAW_FRAME_SCHEMA: &str = "mosaicd.RawFrame";
/// Schema encoding of the raw-frame channel (the schema data is this module's layout text).
pub const RAW_FRAME_SCHEMA_ENCODING: &str = "mosaicd.rawframe";
/// Message encoding of the raw-frame channel.
pub const RAW_FRAME_ENCODING: &str = "mosaicd.rawframe.v1";
/// Schema name of the Foxglove preview channel.
pub const RAW_IMAGE_SCHEMA: &str = "foxglove.RawImage";
/// Schema name of the Foxglove annotations channel.
pub const IMAGE_ANNOTATIONS_SCHEMA: &str = "foxglove.ImageAnnotations";
/// Schema name of our detections channel.
pub const DETECTIONS_SCHEMA: &str = "mosaicd.Detections";
/// Schema name of our stats channel.
pub const STATS_SCHEMA: &str = "mosaicd.Stats";
/// Schema name of our SIFT features channel.
pub const SIFT_FEATURES_SCHEMA: &str = "mosaicd.SiftFeatures";
/// Foxglove `PointsAnnotationType::POINTS`.
pub const POINTS_POINTS: u8 = 1;
/// Foxglove `PointsAnnotationType::LINE_LOOP`.
pub const POINTS_LINE_LOOP: u8 = 2;

/// The layout text stored as the `mosaicd.RawFrame` schema data.
pub const RAW_FRAME_SCHEMA_TEXT: &str = "mosaicd.RawFrame v1: magic \"MRF1\" (4 bytes); u32 LE header length H; \
H bytes UTF-8 JSON header {sequence:u64, sensor_sequence:u64|null, timestamp_ns:u64, source:string, width:u32, \
height:u32, cfa:\"RGGB\"|\"BGGR\"|\"GRBG\"|\"GBRG\" (physical, RGGB = red at (0,0)), bit_depth:8..16, \
container_bits:8|16, black:[u16;4] (index (y&1)*2+(x&1)), white:u16, wb_gains:[f32;3]|null}; then width*height \
pixels row-major without padding, u8 (container 8) or u16 little-endian LSB-aligned (container 16).";

/// JSON schema of `mosaicd.Detections`.
pub const DETECTIONS_JSON_SCHEMA: &str = r#"{"title":"mosaicd.Detections","description":"Person detections of one frame, full-frame pixel coordinates","type":"object","properties":{"sequence":{"type":"integer","minimum":0},"timestamp_ns":{"type":"integer","minimum":0},"frame_width":{"type":"integer","minimum":0},"frame_height":{"type":"integer","minimum":0},"detections":{"type":"array","items":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"width":{"type":"number"},"height":{"type":"number"},"score":{"type":"number"}}}}}}"#;

/// JSON schema of `mosaicd.SiftFeatures`.
pub const SIFT_FEATURES_JSON_SCHEMA: &str = r#"{"title":"mosaicd.SiftFeatures","description":"Mosaic SIFT keypoints of one frame, strongest first, full-frame pixel coordinates (pixel centres at integers); descriptors[i] belongs to keypoints[i] and is empty when the daemon computes no descriptors","type":"object","properties":{"sequence":{"type":"integer","minimum":0},"timestamp_ns":{"type":"integer","minimum":0},"frame_width":{"type":"integer","minimum":0},"frame_height":{"type":"integer","minimum":0},"keypoints":{"type":"array","items":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"size":{"type":"number"},"angle":{"type":"number"},"response":{"type":"number"},"octave":{"type":"integer"},"layer":{"type":"integer"}}}},"descriptors":{"type":"array","items":{"type":"string","contentEncoding":"base64"}}}}"#;

/// JSON schema of `mosaicd.Stats` (free-form object).
pub const STATS_JSON_SCHEMA: &str = r#"{"title":"mosaicd.Stats","description":"Pipeline statistics (counters, latency); free-form object","type":"object"}"#;

/// Foxglove's JSON form of `google.protobuf.Timestamp` (its JSON schemas' `time`).
const TIME_SCHEMA: &str = r#"{"type":"object","title":"time","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}}"#;
/// Foxglove's JSON form of `google.protobuf.Duration` (its JSON schemas' `duration`).
const DURATION_SCHEMA: &str = r#"{"type":"object","title":"duration","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}}"#;

/// JSON schema of `foxglove.RawImage`, from the `foxglove` crate's definition
/// ([`foxglove_json_schema`]).
pub fn raw_image_json_schema() -> String {
    foxglove_json_schema::<foxglove::messages::RawImage>()
}

/// JSON schema of `foxglove.ImageAnnotations`, from the `foxglove` crate's definition
/// ([`foxglove_json_schema`]).
pub fn image_annotations_json_schema() -> String {
    foxglove_json_schema::<foxglove::messages::ImageAnnotations>()
}

/// The JSON schema of a Foxglove message type, derived from the `foxglove` crate's own
/// definition of it (the protobuf descriptor its [`foxglove::Encode::get_schema`] gives), so the
/// recorder's JSON channels and the live view's protobuf ones share one home for Foxglove's
/// schemas: the SDK. Foxglove's JSON mapping: a message is an object of its fields by their
/// protobuf names; numbers are `number`, integers `integer` (unsigned ones `minimum: 0`), enums
/// `oneOf` their `{title, const}` values, `bytes` base64 strings, repeated fields arrays, and
/// `google.protobuf.Timestamp` / `Duration` are `{sec, nsec}`. Only the message and field names
/// and types come from the descriptor (it carries no comments). Deterministic (keys sorted).
pub fn foxglove_json_schema<T: foxglove::Encode>() -> String {
    use prost::Message as _;
    let schema = T::get_schema().expect("every foxglove message type has a schema");
    let set = prost_types::FileDescriptorSet::decode(schema.data.as_ref())
        .expect("the foxglove crate's own descriptors decode");
    let mut messages = std::collections::HashMap::new();
    let mut enums = std::collections::HashMap::new();
    for file in &set.file {
        let package = file.package();
        for m in &file.message_type {
            index_message(&format!(".{package}"), m, &mut messages, &mut enums);
        }
        for e in &file.enum_type {
            enums.insert(format!(".{package}.{}", e.name()), e);
        }
    }
    json_schema_of(&format!(".{}", schema.name), &messages, &enums).to_string()
}

type Messages<'a> = std::collections::HashMap<String, &'a prost_types::DescriptorProto>;
type Enums<'a> = std::collections::HashMap<String, &'a prost_types::EnumDescriptorProto>;

/// Index a message and its nested messages and enums by full name (`.package.Outer.Inner`).
fn index_message<'a>(
    scope: &str,
    m: &'a prost_types::DescriptorProto,
    messages: &mut Messages<'a>,
    enums: &mut Enums<'a>,
) {
    let name = format!("{scope}.{}", m.name());
    for n in &m.nested_type {
        index_message(&name, n, messages, enums);
    }
    for e in &m.enum_type {
        enums.insert(format!("{name}.{}", e.name()), e);
    }
    messages.insert(name, m);
}

/// The JSON schema of the message `full_name` (see [`foxglove_json_schema`]).
fn json_schema_of(full_name: &str, messages: &Messages<'_>, enums: &Enums<'_>) -> serde_json::Value {
    use prost_types::field_descriptor_proto::{Label, Type};
    use serde_json::json;
    match full_name {
        ".google.protobuf.Timestamp" => return serde_json::from_str(TIME_SCHEMA).expect("valid JSON"),
        ".google.protobuf.Duration" => return serde_json::from_str(DURATION_SCHEMA).expect("valid JSON"),
        _ => {}
    }
    let Some(m) = messages.get(full_name) else {
        // not in the descriptor set: an object, no more is known
        return json!({"title": full_name.trim_start_matches('.'), "type": "object"});
    };
    let mut props = serde_json::Map::new();
    for f in &m.field {
        let item = match f.r#type() {
            Type::Double | Type::Float => json!({"type": "number"}),
            Type::Uint32 | Type::Uint64 | Type::Fixed32 | Type::Fixed64 => {
                json!({"type": "integer", "minimum": 0})
            }
            Type::Int32 | Type::Int64 | Type::Sint32 | Type::Sint64 | Type::Sfixed32 | Type::Sfixed64 => {
                json!({"type": "integer"})
            }
            Type::Bool => json!({"type": "boolean"}),
            Type::String => json!({"type": "string"}),
            Type::Bytes => json!({"type": "string", "contentEncoding": "base64"}),
            Type::Enum => match enums.get(f.type_name()) {
                Some(e) => json!({
                    "title": f.type_name().trim_start_matches('.'),
                    "oneOf": e.value.iter().map(|v| json!({"title": v.name(), "const": v.number()})).collect::<Vec<_>>(),
                }),
                None => json!({"type": "integer"}),
            },
            Type::Message | Type::Group => json_schema_of(f.type_name(), messages, enums),
        };
        let v = if f.label() == Label::Repeated {
            json!({"type": "array", "items": item})
        } else {
            item
        };
        props.insert(f.name().to_string(), v);
    }
    json!({"title": full_name.trim_start_matches('.'), "type": "object", "properties": props})
}

/// Errors decoding messages of our schemas.
#[derive(Debug, thiserror::Error)]
pub enum SchemaError {
    /// The message does not start with [`RAW_FRAME_MAGIC`].
    #[error("not a mosaicd.RawFrame message: magic {found:?}, expected \"MRF1\"")]
    BadMagic {
        /// The first bytes found.
        found: Vec<u8>,
    },
    /// The message is shorter than its header says.
    #[error("mosaicd.RawFrame message is {len} bytes, its header needs {needed}")]
    Short {
        /// Bytes present.
        len: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// The JSON header (or a JSON message) does not parse.
    #[error("bad JSON in {what}: {source}")]
    Json {
        /// Which message.
        what: &'static str,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// An unknown CFA name.
    #[error("unknown CFA pattern {0:?} (expected RGGB, BGGR, GRBG or GBRG)")]
    Cfa(String),
    /// A container size other than 8 or 16 bits.
    #[error("container_bits {0} is not 8 or 16")]
    Container(u8),
    /// A pixel value above the frame's declared bit depth (what the file and V4L2 readers
    /// refuse too; `x`, `y` of the first one).
    #[error("pixel value {value} at ({x}, {y}) exceeds the declared {bit_depth}-bit range")]
    ValueOutOfRange {
        /// Value.
        value: u16,
        /// x.
        x: usize,
        /// y.
        y: usize,
        /// Declared depth.
        bit_depth: u8,
    },
    /// The header values do not make a valid frame.
    #[error("invalid frame in recording: {0}")]
    Frame(#[from] RawError),
}

/// The JSON header of a `mosaicd.RawFrame` message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RawFrameHeader {
    /// Our dense sequence number.
    pub sequence: u64,
    /// The driver's sequence number, if any.
    pub sensor_sequence: Option<u64>,
    /// Capture timestamp (ns), equal to the MCAP log time.
    pub timestamp_ns: u64,
    /// Where the frame came from.
    pub source: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Physical pattern name.
    pub cfa: String,
    /// Significant bits.
    pub bit_depth: u8,
    /// 8 or 16.
    pub container_bits: u8,
    /// Black level per tile position.
    pub black: [u16; 4],
    /// White level.
    pub white: u16,
    /// White-balance gains.
    pub wb_gains: Option<[f32; 3]>,
}

/// Append the `mosaicd.RawFrame` encoding of `frame` to `out` (cleared first).
pub fn encode_raw_frame(frame: &RawFrame, out: &mut Vec<u8>) {
    out.clear();
    let container_bits = match frame.pixels() {
        RawPixels::U8(_) => 8,
        RawPixels::U16(_) => 16,
    };
    let header = RawFrameHeader {
        sequence: frame.meta.sequence,
        sensor_sequence: frame.meta.sensor_sequence,
        timestamp_ns: frame.meta.timestamp_ns,
        source: frame.meta.source.to_string(),
        width: frame.width() as u32,
        height: frame.height() as u32,
        cfa: frame.cfa().name().to_string(),
        bit_depth: frame.bit_depth(),
        container_bits,
        black: frame.levels().black,
        white: frame.levels().white,
        wb_gains: frame.wb_gains,
    };
    let json = serde_json::to_vec(&header).expect("header serialises");
    let (w, h) = (frame.width(), frame.height());
    out.reserve(8 + json.len() + w * h * (container_bits as usize / 8));
    out.extend_from_slice(RAW_FRAME_MAGIC);
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&json);
    match frame.view() {
        RawView::U8(v) => {
            for y in 0..h {
                out.extend_from_slice(v.row(y));
            }
        }
        RawView::U16(v) => {
            for y in 0..h {
                for &p in v.row(y) {
                    out.extend_from_slice(&p.to_le_bytes());
                }
            }
        }
    }
}

/// Parse only the JSON header of a `mosaicd.RawFrame` message; returns it and the pixel bytes.
pub fn decode_raw_frame_header(data: &[u8]) -> Result<(RawFrameHeader, &[u8]), SchemaError> {
    if data.len() < 8 || &data[..4] != RAW_FRAME_MAGIC {
        return Err(SchemaError::BadMagic {
            found: data[..data.len().min(4)].to_vec(),
        });
    }
    let hlen = u32::from_le_bytes([data[4], data[5], data[6], data[7]]) as usize;
    let end = 8usize.saturating_add(hlen);
    if data.len() < end {
        return Err(SchemaError::Short {
            len: data.len(),
            needed: end,
        });
    }
    let header: RawFrameHeader =
        serde_json::from_slice(&data[8..end]).map_err(|source| SchemaError::Json {
            what: "mosaicd.RawFrame header",
            source,
        })?;
    Ok((header, &data[end..]))
}

/// Decode a `mosaicd.RawFrame` message into a contiguous [`RawFrame`] with its metadata.
pub fn decode_raw_frame(data: &[u8]) -> Result<RawFrame, SchemaError> {
    let (h, px) = decode_raw_frame_header(data)?;
    let cfa: Cfa = h.cfa.parse().map_err(|_| SchemaError::Cfa(h.cfa.clone()))?;
    let n = (h.width as usize).saturating_mul(h.height as usize);
    let bytes = match h.container_bits {
        8 => 1,
        16 => 2,
        other => return Err(SchemaError::Container(other)),
    };
    let needed = n.saturating_mul(bytes);
    if px.len() != needed {
        return Err(SchemaError::Short {
            len: data.len(),
            needed: (data.len() - px.len()).saturating_add(needed),
        });
    }
    let pixels = if bytes == 1 {
        RawPixels::U8(px.to_vec())
    } else {
        RawPixels::U16(
            px.chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect(),
        )
    };
    let levels = Levels {
        black: h.black,
        white: h.white,
    };
    let mut f = RawFrame::new(
        h.width as usize,
        h.height as usize,
        h.width as usize,
        pixels,
        cfa,
        h.bit_depth,
        levels,
    )?;
    // Values above the bit depth: refused as the file and V4L2 readers refuse them.
    if let RawPixels::U16(v) = f.pixels() {
        let max = f.max_value();
        if let Some(i) = v.iter().position(|&p| p > max) {
            return Err(SchemaError::ValueOutOfRange {
                value: v[i],
                x: i % f.width(),
                y: i / f.width(),
                bit_depth: f.bit_depth(),
            });
        }
    }
    f.wb_gains = h.wb_gains;
    f.meta = FrameMeta {
        sequence: h.sequence,
        sensor_sequence: h.sensor_sequence,
        timestamp_ns: h.timestamp_ns,
        source: Arc::from(h.source.as_str()),
    };
    Ok(f)
}

/// A `mosaicd.Detections` message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DetectionsMessage {
    /// Frame sequence number.
    pub sequence: u64,
    /// Frame capture timestamp (ns).
    pub timestamp_ns: u64,
    /// Frame width.
    pub frame_width: u32,
    /// Frame height.
    pub frame_height: u32,
    /// Boxes in full-frame pixel coordinates.
    pub detections: Vec<Detection>,
}

/// A `mosaicd.SiftFeatures` message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SiftFeaturesMessage {
    /// Frame sequence number.
    pub sequence: u64,
    /// Frame capture timestamp (ns).
    pub timestamp_ns: u64,
    /// Frame width.
    pub frame_width: u32,
    /// Frame height.
    pub frame_height: u32,
    /// Keypoints in full-frame mosaic pixel coordinates, strongest first.
    pub keypoints: Vec<Keypoint>,
    /// `descriptors[i]`: the 128-byte descriptor of `keypoints[i]`, standard padded base64; empty
    /// when no descriptors were computed.
    pub descriptors: Vec<String>,
}

/// Descriptors as standard padded base64 strings (Foxglove's JSON encoding of bytes), one each.
pub fn descriptors_base64(d: &[[u8; crate::features::sift::DESCRIPTOR_LEN]]) -> Vec<String> {
    d.iter().map(|x| base64_encode(x)).collect()
}

impl SiftFeaturesMessage {
    /// The decoded descriptors; `None` if one is not valid base64 of 128 bytes.
    pub fn decoded_descriptors(&self) -> Option<Vec<[u8; crate::features::sift::DESCRIPTOR_LEN]>> {
        self.descriptors
            .iter()
            .map(|s| base64_decode(s).and_then(|v| v.try_into().ok()))
            .collect()
    }
}

/// Foxglove `time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FoxgloveTime {
    /// Seconds.
    pub sec: u64,
    /// Nanoseconds, 0..1e9.
    pub nsec: u32,
}

impl FoxgloveTime {
    /// Split nanoseconds.
    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: ns / 1_000_000_000,
            nsec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// Foxglove `Point2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Point2 {
    /// x (pixels).
    pub x: f64,
    /// y (pixels).
    pub y: f64,
}

/// Foxglove `Color` (components 0..1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Color {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Alpha.
    pub a: f64,
}

/// Foxglove `PointsAnnotation`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointsAnnotation {
    /// Timestamp.
    pub timestamp: FoxgloveTime,
    /// Type (2 = LINE_LOOP).
    #[serde(rename = "type")]
    pub kind: u8,
    /// Points.
    pub points: Vec<Point2>,
    /// Outline colour.
    pub outline_color: Color,
    /// Per-point colours (empty).
    pub outline_colors: Vec<Color>,
    /// Fill colour.
    pub fill_color: Color,
    /// Stroke thickness (pixels).
    pub thickness: f64,
}

/// Foxglove `TextAnnotation`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TextAnnotation {
    /// Timestamp.
    pub timestamp: FoxgloveTime,
    /// Bottom-left origin of the text.
    pub position: Point2,
    /// Text.
    pub text: String,
    /// Font size (pixels).
    pub font_size: f64,
    /// Text colour.
    pub text_color: Color,
    /// Background colour.
    pub background_color: Color,
}

/// Foxglove `ImageAnnotations` (no circles from us, but the field is present).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImageAnnotations {
    /// Circles (always empty here).
    pub circles: Vec<serde_json::Value>,
    /// Boxes as LINE_LOOPs.
    pub points: Vec<PointsAnnotation>,
    /// Scores.
    pub texts: Vec<TextAnnotation>,
}

impl From<FoxgloveTime> for foxglove::messages::Timestamp {
    /// Seconds saturate at `u32::MAX` (the year 2106).
    fn from(t: FoxgloveTime) -> Self {
        Self::new(t.sec.min(u32::MAX as u64) as u32, t.nsec)
    }
}

impl From<Point2> for foxglove::messages::Point2 {
    fn from(p: Point2) -> Self {
        Self { x: p.x, y: p.y }
    }
}

impl From<Color> for foxglove::messages::Color {
    fn from(c: Color) -> Self {
        Self {
            r: c.r,
            g: c.g,
            b: c.b,
            a: c.a,
        }
    }
}

/// The same annotations as the SDK's protobuf message (the live view sends these): the same
/// points, colours, texts and timestamps; `kind` is Foxglove's `PointsAnnotation.Type` number in
/// both. No circles (we make none).
impl From<&ImageAnnotations> for foxglove::messages::ImageAnnotations {
    fn from(a: &ImageAnnotations) -> Self {
        Self {
            timestamp: None,
            circles: Vec::new(),
            points: a
                .points
                .iter()
                .map(|p| foxglove::messages::PointsAnnotation {
                    timestamp: Some(p.timestamp.into()),
                    r#type: p.kind as i32,
                    points: p.points.iter().map(|&q| q.into()).collect(),
                    outline_color: Some(p.outline_color.into()),
                    outline_colors: p.outline_colors.iter().map(|&c| c.into()).collect(),
                    fill_color: Some(p.fill_color.into()),
                    thickness: p.thickness,
                    metadata: Vec::new(),
                })
                .collect(),
            texts: a
                .texts
                .iter()
                .map(|t| foxglove::messages::TextAnnotation {
                    timestamp: Some(t.timestamp.into()),
                    position: Some(t.position.into()),
                    text: t.text.clone(),
                    font_size: t.font_size,
                    text_color: Some(t.text_color.into()),
                    background_color: Some(t.background_color.into()),
                    metadata: Vec::new(),
                })
                .collect(),
            metadata: Vec::new(),
        }
    }
}

/// Box outline colour in annotations (opaque green).
const BOX_COLOUR: Color = Color {
    r: 0.0,
    g: 1.0,
    b: 0.0,
    a: 1.0,
};
/// Transparent fill.
const NO_FILL: Color = Color {
    r: 0.0,
    g: 0.0,
    b: 0.0,
    a: 0.0,
};
/// Score label background (half-transparent black).
const LABEL_BACKGROUND: Color = Color {
    r: 0.0,
    g: 0.0,
    b: 0.0,
    a: 0.5,
};
/// Box stroke thickness, pixels.
const BOX_THICKNESS: f64 = 2.0;
/// Score label font size, pixels.
const LABEL_FONT_SIZE: f64 = 12.0;

/// Annotations for detections, with coordinates divided by `scale` (the preview decimation, so the
/// boxes sit on the preview image; 1 for full-frame coordinates).
pub fn annotations_from_detections(timestamp_ns: u64, dets: &[Detection], scale: f64) -> ImageAnnotations {
    let t = FoxgloveTime::from_ns(timestamp_ns);
    let s = if scale > 0.0 { 1.0 / scale } else { 1.0 };
    let mut points = Vec::with_capacity(dets.len());
    let mut texts = Vec::with_capacity(dets.len());
    for d in dets {
        let (x0, y0) = (d.x as f64 * s, d.y as f64 * s);
        let (x1, y1) = ((d.x + d.width) as f64 * s, (d.y + d.height) as f64 * s);
        points.push(PointsAnnotation {
            timestamp: t,
            kind: POINTS_LINE_LOOP,
            points: vec![
                Point2 { x: x0, y: y0 },
                Point2 { x: x1, y: y0 },
                Point2 { x: x1, y: y1 },
                Point2 { x: x0, y: y1 },
            ],
            outline_color: BOX_COLOUR,
            outline_colors: Vec::new(),
            fill_color: NO_FILL,
            thickness: BOX_THICKNESS,
        });
        texts.push(TextAnnotation {
            timestamp: t,
            position: Point2 { x: x0, y: y0 },
            text: format!("{:.2}", d.score),
            font_size: LABEL_FONT_SIZE,
            text_color: BOX_COLOUR,
            background_color: LABEL_BACKGROUND,
        });
    }
    ImageAnnotations {
        circles: Vec::new(),
        points,
        texts,
    }
}

/// Keypoint marker colour in annotations (opaque magenta, apart from the green boxes).
const KEYPOINT_COLOUR: Color = Color {
    r: 1.0,
    g: 0.0,
    b: 1.0,
    a: 1.0,
};
/// Keypoint marker size, pixels.
const KEYPOINT_THICKNESS: f64 = 4.0;

/// Annotations for keypoints: one `POINTS` annotation holding every keypoint, coordinates divided
/// by `scale` (the preview decimation; 1 for full-frame coordinates). An empty list gives no
/// annotation, so Foxglove clears the previous frame's points.
pub fn annotations_from_keypoints(timestamp_ns: u64, keypoints: &[Keypoint], scale: f64) -> ImageAnnotations {
    let t = FoxgloveTime::from_ns(timestamp_ns);
    let s = if scale > 0.0 { 1.0 / scale } else { 1.0 };
    let points = if keypoints.is_empty() {
        Vec::new()
    } else {
        vec![PointsAnnotation {
            timestamp: t,
            kind: POINTS_POINTS,
            points: keypoints
                .iter()
                .map(|k| Point2 {
                    x: k.x as f64 * s,
                    y: k.y as f64 * s,
                })
                .collect(),
            outline_color: KEYPOINT_COLOUR,
            outline_colors: Vec::new(),
            fill_color: KEYPOINT_COLOUR,
            thickness: KEYPOINT_THICKNESS,
        }]
    };
    ImageAnnotations {
        circles: Vec::new(),
        points,
        texts: Vec::new(),
    }
}

/// Foxglove `RawImage` (JSON: `data` is base64).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RawImageMessage {
    /// Timestamp.
    pub timestamp: FoxgloveTime,
    /// Frame id.
    pub frame_id: String,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// `bayer_rggb8` etc.
    pub encoding: String,
    /// Bytes per row.
    pub step: u32,
    /// Base64 pixel data.
    pub data: String,
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding (RFC 4648), as Foxglove's JSON `contentEncoding: base64` expects.
pub fn base64_encode(data: &[u8]) -> String {
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        out.push(B64[(n >> 18) as usize & 63] as char);
        out.push(B64[(n >> 12) as usize & 63] as char);
        out.push(if c.len() > 1 {
            B64[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        out.push(if c.len() > 2 {
            B64[n as usize & 63] as char
        } else {
            '='
        });
    }
    out
}

/// Decode standard padded base64; `None` on a malformed string.
pub fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let s = s.as_bytes();
    if !s.len().is_multiple_of(4) {
        return None;
    }
    let val = |c: u8| -> Option<u32> { B64.iter().position(|&b| b == c).map(|p| p as u32) };
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    for q in s.chunks(4) {
        let pad = q.iter().rev().take_while(|&&c| c == b'=').count();
        if pad > 2 {
            return None;
        }
        let mut n = 0u32;
        for (i, &c) in q.iter().enumerate() {
            let v = if i >= 4 - pad { 0 } else { val(c)? };
            n = n << 6 | v;
        }
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..3 - pad]);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (plain, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64_encode(plain.as_bytes()), enc);
            assert_eq!(base64_decode(enc).unwrap(), plain.as_bytes());
        }
        assert!(base64_decode("Zm9").is_none());
        assert!(base64_decode("Z!==").is_none());
    }

    #[test]
    fn raw_frame_round_trips_u8_u16_strided_and_metadata() {
        let f16 = RawFrame::new(
            3,
            2,
            4,
            RawPixels::U16(vec![1, 2, 3, 999, 4, 5, 1023, 999]),
            Cfa::Gbrg,
            10,
            Levels {
                black: [1, 2, 3, 4],
                white: 1023,
            },
        )
        .unwrap()
        .with_wb_gains([2.0, 1.0, 1.5])
        .with_meta(FrameMeta {
            sequence: 7,
            sensor_sequence: Some(42),
            timestamp_ns: 123_456_789_012,
            source: Arc::from("cam0"),
        });
        let mut buf = Vec::new();
        encode_raw_frame(&f16, &mut buf);
        let back = decode_raw_frame(&buf).unwrap();
        assert_eq!(back.to_u16_vec(), vec![1, 2, 3, 4, 5, 1023]);
        assert_eq!(back.cfa(), Cfa::Gbrg);
        assert_eq!(back.bit_depth(), 10);
        assert_eq!(back.levels(), f16.levels());
        assert_eq!(back.meta, f16.meta);
        assert_eq!(back.wb_gains, f16.wb_gains);
        // Pixel bytes are little-endian at the end: last pixel 1023 = 0xFF 0x03.
        assert_eq!(&buf[buf.len() - 2..], &[0xFF, 0x03]);

        let f8 = RawFrame::from_u8(2, 2, vec![9, 8, 7, 6], Cfa::Bggr, Levels::uniform(3, 255)).unwrap();
        encode_raw_frame(&f8, &mut buf);
        assert_eq!(&buf[buf.len() - 4..], &[9, 8, 7, 6]);
        assert_eq!(decode_raw_frame(&buf).unwrap(), f8);
    }

    #[test]
    fn raw_frame_decoder_rejects_damage() {
        let f = RawFrame::from_u8(2, 2, vec![9, 8, 7, 6], Cfa::Bggr, Levels::uniform(3, 255)).unwrap();
        let mut buf = Vec::new();
        encode_raw_frame(&f, &mut buf);
        assert!(matches!(
            decode_raw_frame(&buf[..buf.len() - 1]),
            Err(SchemaError::Short { .. })
        ));
        assert!(matches!(
            decode_raw_frame(&buf[..6]),
            Err(SchemaError::BadMagic { .. })
        ));
        assert!(matches!(
            decode_raw_frame(&buf[..12]),
            Err(SchemaError::Short { .. })
        ));
        let mut bad = buf.clone();
        bad[0] = b'X';
        assert!(matches!(
            decode_raw_frame(&bad),
            Err(SchemaError::BadMagic { .. })
        ));
        let mut bad = buf.clone();
        bad[9] = b'#';
        assert!(matches!(decode_raw_frame(&bad), Err(SchemaError::Json { .. })));
        let at = buf.windows(6).position(|w| w == b"\"BGGR\"").unwrap();
        let mut bad = buf.clone();
        bad[at + 1..at + 5].copy_from_slice(b"XXXX");
        assert!(matches!(decode_raw_frame(&bad), Err(SchemaError::Cfa(_))));
        // Huge header length must not allocate or panic.
        let mut bad = buf.clone();
        bad[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(decode_raw_frame(&bad), Err(SchemaError::Short { .. })));
        // A value above the declared bit depth (a RawFrame may hold one; a recording must not:
        // the preview's tables are sized by the bit depth).
        let hot =
            RawFrame::from_u16(2, 2, vec![5, 6, 1024, 7], Cfa::Rggb, 10, Levels::uniform(0, 1023)).unwrap();
        encode_raw_frame(&hot, &mut buf);
        let e = decode_raw_frame(&buf).unwrap_err();
        assert!(
            matches!(
                e,
                SchemaError::ValueOutOfRange {
                    value: 1024,
                    x: 0,
                    y: 1,
                    bit_depth: 10
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("1024 at (0, 1)"), "{e}");
        // Absurd dimensions: a clear size error, no overflow.
        let (mut h, px) = decode_raw_frame_header(&buf).unwrap();
        (h.width, h.height) = (u32::MAX, u32::MAX);
        let json = serde_json::to_vec(&h).unwrap();
        let mut bad = buf[..4].to_vec();
        bad.extend((json.len() as u32).to_le_bytes());
        bad.extend(&json);
        bad.extend(px);
        assert!(matches!(decode_raw_frame(&bad), Err(SchemaError::Short { .. })));
    }

    /// One box at (10, 20), 64x128, score 1.25, annotated at 1.5 s for a preview decimated by 2.
    fn one_box_annotations() -> ImageAnnotations {
        let d = Detection {
            x: 10.0,
            y: 20.0,
            width: 64.0,
            height: 128.0,
            score: 1.25,
        };
        annotations_from_detections(1_500_000_000, &[d], 2.0)
    }

    #[test]
    fn annotations_are_line_loops_scaled_to_preview() {
        let a = one_box_annotations();
        assert_eq!(a.points.len(), 1);
        assert_eq!(a.points[0].kind, POINTS_LINE_LOOP);
        assert_eq!(a.points[0].points[0], Point2 { x: 5.0, y: 10.0 });
        assert_eq!(a.points[0].points[2], Point2 { x: 37.0, y: 74.0 });
        assert_eq!(a.texts[0].text, "1.25");
        assert_eq!(
            a.texts[0].timestamp,
            FoxgloveTime {
                sec: 1,
                nsec: 500_000_000
            }
        );
        let json = serde_json::to_value(&a).unwrap();
        assert_eq!(json["points"][0]["type"], 2);
    }

    fn props(v: &serde_json::Value) -> Vec<String> {
        let mut k: Vec<String> = v["properties"].as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    }

    fn sorted(v: &[&str]) -> Vec<String> {
        let mut k: Vec<String> = v.iter().map(|s| s.to_string()).collect();
        k.sort();
        k
    }

    /// `have` holds every name of `want`.
    fn includes(have: &[String], want: &[&str]) {
        for w in want {
            assert!(have.iter().any(|h| h == w), "{w} missing from {have:?}");
        }
    }

    /// The schemas derived from the foxglove crate hold the properties of the published Foxglove
    /// JSON schemas (github.com/foxglove/schemas, schemas/jsonschema/RawImage.json and
    /// ImageAnnotations.json, checked 2026-11; the SDK may add fields, e.g. `metadata`), with
    /// Foxglove's JSON mapping (base64 bytes, `{sec, nsec}` time, enum values as numbers), and
    /// every name our JSON messages carry.
    #[test]
    fn schemas_have_the_published_foxglove_properties() {
        let raw: serde_json::Value = serde_json::from_str(&raw_image_json_schema()).unwrap();
        assert_eq!(raw["title"], "foxglove.RawImage");
        assert_eq!(
            props(&raw),
            sorted(&[
                "timestamp",
                "frame_id",
                "width",
                "height",
                "encoding",
                "step",
                "data"
            ])
        );
        assert_eq!(raw["properties"]["data"]["contentEncoding"], "base64");
        assert_eq!(raw["properties"]["width"]["type"], "integer");
        assert_eq!(props(&raw["properties"]["timestamp"]), sorted(&["sec", "nsec"]));
        let ann: serde_json::Value = serde_json::from_str(&image_annotations_json_schema()).unwrap();
        assert_eq!(ann["title"], "foxglove.ImageAnnotations");
        includes(&props(&ann), &["circles", "points", "texts"]);
        includes(
            &props(&ann["properties"]["circles"]["items"]),
            &[
                "timestamp",
                "position",
                "diameter",
                "thickness",
                "fill_color",
                "outline_color",
            ],
        );
        let points = &ann["properties"]["points"]["items"];
        includes(
            &props(points),
            &[
                "timestamp",
                "type",
                "points",
                "outline_color",
                "outline_colors",
                "fill_color",
                "thickness",
            ],
        );
        includes(
            &props(&ann["properties"]["texts"]["items"]),
            &[
                "timestamp",
                "position",
                "text",
                "font_size",
                "text_color",
                "background_color",
            ],
        );
        let kinds = points["properties"]["type"]["oneOf"].as_array().unwrap();
        let value = |name: &str| kinds.iter().find(|k| k["title"] == name).unwrap()["const"].as_u64();
        assert_eq!(value("POINTS"), Some(POINTS_POINTS as u64));
        assert_eq!(value("LINE_LOOP"), Some(POINTS_LINE_LOOP as u64));
        assert_eq!(
            props(&points["properties"]["points"]["items"]),
            sorted(&["x", "y"])
        );
        assert_eq!(
            props(&points["properties"]["outline_color"]),
            sorted(&["r", "g", "b", "a"])
        );
        // Our serialised messages carry only names the schemas have.
        let a = annotations_from_detections(
            0,
            &[Detection {
                x: 0.0,
                y: 0.0,
                width: 1.0,
                height: 1.0,
                score: 0.0,
            }],
            1.0,
        );
        let v = serde_json::to_value(&a).unwrap();
        let keys =
            |o: &serde_json::Value| -> Vec<String> { o.as_object().unwrap().keys().cloned().collect() };
        includes(
            &props(&ann),
            &keys(&v).iter().map(String::as_str).collect::<Vec<_>>(),
        );
        includes(
            &props(points),
            &keys(&v["points"][0])
                .iter()
                .map(String::as_str)
                .collect::<Vec<_>>(),
        );
        includes(
            &props(&ann["properties"]["texts"]["items"]),
            &keys(&v["texts"][0])
                .iter()
                .map(String::as_str)
                .collect::<Vec<_>>(),
        );
        let img = RawImageMessage {
            timestamp: FoxgloveTime::from_ns(0),
            frame_id: String::new(),
            width: 0,
            height: 0,
            encoding: String::new(),
            step: 0,
            data: String::new(),
        };
        assert_eq!(
            keys(&serde_json::to_value(&img).unwrap()).len(),
            props(&raw).len()
        );
    }

    /// The live view's protobuf annotations are the recorder's JSON ones: same points, type,
    /// colours, texts and timestamps.
    #[test]
    fn protobuf_annotations_equal_the_json_ones() {
        let a = one_box_annotations();
        let p = foxglove::messages::ImageAnnotations::from(&a);
        assert_eq!(p.points.len(), 1);
        let (q, j) = (&p.points[0], &a.points[0]);
        assert_eq!(
            q.r#type,
            foxglove::messages::points_annotation::Type::LineLoop as i32
        );
        let pts: Vec<(f64, f64)> = q.points.iter().map(|p| (p.x, p.y)).collect();
        let want: Vec<(f64, f64)> = j.points.iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(pts, want);
        let t = q.timestamp.unwrap();
        assert_eq!((t.sec(), t.nsec()), (1, 500_000_000));
        assert_eq!(q.outline_color.as_ref().unwrap().g, 1.0);
        assert_eq!(q.thickness, j.thickness);
        assert_eq!(p.texts[0].text, "1.25");
        assert_eq!(p.texts[0].position.unwrap().x, 5.0);
        let kp = annotations_from_keypoints(
            0,
            &[Keypoint {
                x: 4.0,
                y: 6.0,
                size: 1.0,
                angle: 0.0,
                response: 1.0,
                octave: 0,
                layer: 1,
            }],
            2.0,
        );
        let p = foxglove::messages::ImageAnnotations::from(&kp);
        assert_eq!(
            p.points[0].r#type,
            foxglove::messages::points_annotation::Type::Points as i32
        );
        assert_eq!((p.points[0].points[0].x, p.points[0].points[0].y), (2.0, 3.0));
    }

    #[test]
    fn our_json_schemas_parse() {
        for s in [
            raw_image_json_schema(),
            image_annotations_json_schema(),
            DETECTIONS_JSON_SCHEMA.to_string(),
            STATS_JSON_SCHEMA.to_string(),
            SIFT_FEATURES_JSON_SCHEMA.to_string(),
        ] {
            serde_json::from_str::<serde_json::Value>(&s).unwrap();
        }
    }
}
