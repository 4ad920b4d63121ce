//! Reading recordings back: the summary ([`RecordingInfo`]) and the JSON channels (detections,
//! annotations, stats) — used by tests and by the daemon's golden comparisons. Raw frames are
//! replayed by [`crate::capture::mcap_source::McapSource`].
//!
//! All readers stream the file (memory scales with one chunk) and validate every CRC.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

use super::schema::{DetectionsMessage, ImageAnnotations, SchemaError};
use super::RecordError;
use crate::raw::FrameLimits;

/// Recorders refuse chunk-size targets above a quarter of this (64 MiB), bytes.
pub(crate) const MAX_RECORD_BYTES: u64 = 256 * 1024 * 1024;
/// Room for a raw-frame message's JSON header and the MCAP record framing, bytes.
pub(crate) const FRAME_MESSAGE_SLACK_BYTES: u64 = 64 * 1024;

/// The largest record or (de)compressed chunk a reader accepts under `limits`, bytes, so that a
/// corrupt or hostile length field (an 8.5 KB zstd chunk can claim 250 MB) is refused before
/// anything is allocated or decompressed. Derived from the frame-size limit: a recorder's chunk
/// holds at most its chunk-size target (at most `MAX_RECORD_BYTES / 4`) plus the one message that
/// crosses it, a raw frame of at most [`FrameLimits::max_sample_bytes`] and its header. With the
/// default limit (2^26 pixels) that is 192 MiB + 64 KiB.
pub(crate) fn record_length_limit(limits: FrameLimits) -> u64 {
    (MAX_RECORD_BYTES / 4)
        .saturating_add(limits.max_sample_bytes())
        .saturating_add(FRAME_MESSAGE_SLACK_BYTES)
}

/// Reader options that check everything: chunk CRCs (before any message of the chunk is used),
/// data-section and summary CRCs, and record lengths limited to [`record_length_limit`] of the
/// process's frame-size limit.
pub(crate) fn strict_reader_options() -> mcap::sans_io::LinearReaderOptions {
    mcap::sans_io::LinearReaderOptions::default()
        .with_prevalidate_chunk_crcs(true)
        .with_validate_data_section_crc(true)
        .with_validate_summary_section_crc(true)
        .with_record_length_limit(record_length_limit(FrameLimits::process()) as usize)
}

/// Re-exported from [`super`], where the recording error uses it.
pub(crate) use super::mcap_detail;

/// One channel of a recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Topic.
    pub topic: String,
    /// Schema name (empty without a schema).
    pub schema: String,
    /// Schema encoding.
    pub schema_encoding: String,
    /// Message encoding.
    pub message_encoding: String,
    /// Messages on the channel (from the summary statistics).
    pub messages: u64,
}

/// What the summary section of a finished recording says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingInfo {
    /// Channels by topic.
    pub channels: BTreeMap<String, ChannelInfo>,
    /// Total messages.
    pub messages: u64,
    /// Chunks (each has an index entry).
    pub chunks: usize,
    /// First log time (ns).
    pub start_ns: u64,
    /// Last log time (ns).
    pub end_ns: u64,
}

