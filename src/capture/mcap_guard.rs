//! A guard between a recording file and the `mcap` crate's streaming reader, for two structures
//! that reader does not check: records that run past the end of the file, and records that
//! overrun an uncompressed chunk.
//!
//! An MCAP file is a magic, then top-level records, each an opcode (1 byte), a length `n` (u64)
//! and `n` bytes. A chunk (opcode 0x06) holds, after its header, `records_len` bytes of records
//! of the same form.
//!
//! * **Past the end of the file.** `mcap` 0.26 reads a record by growing its buffer to the whole
//!   length the header declares, zero-filled (`RwBuf::tail_with_size`, `Vec::resize`), and then
//!   reading into it. Its only bound is the record-length limit, which the frame-size limit sets
//!   (about 192 MiB with the default 64 MP), so a 33-byte file whose one record declares 150 MB
//!   cost 158 MB of resident memory before it was reported as truncated (docs/fuzzing.md,
//!   finding 5). The guard knows the file's length from the start and compares each top-level
//!   record's end with it, before `mcap` has the record's header: a record that does not end
//!   within the file is a [`RecordPastEnd`], delivered as an [`std::io::ErrorKind::UnexpectedEof`]
//!   error, so it is still reported as a truncation. A record inside an uncompressed chunk is
//!   bounded by its chunk (below), which is bounded by the file. A compressed chunk's
//!   uncompressed size is not in the file: it keeps the record-length limit.
//! * **Overrunning an uncompressed chunk.** For a chunk with an empty compression string, `mcap`
//!   reads the records straight from the file and subtracts each record's `9 + n` from what is
//!   left of `records_len` without a check (`sans_io/linear_reader.rs`,
//!   `compressed_remaining -= …`). A record that does not fit (fewer than 9 bytes left for its
//!   header, or `9 + n` more than what is left) makes that subtraction overflow: a panic in debug
//!   builds, and in release builds a wrapped count that reads the rest of the file as records and
//!   ends in a misleading "truncated" error. The fuzzer found such a file
//!   (`fuzz/seeds/mcap_source/chunk-records-overrun.mcap`, tested in `tests/hostile_inputs.rs`).
//!   Inside each uncompressed chunk the guard checks every record header against what is left of
//!   `records_len`: one that does not fit is a [`ChunkOverrun`], delivered as an
//!   [`std::io::ErrorKind::InvalidData`] error (a corruption).
//!
//! [`RecordGuard`] wraps the file's reader and follows the record structure as the bytes pass:
//! top-level records are skipped by their lengths, and so are the records of an uncompressed
//! chunk. It delivers the bytes before the first record that fails a check, then fails every
//! further read with the error, so the `mcap` reader never holds that record's header whole (and
//! never sizes a buffer from it, or reaches the subtraction). The outcome is the same in debug and
//! release builds: the frames of the earlier records, then the error. Chunks whose header `mcap`
//! refuses itself (a compression string or `records_len` longer than the chunk) end the guarding:
//! `mcap` reports them; so does the footer (what follows it is the end magic). The cost is a few
//! comparisons per record; frame payloads are skipped, not inspected.

use std::io::{self, Read};

/// Bytes of a record's opcode and length.
const RECORD_HEADER: u64 = 9;
/// Bytes of a chunk header up to the compression string's length: start and end time, uncompressed
/// size, uncompressed CRC, compression string length.
const CHUNK_FIXED: usize = 8 + 8 + 8 + 4 + 4;
const OP_FOOTER: u8 = 0x02;
const OP_CHUNK: u8 = 0x06;
/// The file's leading magic.
const MAGIC_LEN: u64 = 8;

/// A record inside an uncompressed chunk that does not fit in the chunk's records.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the uncompressed chunk at byte {chunk} holds {records_len} bytes of records, but its record at byte {record} needs at least {need} bytes where {left} remain (records overrun the chunk)"
)]
pub struct ChunkOverrun {
    /// File offset of the chunk record.
    pub chunk: u64,
    /// The chunk's `records_len`.
    pub records_len: u64,
    /// File offset of the record that does not fit.
    pub record: u64,
    /// Bytes it needs: 9 for its header, or 9 + its length (saturating).
    pub need: u64,
    /// Bytes of the chunk's records left at that record.
    pub left: u64,
}