impl RecordingInfo {
    /// Read the summary of `path` (fails on a file without one: truncated or unfinished).
    pub fn read(path: impl AsRef<Path>) -> Result<Self, RecordError> {
        let path = path.as_ref();
        let mut file = File::open(path).map_err(|source| RecordError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        let summary = read_summary(&mut file).map_err(|source| RecordError::Read {
            path: path.to_path_buf(),
            source: Box::new(source),
        })?;
        let Some(summary) = summary else {
            return Err(RecordError::Read {
                path: path.to_path_buf(),
                source: Box::new(mcap::McapError::BadFooter),
            });
        };
        let stats = summary.stats.clone().unwrap_or_default();
        let mut channels = BTreeMap::new();
        for (id, ch) in &summary.channels {
            let (schema, schema_encoding) = match &ch.schema {
                Some(s) => (s.name.clone(), s.encoding.clone()),
                None => (String::new(), String::new()),
            };
            channels.insert(
                ch.topic.clone(),
                ChannelInfo {
                    topic: ch.topic.clone(),
                    schema,
                    schema_encoding,
                    message_encoding: ch.message_encoding.clone(),
                    messages: stats.channel_message_counts.get(id).copied().unwrap_or(0),
                },
            );
        }
        Ok(Self {
            channels,
            messages: stats.message_count,
            chunks: summary.chunk_indexes.len(),
            start_ns: stats.message_start_time,
            end_ns: stats.message_end_time,
        })
    }

    /// Messages on `topic` (0 when absent).
    pub fn count(&self, topic: &str) -> u64 {
        self.channels.get(topic).map(|c| c.messages).unwrap_or(0)
    }
}

/// Bytes of the footer record: opcode, length, summary start, summary offset start, summary CRC.
const FOOTER_RECORD_BYTES: u64 = 1 + 8 + 8 + 8 + 4;

/// Check the summary section's CRC32 against the footer's `summary_crc` (which covers every byte
/// from the start of the summary section up to and including the footer's
/// `summary_offset_start`). The summary reader of the `mcap` crate does not check it, and the
/// streaming reader only at the very end, after every frame: this finds a damaged summary at open.
/// `Ok(())` too for a file without a footer, a summary or a CRC (0 = not computed).
pub(crate) fn check_summary_crc<R: Read + Seek>(r: &mut R) -> mcap::McapResult<()> {
    use std::io::SeekFrom;
    let len = r.seek(SeekFrom::End(0))?;
    let magic = mcap::MAGIC.len() as u64;
    let Some(footer_at) = len.checked_sub(magic + FOOTER_RECORD_BYTES) else {
        return Ok(());
    };
    let mut footer = [0u8; FOOTER_RECORD_BYTES as usize];
    r.seek(SeekFrom::Start(footer_at))?;
    r.read_exact(&mut footer)?;
    if footer[0] != 0x02 {
        return Err(mcap::McapError::BadFooter);
    }
    let word = |at: usize| u64::from_le_bytes(footer[at..at + 8].try_into().expect("8 bytes"));
    let summary_start = word(9);
    let saved = u32::from_le_bytes(footer[25..29].try_into().expect("4 bytes"));
    if summary_start == 0 || saved == 0 {
        return Ok(());
    }
    if summary_start < magic || summary_start > footer_at {
        return Err(mcap::McapError::BadFooter);
    }
    let mut hasher = crc32fast::Hasher::new();
    r.seek(SeekFrom::Start(summary_start))?;
    let mut left = footer_at - summary_start;
    let mut buf = vec![0u8; 64 * 1024];
    while left > 0 {
        let n = left.min(buf.len() as u64) as usize;
        r.read_exact(&mut buf[..n])?;
        hasher.update(&buf[..n]);
        left -= n as u64;
    }
    hasher.update(&footer[..25]);
    let calculated = hasher.finalize();
    if calculated != saved {
        return Err(mcap::McapError::BadSummaryCrc { saved, calculated });
    }
    Ok(())
}

/// Read the summary section through the footer (seeking), validating its CRC
/// (`check_summary_crc`) and limiting record lengths (`record_length_limit`); `Ok(None)` when
/// the file has no summary.
pub fn read_summary<R: Read + Seek>(r: &mut R) -> mcap::McapResult<Option<mcap::Summary>> {
    use mcap::sans_io::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
    check_summary_crc(r)?;
    let len = r.seek(std::io::SeekFrom::End(0))?;
    r.seek(std::io::SeekFrom::Start(0))?;
    let limit = record_length_limit(FrameLimits::process()) as usize;
    let mut sr = SummaryReader::new_with_options(
        SummaryReaderOptions::default()
            .with_file_size(len)
            .with_record_length_limit(limit),
    );
    while let Some(ev) = sr.next_event() {
        match ev? {
            SummaryReadEvent::ReadRequest(n) => {
                let got = r.read(sr.insert(n))?;
                sr.notify_read(got);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let pos = r.seek(to)?;
                sr.notify_seeked(pos);
            }
        }
    }
    Ok(sr.finish())
}

/// A message read back from a JSON channel, with its log time.
#[derive(Debug, Clone, PartialEq)]
pub struct Logged<T> {
    /// MCAP log time (ns).
    pub log_time: u64,
    /// The decoded message.
    pub message: T,
}

/// Every message on `topic`, decoded from JSON, in file order. Fails on the first unreadable
/// record (truncated or corrupt file) or undecodable message.
pub fn read_json_topic<T: DeserializeOwned>(
    path: impl AsRef<Path>,
    topic: &str,
) -> Result<Vec<Logged<T>>, RecordError> {
    let path = path.as_ref();
    let mut out = Vec::new();
    for_each_message(path, |m| {
        if m.channel.topic != topic {
            return Ok(());
        }
        let message = serde_json::from_slice(&m.data).map_err(|source| RecordError::Decode {
            path: path.to_path_buf(),
            topic: topic.to_string(),
            sequence: m.sequence,
            source: Box::new(SchemaError::Json {
                what: "JSON channel message",
                source,
            }),
        })?;
        out.push(Logged {
            log_time: m.log_time,
            message,
        });
        Ok(())
    })?;
    Ok(out)
}

/// The `mosaicd.Detections` messages of camera `camera`.
pub fn read_detections(path: impl AsRef<Path>, camera: &str) -> Result<Vec<DetectionsMessage>, RecordError> {
    let topic = super::Topics::new(camera).detections;
    Ok(read_json_topic(path, &topic)?
        .into_iter()
        .map(|l| l.message)
        .collect())
}

/// The `foxglove.ImageAnnotations` messages of camera `camera`, with log times.
pub fn read_annotations(
    path: impl AsRef<Path>,
    camera: &str,
) -> Result<Vec<Logged<ImageAnnotations>>, RecordError> {
    read_json_topic(path, &super::Topics::new(camera).annotations)
}

/// The stats messages of camera `camera`, with log times.
pub fn read_stats(
    path: impl AsRef<Path>,
    camera: &str,
) -> Result<Vec<Logged<serde_json::Value>>, RecordError> {
    read_json_topic(path, &super::Topics::new(camera).stats)
}

/// Call `f` on every message of `path` in file order (streaming, strict CRC checks).
pub fn for_each_message(
    path: &Path,
    mut f: impl FnMut(&mcap::Message<'static>) -> Result<(), RecordError>,
) -> Result<(), RecordError> {
    let open_err = |source| RecordError::Open {
        path: path.to_path_buf(),
        source,
    };
    let file = File::open(path).map_err(open_err)?;
    let reader = mcap::io::MessageReader::new_with_options(BufReader::new(file), strict_reader_options());
    for m in reader {
        let m = m.map_err(|source| RecordError::Read {
            path: PathBuf::from(path),
            source: Box::new(source),
        })?;
        f(&m)?;
    }
    Ok(())
}