/// A top-level record whose declared length runs past the end of the file: the file was cut
/// short (or the length is damaged). Reported as a truncation, before any buffer is sized from
/// that length.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the record at byte {record} (opcode {opcode:#04x}) declares {len} bytes, but the file ({file_len} bytes) ends {left} bytes after its header (the file is cut short)"
)]
pub struct RecordPastEnd {
    /// File offset of the record.
    pub record: u64,
    /// Its opcode.
    pub opcode: u8,
    /// The length its header declares (after the header).
    pub len: u64,
    /// Bytes of the file after its header.
    pub left: u64,
    /// The file's length.
    pub file_len: u64,
}

/// Why the guard stopped the stream.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Failure {
    Overrun(ChunkOverrun),
    PastEnd(RecordPastEnd),
}

impl Failure {
    /// The error every read returns from the failure on: a corruption, or the end of the file.
    fn io(&self) -> io::Error {
        match self {
            Failure::Overrun(e) => io::Error::new(io::ErrorKind::InvalidData, e.clone()),
            Failure::PastEnd(e) => io::Error::new(io::ErrorKind::UnexpectedEof, e.clone()),
        }
    }
}

/// An uncompressed chunk being followed.
#[derive(Debug, Clone, Copy)]
struct Chunk {
    start: u64,
    records_len: u64,
    /// Bytes of records left.
    left: u64,
    /// Bytes of the chunk record after its records (mcap skips them as padding).
    tail: u64,
}

#[derive(Debug, Clone, Copy)]
enum State {
    /// The leading magic: bytes left.
    Magic(u64),
    /// A top-level record's opcode and length (in `head`).
    Top,
    /// The rest of a top-level record: bytes left, then [`State::Top`].
    Skip(u64),
    /// A chunk's header (in `head`): the chunk's offset and record length.
    ChunkHeader { start: u64, len: u64 },
    /// The next record of an uncompressed chunk (its header in `head`).
    Record(Chunk),
    /// The body of a record of an uncompressed chunk: bytes left.
    RecordBody(Chunk, u64),
    /// No more checks: the footer, a structure `mcap` refuses itself, or a failure already
    /// reported.
    Off,
}

/// A [`Read`] that passes a recording's bytes through and stops before the first record that
/// runs past the end of the file or overruns its uncompressed chunk (see the
/// [module overview](self)).
#[derive(Debug)]
pub(super) struct RecordGuard<R> {
    inner: R,
    /// The file's length: every top-level record must end within it.
    file_len: u64,
    state: State,
    /// File offset of the next byte read from `inner`.
    pos: u64,
    /// Header bytes collected so far, and the file offset of the first.
    head: Vec<u8>,
    head_at: u64,
    failed: Option<Failure>,
}

impl<R: Read> RecordGuard<R> {
    /// Guard `inner`, which is read from the start of a file of `file_len` bytes.
    pub(super) fn new(inner: R, file_len: u64) -> Self {
        Self {
            inner,
            file_len,
            state: State::Magic(MAGIC_LEN),
            pos: 0,
            head: Vec::with_capacity(CHUNK_FIXED + 8),
            head_at: 0,
            failed: None,
        }
    }

    /// Collect header bytes from `data[*i..]` until `head` holds `n`; `true` once it does.
    fn collect(&mut self, data: &[u8], i: &mut usize, n: usize) -> bool {
        if self.head.len() >= n {
            return true;
        }
        if self.head.is_empty() {
            self.head_at = self.pos + *i as u64;
        }
        let take = (n - self.head.len()).min(data.len() - *i);
        self.head.extend_from_slice(&data[*i..*i + take]);
        *i += take;
        self.head.len() == n
    }

    /// Skip up to `n` bytes of `data[*i..]`; the bytes still to skip.
    fn skip(data: &[u8], i: &mut usize, n: u64) -> u64 {
        let take = n.min((data.len() - *i) as u64);
        *i += take as usize;
        n - take
    }

    /// Follow `data` (the bytes at `self.pos`); the number of them that may be delivered (all,
    /// unless a record fails a check: then those before it).
    fn feed(&mut self, data: &[u8]) -> usize {
        let mut i = 0;
        loop {
            // States that consume no byte run even at the end of `data`.
            let progress = match self.state {
                State::Off => return data.len(),
                State::Magic(n) => {
                    let left = Self::skip(data, &mut i, n);
                    self.state = if left == 0 { State::Top } else { State::Magic(left) };
                    left == 0
                }
                State::Skip(n) => {
                    let left = Self::skip(data, &mut i, n);
                    self.state = if left == 0 { State::Top } else { State::Skip(left) };
                    left == 0
                }
                State::Top => {
                    if !self.collect(data, &mut i, RECORD_HEADER as usize) {
                        false
                    } else {
                        let op = self.head[0];
                        let len = u64::from_le_bytes(self.head[1..9].try_into().expect("8 bytes"));
                        let start = self.head_at;
                        self.head.clear();
                        let body_at = start + RECORD_HEADER;
                        let left = self.file_len.saturating_sub(body_at);
                        if len > left {
                            let past = RecordPastEnd {
                                record: start,
                                opcode: op,
                                len,
                                left,
                                file_len: self.file_len,
                            };
                            return self.fail(Failure::PastEnd(past), start, data.len());
                        }
                        self.state = match op {
                            OP_CHUNK => State::ChunkHeader { start, len },
                            // Then the end magic, which `mcap` checks.
                            OP_FOOTER => State::Off,
                            _ => State::Skip(len),
                        };
                        true
                    }
                }
                State::ChunkHeader { start, len } => self.chunk_header(data, &mut i, start, len),
                State::Record(c) => {
                    if c.left == 0 {
                        self.state = State::Skip(c.tail);
                        true
                    } else if c.left < RECORD_HEADER {
                        let at = self.pos + i as u64;
                        return self.fail(overrun(c, at, RECORD_HEADER), at, data.len());
                    } else if !self.collect(data, &mut i, RECORD_HEADER as usize) {
                        false
                    } else {
                        let n = u64::from_le_bytes(self.head[1..9].try_into().expect("8 bytes"));
                        let at = self.head_at;
                        self.head.clear();
                        let need = RECORD_HEADER.saturating_add(n);
                        if need > c.left {
                            return self.fail(overrun(c, at, need), at, data.len());
                        }
                        let c = Chunk {
                            left: c.left - need,
                            ..c
                        };
                        self.state = State::RecordBody(c, n);
                        true
                    }
                }
                State::RecordBody(c, n) => {
                    let left = Self::skip(data, &mut i, n);
                    self.state = if left == 0 {
                        State::Record(c)
                    } else {
                        State::RecordBody(c, left)
                    };
                    left == 0
                }
            };
            if !progress && i == data.len() {
                return data.len();
            }
        }
    }

    /// The chunk header at `start` (a chunk record of `len` bytes): an uncompressed chunk's
    /// records are followed, anything else skipped. `false` while more bytes are needed.
    fn chunk_header(&mut self, data: &[u8], i: &mut usize, start: u64, len: u64) -> bool {
        if !self.collect(data, i, CHUNK_FIXED) {
            return false;
        }
        let compression_len = u32::from_le_bytes(self.head[28..32].try_into().expect("4 bytes"));
        if compression_len != 0 {
            self.head.clear();
            self.state = State::Skip(len.saturating_sub(CHUNK_FIXED as u64));
            return true;
        }
        if !self.collect(data, i, CHUNK_FIXED + 8) {
            return false;
        }
        let records_len = u64::from_le_bytes(self.head[CHUNK_FIXED..].try_into().expect("8 bytes"));
        self.head.clear();
        let header = (CHUNK_FIXED + 8) as u64;
        self.state = match len.checked_sub(header).and_then(|d| d.checked_sub(records_len)) {
            // mcap refuses this chunk itself (BadChunkLength, UnexpectedEoc).
            None => State::Off,
            Some(tail) => State::Record(Chunk {
                start,
                records_len,
                left: records_len,
                tail,
            }),
        };
        true
    }

    /// Record `failure` of the record at file offset `at`; the bytes of the `n` just read (at
    /// `self.pos`) that may still be delivered: those before `at`.
    fn fail(&mut self, failure: Failure, at: u64, n: usize) -> usize {
        self.failed = Some(failure);
        self.state = State::Off;
        at.saturating_sub(self.pos).min(n as u64) as usize
    }
}

/// The overrun of chunk `c` by the record at `at`, which needs `need` bytes.
fn overrun(c: Chunk, at: u64, need: u64) -> Failure {
    Failure::Overrun(ChunkOverrun {
        chunk: c.start,
        records_len: c.records_len,
        record: at,
        need,
        left: c.left,
    })
}

impl<R: Read> Read for RecordGuard<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if let Some(f) = &self.failed {
            return Err(f.io());
        }
        let n = self.inner.read(buf)?;
        let deliver = self.feed(&buf[..n]);
        self.pos += n as u64;
        match &self.failed {
            // Zero bytes would read as the end of the file: fail now instead.
            Some(f) if deliver == 0 && n > 0 => Err(f.io()),
            _ => Ok(deliver),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record: opcode, length, body.
    fn record(op: u8, body: &[u8]) -> Vec<u8> {
        let mut out = vec![op];
        out.extend((body.len() as u64).to_le_bytes());
        out.extend(body);
        out
    }

    /// A chunk record with compression `comp` holding `records` (declared `records_len` bytes).
    fn chunk(comp: &str, records: &[u8], records_len: u64) -> Vec<u8> {
        let mut body = Vec::new();
        body.extend([0u8; 8 + 8 + 8 + 4]);
        body.extend((comp.len() as u32).to_le_bytes());
        body.extend(comp.as_bytes());
        body.extend(records_len.to_le_bytes());
        body.extend(records);
        record(OP_CHUNK, &body)
    }

    fn file(records: &[Vec<u8>]) -> Vec<u8> {
        let mut out = mcap::MAGIC.to_vec();
        for r in records {
            out.extend(r);
        }
        out
    }

    /// The failure an error from the guard carries, checked against the error's kind.
    fn failure(e: io::Error) -> Failure {
        let kind = e.kind();
        let inner = e.into_inner().unwrap();
        if let Some(o) = inner.downcast_ref::<ChunkOverrun>() {
            assert_eq!(kind, io::ErrorKind::InvalidData);
            return Failure::Overrun(o.clone());
        }
        let p = inner.downcast_ref::<RecordPastEnd>().unwrap();
        assert_eq!(kind, io::ErrorKind::UnexpectedEof);
        Failure::PastEnd(p.clone())
    }

    /// Read the file `bytes` through a guard in reads of `step` bytes: what was delivered, and
    /// why it stopped.
    fn drain_failure(bytes: &[u8], step: usize) -> (Vec<u8>, Option<Failure>) {
        let mut g = RecordGuard::new(bytes, bytes.len() as u64);
        let mut out = Vec::new();
        let mut buf = vec![0u8; step];
        loop {
            match g.read(&mut buf) {
                Ok(0) => return (out, None),
                Ok(n) => out.extend(&buf[..n]),
                Err(e) => {
                    let f = failure(e);
                    // Every later read fails the same way.
                    assert_eq!(failure(g.read(&mut buf).unwrap_err()), f);
                    return (out, Some(f));
                }
            }
        }
    }

    /// [`drain_failure`] for the chunk overruns.
    fn drain(bytes: &[u8], step: usize) -> (Vec<u8>, Option<ChunkOverrun>) {
        let (out, f) = drain_failure(bytes, step);
        let o = f.map(|f| match f {
            Failure::Overrun(o) => o,
            other => panic!("{other:?}"),
        });
        (out, o)
    }

    #[test]
    fn sound_files_pass_unchanged_in_any_read_size() {
        let inner = [record(0x05, b"message one"), record(0x05, &[7u8; 300])].concat();
        let f = file(&[
            record(0x01, b"header"),
            chunk("", &inner, inner.len() as u64),
            chunk("zstd", b"\x01\x02 not parsed", 3),
            chunk("", &[], 0),
            record(0x0F, &[0; 4]),
            record(OP_FOOTER, &[0; 20]),
            mcap::MAGIC.to_vec(),
        ]);
        for step in [1, 2, 7, 9, 40, 4096] {
            assert_eq!(drain(&f, step), (f.clone(), None), "step {step}");
        }
    }

    #[test]
    fn a_record_that_overruns_its_chunk_is_cut_before_it() {
        let inner = [record(0x05, b"fits"), record(0x05, &[1u8; 20])].concat();
        // Declared one byte short of the second record's end.
        let short = (inner.len() - 1) as u64;
        let head = file(&[record(0x01, b"h")]);
        let f = [head.clone(), chunk("", &inner, short)].concat();
        let chunk_at = head.len() as u64;
        let second = chunk_at + 9 + 32 + 8 + 13;
        for step in [1, 5, 64, 4096] {
            let (out, e) = drain(&f, step);
            let e = e.unwrap();
            assert_eq!(
                e,
                ChunkOverrun {
                    chunk: chunk_at,
                    records_len: short,
                    record: second,
                    need: 29,
                    left: 28
                }
            );
            assert!(out.len() as u64 <= second + 9, "{step}: {}", out.len());
            assert_eq!(&out[..], &f[..out.len()]);
        }
        // Fewer than 9 bytes left for a header: refused at the record's first byte.
        let f = [head.clone(), chunk("", &[0u8; 12], 1)].concat();
        let (out, e) = drain(&f, 4096);
        let e = e.unwrap();
        assert_eq!((e.record, e.need, e.left), (chunk_at + 49, 9, 1));
        assert_eq!(out.len() as u64, chunk_at + 49);
        assert!(
            e.to_string().contains("needs at least 9 bytes where 1 remain"),
            "{e}"
        );
        // A length whose 9 + n wraps u64.
        let mut huge = record(0x05, b"");
        huge[1..9].copy_from_slice(&u64::MAX.to_le_bytes());
        let f = [head, chunk("", &huge, 9)].concat();
        assert_eq!(drain(&f, 3).1.unwrap().need, u64::MAX);
    }

    #[test]
    fn chunks_mcap_refuses_itself_pass_through() {
        // records_len longer than the chunk: mcap's UnexpectedEoc, not ours.
        let f = file(&[chunk("", &record(0x05, b"x"), 1000)]);
        assert_eq!(drain(&f, 16), (f.clone(), None));
    }

    /// The 33-byte file of docs/fuzzing.md (finding 5): the magic and a Schema record whose header
    /// declares 150,000,000 bytes. `mcap` would size a zero-filled buffer from that header; the
    /// guard stops the stream before the header, with an end-of-file error.
    #[test]
    fn a_record_past_the_end_of_the_file_is_stopped_before_its_header() {
        let mut f = file(&[record(0x01, b"header")]);
        let at = f.len() as u64;
        f.push(0x03);
        f.extend(150_000_000u64.to_le_bytes());
        f.extend([0u8; 16]);
        for step in [1, 4, 9, 17, 4096] {
            let (out, e) = drain_failure(&f, step);
            let expected = RecordPastEnd {
                record: at,
                opcode: 0x03,
                len: 150_000_000,
                left: 16,
                file_len: f.len() as u64,
            };
            assert_eq!(e, Some(Failure::PastEnd(expected.clone())), "step {step}");
            // Every byte before the record, never its header whole.
            let got = out.len() as u64;
            assert!(at <= got && got < at + RECORD_HEADER, "step {step}: {got}");
            assert_eq!(&out[..], &f[..out.len()]);
            assert_eq!(
                expected.to_string(),
                format!(
                    "the record at byte {at} (opcode 0x03) declares 150000000 bytes, but the file ({} bytes) ends 16 bytes after its header (the file is cut short)",
                    f.len()
                )
            );
        }
        // A length that wraps when added to the offset, and a chunk that runs past the end.
        let mut huge = record(0x05, b"");
        huge[1..9].copy_from_slice(&u64::MAX.to_le_bytes());
        let (_, e) = drain_failure(&file(&[huge]), 64);
        assert!(
            matches!(
                e,
                Some(Failure::PastEnd(RecordPastEnd {
                    len: u64::MAX,
                    left: 0,
                    ..
                }))
            ),
            "{e:?}"
        );
        let c = chunk("zstd", &[0u8; 40], 40);
        let (_, e) = drain_failure(&file(std::slice::from_ref(&c))[..8 + c.len() - 1], 64);
        assert!(
            matches!(e, Some(Failure::PastEnd(RecordPastEnd { opcode: OP_CHUNK, .. }))),
            "{e:?}"
        );
        // A record that ends exactly at the end of the file passes.
        let f = file(&[record(0x03, &[5; 30])]);
        assert_eq!(drain_failure(&f, 7), (f.clone(), None));
    }

    /// Every cut of a sound file: the bytes up to the cut record, then an end-of-file error (or,
    /// at a record boundary or inside a record's header, every byte and no error: `mcap` sees
    /// the end of the file itself). Never an overrun.
    #[test]
    fn every_cut_of_a_sound_file_reads_as_a_truncation() {
        let inner = record(0x05, b"abc");
        let f = file(&[
            record(0x01, b"header"),
            chunk("", &inner, inner.len() as u64),
            record(0x0F, &[0; 4]),
            record(OP_FOOTER, &[0; 20]),
            mcap::MAGIC.to_vec(),
        ]);
        let mut cut_records = 0;
        for n in 0..f.len() {
            let (out, e) = drain_failure(&f[..n], 3);
            assert_eq!(&out[..], &f[..out.len()], "{n}");
            match e {
                None => assert_eq!(out.len(), n, "{n}"),
                Some(Failure::PastEnd(p)) => {
                    assert!(
                        p.record + RECORD_HEADER <= n as u64 && p.left < p.len,
                        "{n}: {p:?}"
                    );
                    let got = out.len() as u64;
                    assert!(p.record <= got && got < p.record + RECORD_HEADER, "{n}: {got}");
                    cut_records += 1;
                }
                Some(other) => panic!("{n}: {other:?}"),
            }
        }
        assert!(cut_records > f.len() / 2, "{cut_records}");
    }
}
