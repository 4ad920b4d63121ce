//! A pre-check of the TIFF directory structure that `rawloader::decode` walks, before it walks it.
//!
//! rawloader 0.37 reads every TIFF-structured file (any file starting with `II` or `MM`, and the
//! two TIFF roots of a Fujifilm RAF) into a tree of IFDs before it knows the camera. An IFD
//! (at most 4000 entries) follows, to depth 10 and with no memory of offsets already visited:
//! every one of the `count` pointers of its SubIFDs (0x014A), ExifIFDPointer (0x8769),
//! RafRawSubIFD (0xF000), KodakIFD (0x8290) and KdcIFD (0xFE00) entries, and its Makernote
//! (0x927C, whose IFD offset depends on the vendor prefix); a root follows up to 100 next-IFD
//! links at depth 0. The number of IFDs it builds is the size of that tree. Written as a
//! recurrence over `v(ifd, depth)`, the number of visits of the subtree below one IFD at one depth,
//!
//! ```text
//! v(i, d) = 1 + Σ_{pointers p of i} v(p, d + 1) + v(makernote(i), d + 1)   (d < 10; else 1)
//! ```
//!
//! which is exponential in the depth when IFDs point back at each other (a 454-byte file asks for
//! minutes of work and 1.5 GB). `v` depends only on the IFD's position (slice start, offset, base
//! offset of data pointers), its depth and its byte order, so memoising on those evaluates each
//! distinct (IFD, depth) once: [`rawloader_ifd_visits`] computes the same sum in time linear in
//! the distinct IFDs, and stops as soon as the sum exceeds the caller's limit, so at most `limit`
//! IFDs of at most 4000 entries are read. Every read is bounds-checked against the bytes
//! rawloader sees (the file plus the 16 zero bytes it appends); where rawloader would panic (a
//! read out of bounds, an unreadable pointer type) the walk of that branch ends, so the count is
//! never below rawloader's (a panic ends rawloader's whole walk).
//!
//! The same walk runs on every other TIFF structure rawloader 0.37 builds, each a new tree at
//! depth 0 with the same unbounded recurrence:
//! - **Minolta MRW**: one big-endian IFD at offset 8 of the TTW block (of the file when there is
//!   none), found by rawloader's block loop, which is replayed here ([`mrw_length_wrap`] is that
//!   loop's other hazard: a length that wraps its 32-bit arithmetic);
//! - **Sony** (`ArwDecoder::get_wb`, after the image is decoded): the little-endian IFD at the first
//!   DNGPrivateArea value, and the IFD at the start of the block that IFD's SonyOffset,
//!   SonyLength and SonyKey name, once decrypted (rawloader's key stream, replayed here; data
//!   pointers relative to the block). Counted for any TIFF tree with a DNGPrivateArea, Sony or
//!   not: an upper bound (for a DNG, whose private data starts "Adobe", one visit);
//! - **Sigma X3F**: the TIFF root inside the camera-information block is not counted; X3F files
//!   are refused before rawloader instead ([`is_x3f`]), since rawloader decodes none.
//!
//! Canon's CIFF (CRW) is not TIFF but is walked the same way: a heap's directory entries of
//! the two sub-heap types are followed to depth 10 with no memory of heaps visited, and up to
//! 65535 entries per heap. It is counted by the same memoised recurrence, on (heap start, heap
//! end, depth).
//!
//! The same tree tells which decoder rawloader will pick, and one of them allocates from the
//! header before it reads anything: the Sony SRF path reserves `width * height * 2` bytes (no
//! bound; a failed reservation aborts the process). [`sony_srf_size`] reports the size such a
//! file declares, so that it can be checked against the file and the frame-size limit first.
//!
//! A hand-made input for each path is in `fuzz/seeds/camera_raw/` (written by
//! `fuzz/make_seeds.py`); given to rawloader 0.37 directly, each of them runs for more than 8 s and
//! grows past 5 GB (the MRW length wrap: spins forever; the SRF seed: the process aborts on a
//! 2 TB reservation).

use std::collections::HashMap;

/// The largest number of IFD visits a camera raw file may ask of rawloader's walk.
///
/// Real files need a handful: a root chain of one to four IFDs, their SubIFDs, the Exif IFD and
/// a makernote with a few IFDs of its own (the DC50 KDC of the shared data: 3; the synthetic DNG
/// of the tests: 1). 1000 is two orders of magnitude above that, and bounds the pre-check at 1000
/// IFDs of at most 4000 entries (milliseconds).
pub const MAX_TIFF_IFD_VISITS: u64 = 1000;

/// Bytes rawloader appends (zeros) to the file before parsing it.
const PAD: usize = 16;
/// rawloader's entry limit per IFD (more: the IFD is an error, not followed).
const MAX_ENTRIES: u16 = 4000;
/// rawloader's depth limit: IFDs at this depth follow no pointers.
const MAX_DEPTH: u32 = 10;
/// rawloader's limit on a root's next-IFD chain.
const MAX_CHAIN: usize = 100;
/// Tags whose every value is an IFD offset that rawloader follows.
const SUB_IFD_TAGS: [u16; 5] = [0x014A, 0x8769, 0xF000, 0x8290, 0xFE00];
const MAKERNOTE: u16 = 0x927C;
/// log2 of the size of a TIFF type, as rawloader reads them (types 0 and > 13 read as bytes).
const SHIFTS: [u8; 14] = [0, 0, 0, 1, 2, 3, 0, 0, 1, 2, 3, 2, 3, 2];

/// The number of IFDs `rawloader::decode` would build for `bytes` (0 for files it does not parse
/// as TIFF), computed without building them.
///
/// The walk stops as soon as the count exceeds `limit`: a result above `limit` is a lower bound
/// (the file asks for at least that many). Never panics, whatever the bytes.
pub fn rawloader_ifd_visits(bytes: &[u8], limit: u64) -> u64 {
    match Walker::new(bytes, PAD, limit).file() {
        Ok(v) | Err(Exceeded(v)) => v,
    }
}

/// Where rawloader 0.37's Sony SRF decoder (`ArwDecoder::image_srf`) reads the samples: 16-bit,
/// `width * height * 2` bytes (encrypted) from this byte of the file (a constant from dcraw).
pub(super) const SRF_DATA_OFFSET: u64 = 862_144;

/// The image size a Sony SRF declares, `Some((width, height))`, when `rawloader::decode` would
/// take its SRF path for `bytes`; `None` otherwise (and when the TIFF walk exceeds
/// [`MAX_TIFF_IFD_VISITS`]: such a file is refused before this matters).
///
/// rawloader 0.37 picks that path for a TIFF tree without DNGVersion whose Make reads "SONY"
/// (and whose Model is not "DCS560C") when no IFD has StripOffsets and the Model is not
/// "DSLR-A100" (it also needs the model in its camera list, which is not checked here: an upper
/// bound). It then takes `width` and `height` from the first IFD with ImageWidth and, before
/// reading a sample, reserves `width * height * 2` bytes (`ArwDecoder::sony_decrypt`'s
/// `Vec::with_capacity`): up to 2^65 bytes from a header of two 32-bit values, and a failed
/// reservation aborts the process (rawloader's `catch_unwind` cannot catch it). The samples
/// are read from [`SRF_DATA_OFFSET`], so a real file holds `SRF_DATA_OFFSET + width * height *
/// 2` bytes at least.
pub(super) fn sony_srf_size(bytes: &[u8]) -> Option<(u32, u32)> {
    let mut w = Walker::new(bytes, PAD, MAX_TIFF_IFD_VISITS);
    let (_, f) = w.tiff_tree().ok()??;
    let srf = f[F_DNG].is_none()
        && f[F_MAKE] == Some(1)
        && f[F_MODEL] != Some(2)
        && f[F_STRIPS].is_none()
        && f[F_MODEL] != Some(1);
    if !srf {
        return None;
    }
    Some((f[F_WIDTH]?, f[F_SRF_HEIGHT]?))
}

/// Bytes followed by `pad` zeros (the file: [`PAD`]; a decrypted Sony block: none), read with
/// bounds checks.
struct Padded<'a> {
    bytes: &'a [u8],
    pad: usize,
}

impl Padded<'_> {
    fn len(&self) -> usize {
        self.bytes.len() + self.pad
    }

    fn byte(&self, pos: usize) -> Option<u8> {
        if pos < self.bytes.len() {
            Some(self.bytes[pos])
        } else if pos < self.len() {
            Some(0)
        } else {
            None
        }
    }

    fn bytes<const N: usize>(&self, pos: usize) -> Option<[u8; N]> {
        let mut out = [0u8; N];
        for (k, b) in out.iter_mut().enumerate() {
            *b = self.byte(pos.checked_add(k)?)?;
        }
        Some(out)
    }

    fn u16(&self, pos: usize, big: bool) -> Option<u16> {
        let b = self.bytes::<2>(pos)?;
        Some(if big {
            u16::from_be_bytes(b)
        } else {
            u16::from_le_bytes(b)
        })
    }

    fn u32(&self, pos: usize, big: bool) -> Option<u32> {
        let b = self.bytes::<4>(pos)?;
        Some(if big {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    /// `Some(true)` when the bytes at `pos` are `pat`; `None` when they are out of bounds (rawloader
    /// slices them: a panic).
    fn has(&self, pos: usize, pat: &[u8]) -> Option<bool> {
        let end = pos.checked_add(pat.len())?;
        if end > self.len() {
            return None;
        }
        Some((pos..end).zip(pat).all(|(p, &c)| self.byte(p) == Some(c)))
    }
}

/// The walk passed the limit, after counting this many visits.
struct Exceeded(u64);

/// The values of [`FOUND_TAGS`] that rawloader's `find_entry` returns for one IFD's subtree (the
/// IFD's own last entry of the tag, else the first found in its sub-IFDs in order), read as
/// rawloader reads them (`None`: absent, or a read where rawloader panics).
type Found = [Option<u32>; N_FOUND];

/// Slots of [`Found`]: one per tag of [`FOUND_TAGS`], then [`F_SRF_HEIGHT`].
const N_FOUND: usize = FOUND_TAGS.len() + 1;
/// Nothing found.
const NONE: Found = [None; N_FOUND];

/// Tags whose value decides a further walk: Olympus ImgProc (an IFD of the makernote),
/// DNGPrivateArea (Sony's private IFD) and, in that IFD, the offset, length and key of the
/// encrypted block holding Sony's SR2 sub-IFD; then the tags that decide whether rawloader takes
/// its Sony SRF path and the size it declares there ([`sony_srf_size`]).
const FOUND_TAGS: [u16; 11] = [
    OLYMPUS_IMG_PROC,
    DNG_PRIVATE_AREA,
    SONY_OFFSET,
    SONY_LENGTH,
    SONY_KEY,
    IMAGE_WIDTH,
    IMAGE_LENGTH,
    STRIP_OFFSETS,
    DNG_VERSION,
    MAKE,
    MODEL,
];
const OLYMPUS_IMG_PROC: u16 = 0x2040;
const DNG_PRIVATE_AREA: u16 = 0xC634;
const SONY_OFFSET: u16 = 0x7200;
const SONY_LENGTH: u16 = 0x7201;
const SONY_KEY: u16 = 0x7221;
const IMAGE_WIDTH: u16 = 0x0100;
const IMAGE_LENGTH: u16 = 0x0101;
const STRIP_OFFSETS: u16 = 0x0111;
const DNG_VERSION: u16 = 0xC612;
const MAKE: u16 = 0x010F;
const MODEL: u16 = 0x0110;
/// Indices into [`Found`].
const F_IMG_PROC: usize = 0;
const F_PRIVATE: usize = 1;
const F_SONY_OFFSET: usize = 2;
const F_SONY_LENGTH: usize = 3;
const F_SONY_KEY: usize = 4;
/// `ImageWidth`, as rawloader's `find_entry` finds it.
const F_WIDTH: usize = 5;
/// `ImageLength`, as `find_entry` finds it.
const F_LENGTH: usize = 6;
/// `Some(0)` when `StripOffsets` is present.
const F_STRIPS: usize = 7;
/// `Some(0)` when `DNGVersion` is present.
const F_DNG: usize = 8;
/// `Make`: `Some(1)` when it reads "SONY" (rawloader's `get_str`), else `Some(0)`.
const F_MAKE: usize = 9;
/// `Model`: `Some(1)` "DSLR-A100", `Some(2)` "DCS560C", else `Some(0)`.
const F_MODEL: usize = 10;
/// The `ImageLength` rawloader pairs with [`F_WIDTH`]: found from the IFD that holds that width
/// (its own, else the first in its sub-IFDs), as `fetch_tag!(raw, ImageLength)` reads it.
const F_SRF_HEIGHT: usize = 11;

/// `a` where it is set, else `b`, tag by tag.
fn or_found(a: Found, b: Found) -> Found {
    std::array::from_fn(|i| a[i].or(b[i]))
}

/// What rawloader's `TiffIFD::new` returns for one IFD, as far as the walk needs it.
#[derive(Clone, Copy)]
struct Ifd {
    /// IFDs built in this subtree (this one included).
    visits: u64,
    /// rawloader returned `Ok` (it is kept as a sub-IFD of its parent).
    parsed: bool,
    /// The next-IFD link (`None`: out of bounds).
    next: Option<u32>,
    /// The values of [`FOUND_TAGS`] in this subtree.
    found: Found,
}

impl Ifd {
    /// A branch where rawloader panics (or builds nothing).
    const DEAD: Ifd = Ifd {
        visits: 0,
        parsed: false,
        next: None,
        found: NONE,
    };
}

/// One IFD entry as rawloader's `TiffEntry::new` reads it: its data is `len` bytes at absolute
/// position `data`.
struct Entry {
    typ: u16,
    count: usize,
    /// Data offset relative to the IFD's slice (rawloader's `doffset`).
    doffset: usize,
    data: usize,
    len: usize,
    big: bool,
}

/// Memo key: slice start, IFD offset in the slice, base offset of data pointers, depth, big-endian.
type Key = (usize, usize, usize, u32, bool);

struct Walker<'a> {
    buf: Padded<'a>,
    limit: u64,
    memo: HashMap<Key, Ifd>,
    /// Canon CIFF heaps: (start, end, depth) -> visits.
    ciff_memo: HashMap<(usize, usize, u32), u64>,
}

impl<'a> Walker<'a> {
    fn new(bytes: &'a [u8], pad: usize, limit: u64) -> Self {
        Walker {
            buf: Padded { bytes, pad },
            limit,
            memo: HashMap::new(),
            ciff_memo: HashMap::new(),
        }
    }

    /// `RawLoader::get_decoder`'s order: an MRW holds one TIFF IFD; a Canon CIFF is a tree of
    /// heaps ([`Walker::ciff`]); ARRI and X3F are not walked here (X3F is refused before
    /// rawloader: see [`is_x3f`]); a RAF has two TIFF roots;
    /// anything else is a TIFF root at 0 when it starts with `II` or `MM`. A TIFF tree with a
    /// DNGPrivateArea entry adds the walks of rawloader's Sony white-balance reader.
    fn file(&mut self) -> Result<u64, Exceeded> {
        let b = &self.buf;
        if b.u32(0, true) == Some(MRW_MAGIC) {
            return self.mrw();
        }
        if b.has(6, b"HEAPCCDR") == Some(true) {
            // `CiffIFD::new_file`: the root heap from the header's length to the end of the file.
            return match b.u32(2, false) {
                Some(start) => self.ciff(start as usize, b.bytes.len(), 1),
                None => Ok(0),
            };
        }
        let Some((visits, found)) = self.tiff_tree()? else {
            return Ok(0);
        };
        let sony = self.sony_private(&found, visits)?;
        self.add(visits, sony)
    }

    /// `TiffIFD::new_file`: the visits of the file's own TIFF tree and what it holds of
    /// [`FOUND_TAGS`]; `None` for a file rawloader does not read as TIFF (MRW, CIFF, ARRI and X3F
    /// are decided before, in [`Walker::file`]'s order).
    fn tiff_tree(&mut self) -> Result<Option<(u64, Found)>, Exceeded> {
        let b = &self.buf;
        let not_tiff = b.u32(0, true) == Some(MRW_MAGIC)
            || b.has(6, b"HEAPCCDR") == Some(true)
            || b.has(0, b"ARRI") == Some(true)
            || b.has(0, b"FOVb") == Some(true);
        if not_tiff {
            return Ok(None);
        }
        Ok(Some(if b.has(0, b"FUJIFILM") == Some(true) {
            // rawloader adds 12 to the offset in 32 bits: it wraps in release builds.
            let Some(first) = b.u32(84, true).map(|o| o.wrapping_add(12)) else {
                return Ok(None);
            };
            let Some((v1, f1)) = self.root(first as usize)? else {
                return Ok(None);
            };
            let (v2, f2) = match self.buf.u32(100, true) {
                Some(o) => self.root(o as usize)?.unwrap_or((0, NONE)),
                None => (0, NONE),
            };
            (self.add(v1, v2)?, or_found(f1, f2))
        } else {
            match self.root(0)? {
                Some(r) => r,
                None => return Ok(None),
            }
        }))
    }

    /// `MrwDecoder::new`: the blocks up to the data offset, then one big-endian IFD at offset 8
    /// of the TTW block (of the file when there is none), not followed by its next-IFD link.
    /// Block lengths that wrap rawloader's arithmetic ([`mrw_length_wrap`]) end the count: such a
    /// file is refused before rawloader.
    fn mrw(&mut self) -> Result<u64, Exceeded> {
        match mrw_blocks(self.buf.bytes) {
            Mrw::Tiff(pos) => Ok(self.ifd(pos, 8, 0, 0, true)?.visits),
            Mrw::Wraps { .. } | Mrw::Panics => Ok(0),
        }
    }

    /// `ArwDecoder::get_wb`: the IFD at the first DNGPrivateArea value (little-endian, depth 0,
    /// in the whole file) and, when that IFD's subtree has the Sony offset, length and key, the
    /// IFD at the start of the decrypted block (its data pointers relative to the offset).
    /// Counted for every TIFF tree with a DNGPrivateArea, whatever its make (an upper bound:
    /// rawloader reads it for Sony files only). `visits` is the count so far.
    fn sony_private(&mut self, found: &Found, visits: u64) -> Result<u64, Exceeded> {
        let Some(p) = found[F_PRIVATE] else {
            return Ok(0);
        };
        let private = self.ifd(0, p as usize, 0, 0, false)?;
        let mut total = self.add(visits, private.visits)?;
        let f = private.found;
        let (Some(off), Some(len), Some(key)) = (f[F_SONY_OFFSET], f[F_SONY_LENGTH], f[F_SONY_KEY]) else {
            return Ok(total - visits);
        };
        let Some(block) = sony_decrypt(&self.buf, off as usize, len as usize, key) else {
            return Ok(total - visits);
        };
        let mut inner = Walker::new(&block, 0, self.limit - total);
        match inner.ifd(0, 0, off as usize, 0, false) {
            Ok(ifd) => total = self.add(total, ifd.visits)?,
            Err(Exceeded(v)) => return Err(Exceeded(total.saturating_add(v))),
        }
        Ok(total - visits)
    }

    /// `CiffIFD::new(buf, start, end, depth)`, Canon's CIFF (CRW) heap: its directory (at the
    /// offset in the heap's last 4 bytes) has up to 65535 entries of 10 bytes; an entry of type
    /// 0x2800 or 0x3000 is a sub-heap, followed below depth 10 with no memory of heaps already
    /// visited (the same recurrence as the TIFF walk's, counted the same way). An entry whose
    /// data location is neither in the heap nor in the entry ends the heap (rawloader: `Err`).
    fn ciff(&mut self, start: usize, end: usize, depth: u32) -> Result<u64, Exceeded> {
        let key = (start, end, depth);
        if let Some(&v) = self.ciff_memo.get(&key) {
            return Ok(v);
        }
        let mut visits = 1;
        let dir = end
            .checked_sub(4)
            .and_then(|p| self.buf.u32(p, false))
            .and_then(|v| start.checked_add(v as usize));
        let count = dir.and_then(|d| self.buf.u16(d, false)).unwrap_or(0);
        for i in 0..count as usize {
            let Some(eo) = dir.and_then(|d| d.checked_add(2 + 10 * i)) else {
                break;
            };
            let Some(p) = self.buf.u16(eo, false) else { break };
            let (size, off) = match p & 0xC000 {
                0x0000 => match (self.buf.u32(eo + 2, false), self.buf.u32(eo + 6, false)) {
                    (Some(size), Some(off)) => (size as usize, off as usize + start),
                    _ => break,
                },
                0x4000 => (8, eo + 2),
                _ => break,
            };
            // rawloader slices the entry's data: out of bounds, it panics.
            if off + size > self.buf.len() {
                break;
            }
            let typ = p & 0x3800;
            if (typ == 0x2800 || typ == 0x3000) && depth < MAX_DEPTH {
                let sub = self.ciff(off, off + size, depth + 1)?;
                visits = self.add(visits, sub)?;
            }
        }
        self.ciff_memo.insert(key, visits);
        Ok(visits)
    }

    /// `a + b`, an error once above the limit.
    fn add(&self, a: u64, b: u64) -> Result<u64, Exceeded> {
        let s = a.saturating_add(b);
        if s > self.limit {
            Err(Exceeded(s))
        } else {
            Ok(s)
        }
    }

    /// `TiffIFD::new_root`: the visits of the chain at `r` and what it holds of [`FOUND_TAGS`]
    /// (in chain order), `None` when `r` holds no byte-order mark.
    fn root(&mut self, r: usize) -> Result<Option<(u64, Found)>, Exceeded> {
        let big = match self.buf.u16(r, false) {
            Some(0x4949) => false,
            Some(0x4d4d) => true,
            _ => return Ok(None),
        };
        let mut found = NONE;
        let Some(mut next) = r.checked_add(4).and_then(|p| self.buf.u32(p, big)) else {
            return Ok(Some((0, found)));
        };
        let mut total = 0;
        for _ in 0..MAX_CHAIN {
            let ifd = self.ifd(r, next as usize, 0, 0, big)?;
            total = self.add(total, ifd.visits)?;
            if ifd.parsed {
                found = or_found(found, ifd.found);
            }
            match ifd.next {
                Some(n) if ifd.parsed && n != 0 => next = n,
                _ => break,
            }
        }
        Ok(Some((total, found)))
    }

    /// `TiffIFD::new(&buf[s..], o, b, _, depth, big)`.
    fn ifd(&mut self, s: usize, o: usize, b: usize, depth: u32, big: bool) -> Result<Ifd, Exceeded> {
        let key = (s, o, b, depth, big);
        if let Some(done) = self.memo.get(&key) {
            return Ok(*done);
        }
        let mut out = Ifd {
            visits: 1,
            ..Ifd::DEAD
        };
        let at = |rel: usize| s.checked_add(rel);
        let num = match at(o).and_then(|p| self.buf.u16(p, big)) {
            Some(n) if n <= MAX_ENTRIES => n,
            _ => {
                self.memo.insert(key, out);
                return Ok(out);
            }
        };
        out.parsed = true;
        let (mut own, mut sub): (Found, Found) = (NONE, NONE);
        for i in 0..num as usize {
            let Some(eo) = o.checked_add(2 + 12 * i) else {
                break;
            };
            let Some(tag) = at(eo).and_then(|p| self.buf.u16(p, big)) else {
                break;
            };
            let found_at = FOUND_TAGS.iter().position(|&t| t == tag);
            let special = SUB_IFD_TAGS.contains(&tag) || tag == MAKERNOTE || found_at.is_some();
            if !special {
                continue;
            }
            let Some(entry) = self.entry(s, eo, b, big) else {
                break;
            };
            if let Some(f) = found_at {
                // The map of entries keeps the last one. DNGPrivateArea is read as a LONG
                // whatever its type (`get_force_u32`), Make and Model as strings (`get_str`),
                // StripOffsets and DNGVersion only tested for presence, the others as `get_u32`.
                own[f] = match f {
                    F_PRIVATE => (entry.len >= 4).then(|| self.buf.u32(entry.data, big)).flatten(),
                    F_STRIPS | F_DNG => Some(0),
                    F_MAKE => Some(u32::from(self.text(&entry).as_deref() == Some("SONY"))),
                    F_MODEL => Some(match self.text(&entry).as_deref() {
                        Some("DSLR-A100") => 1,
                        Some("DCS560C") => 2,
                        _ => 0,
                    }),
                    _ => self.value(&entry, 0),
                };
                continue;
            }
            if depth >= MAX_DEPTH {
                continue;
            }
            let children = if tag == MAKERNOTE { 1 } else { entry.count };
            for k in 0..children {
                let child = if tag == MAKERNOTE {
                    self.makernote(s, entry.doffset, b, depth + 1, big)?
                } else {
                    let Some(p) = self.value(&entry, k) else { break };
                    self.ifd(s, p as usize, b, depth + 1, big)?
                };
                out.visits = self.add(out.visits, child.visits)?;
                if child.parsed {
                    sub = or_found(sub, child.found);
                }
            }
        }
        out.found = or_found(own, sub);
        if own[F_WIDTH].is_some() {
            // `fetch_tag!(raw, ImageLength)` on the IFD that holds the width.
            out.found[F_SRF_HEIGHT] = out.found[F_LENGTH];
        }
        out.next = o
            .checked_add(2 + 12 * num as usize)
            .and_then(at)
            .and_then(|p| self.buf.u32(p, big));
        self.memo.insert(key, out);
        Ok(out)
    }

    /// `TiffEntry::new` for the entry at `eo` of the slice at `s`; `None` where rawloader panics.
    fn entry(&self, s: usize, eo: usize, b: usize, big: bool) -> Option<Entry> {
        let pos = s.checked_add(eo)?;
        let mut typ = self.buf.u16(pos.checked_add(2)?, big)?;
        if typ == 0 || typ > 13 {
            typ = 1;
        }
        let count = self.buf.u32(pos.checked_add(4)?, big)? as usize;
        let len = count.checked_shl(SHIFTS[typ as usize] as u32)?;
        let doffset = if len <= 4 {
            eo.checked_add(8)?
        } else {
            (self.buf.u32(pos.checked_add(8)?, big)? as usize).checked_sub(b)?
        };
        let data = s.checked_add(doffset)?;
        if data.checked_add(len)? > self.buf.len() {
            return None;
        }
        Some(Entry {
            typ,
            count,
            doffset,
            data,
            len,
            big,
        })
    }

    /// `TiffEntry::get_str`: the data up to its first NUL, trimmed; `None` where rawloader
    /// panics (not UTF-8).
    fn text(&self, e: &Entry) -> Option<String> {
        let bytes: Vec<u8> = (e.data..e.data + e.len)
            .map_while(|p| self.buf.byte(p))
            .take_while(|&c| c != 0)
            .collect();
        String::from_utf8(bytes).ok().map(|t| t.trim().to_string())
    }

    /// `TiffEntry::get_u32(k)`; `None` where rawloader panics.
    fn value(&self, e: &Entry, k: usize) -> Option<u32> {
        let (size, shift) = match e.typ {
            1 => (1, 0),
            3 | 8 => (2, 1),
            4 | 7 | 9 | 13 => (4, 2),
            _ => return None,
        };
        let rel = k.checked_shl(shift)?;
        if rel.checked_add(size)? > e.len {
            return None;
        }
        let p = e.data + rel;
        match size {
            1 => self.buf.byte(p).map(u32::from),
            2 => self.buf.u16(p, e.big).map(u32::from),
            _ => self.buf.u32(p, e.big),
        }
    }

    /// `TiffIFD::new_makernote(&buf[s..], o, b, depth, big)`: the vendor prefix decides where the
    /// IFD is, which slice its pointers are relative to and its byte order.
    fn makernote(&mut self, s: usize, o: usize, b: usize, depth: u32, big: bool) -> Result<Ifd, Exceeded> {
        let Some(d) = s.checked_add(o) else {
            return Ok(Ifd::DEAD);
        };
        let buf = &self.buf;
        let Some(olymp) = buf.has(d, b"OLYMP") else {
            return Ok(Ifd::DEAD);
        };
        if olymp {
            let Some(olympus) = buf.has(d, b"OLYMPUS") else {
                return Ok(Ifd::DEAD);
            };
            let off = if olympus { 12 } else { 8 };
            let Some(mo) = o.checked_add(off) else {
                return Ok(Ifd::DEAD);
            };
            let mut main = self.ifd(s, mo, b, depth, big)?;
            let ioff = main.found[F_IMG_PROC].filter(|&v| v != 0);
            if main.parsed && olympus {
                if let Some(ioff) = ioff {
                    let Some(is) = d.checked_add(ioff as usize) else {
                        return Ok(main);
                    };
                    let ip = self.ifd(is, 0, ioff as usize, depth, big)?;
                    main.visits = self.add(main.visits, ip.visits)?;
                    main.parsed = ip.parsed;
                    main.found = or_found(main.found, ip.found);
                }
            }
            return Ok(main);
        }
        let mut off = 0usize;
        let (Some(epson), Some(aoc), Some(pentax)) =
            (buf.has(d, b"EPSON"), buf.has(d, b"AOC\0"), buf.has(d, b"PENTAX"))
        else {
            return Ok(Ifd::DEAD);
        };
        if epson {
            off += 8;
        }
        if aoc {
            off += 4;
        }
        if pentax {
            off += 8;
            let Some(little) = buf.has(d + off, b"II") else {
                return Ok(Ifd::DEAD);
            };
            return self.ifd(d, 10, b, depth, !little);
        }
        let Some(nikon) = buf.has(d, b"Nikon\0\x02") else {
            return Ok(Ifd::DEAD);
        };
        if nikon {
            off += 10;
            let Some(little) = buf.has(d + off, b"II") else {
                return Ok(Ifd::DEAD);
            };
            return self.ifd(d + off, 8, b, depth, !little);
        }
        let mut big = big;
        let Some(ii) = buf.has(d + off, b"II") else {
            return Ok(Ifd::DEAD);
        };
        if ii {
            off += 2;
            big = false;
        }
        let Some(mm) = buf.has(d + off, b"MM") else {
            return Ok(Ifd::DEAD);
        };
        if mm {
            off += 2;
            big = true;
        }
        self.ifd(s, o + off, b, depth, big)
    }
}

/// The first four bytes of a Minolta MRW (`\0MRM`), big-endian.
const MRW_MAGIC: u32 = 0x004D_524D;

/// What `MrwDecoder::new` does with a file's blocks.
enum Mrw {
    /// It reads the TIFF IFD at offset 8 of the slice starting here.
    Tiff(usize),
    /// It adds 8 to a 32-bit length at byte `offset` in 32 bits, which wraps.
    Wraps { offset: usize, len: u32 },
    /// It reads out of bounds (a caught panic: the file is refused by rawloader).
    Panics,
}

/// `MrwDecoder::new`'s block loop over the file as rawloader sees it (the bytes and [`PAD`]
/// zeros), in checked arithmetic: the data offset is the header's length + 8, blocks of (tag,
/// length) follow from byte 8 while `pos + 20 < data offset`, each advancing by length + 8, and
/// the TTW block gives the TIFF's position. Both additions are 32-bit in rawloader.
fn mrw_blocks(bytes: &[u8]) -> Mrw {
    let buf = Padded { bytes, pad: PAD };
    let Some(head) = buf.u32(4, true) else {
        return Mrw::Panics;
    };
    let Some(data_offset) = head.checked_add(8) else {
        return Mrw::Wraps { offset: 4, len: head };
    };
    let data_offset = data_offset as usize;
    let (mut pos, mut tiff) = (8usize, 0usize);
    while pos + 20 < data_offset {
        let (Some(tag), Some(len)) = (buf.u32(pos, true), buf.u32(pos + 4, true)) else {
            return Mrw::Panics;
        };
        match tag {
            // PRD reads a byte at pos + 24, WBG up to pos + 20.
            0x50_5244 if buf.byte(pos + 24).is_none() => return Mrw::Panics,
            0x57_4247 if buf.len() < pos + 20 => return Mrw::Panics,
            0x54_5457 => tiff = pos + 8,
            _ => {}
        }
        let Some(step) = len.checked_add(8) else {
            return Mrw::Wraps { offset: pos + 4, len };
        };
        pos += step as usize;
    }
    Mrw::Tiff(tiff)
}

/// A Minolta MRW length field that wraps rawloader 0.37's 32-bit offset arithmetic: `Some((byte
/// offset of the field, its value))`, the first one rawloader's block loop meets.
///
/// `MrwDecoder::new` computes the data offset as the header's length + 8 and steps from block to
/// block by each block's length + 8, in `u32`. A length above `u32::MAX - 8` panics with overflow
/// checks on (debug builds: rawloader catches it) and wraps without (release builds): a block
/// length of `0xFFFF_FFF8` then steps by 0 and the loop never ends (a 52-byte file keeps
/// `mosaicd gradients` busy forever). `None` for any other file, MRW or not.
pub(super) fn mrw_length_wrap(bytes: &[u8]) -> Option<(usize, u32)> {
    let buf = Padded { bytes, pad: PAD };
    if buf.u32(0, true) != Some(MRW_MAGIC) {
        return None;
    }
    match mrw_blocks(bytes) {
        Mrw::Wraps { offset, len } => Some((offset, len)),
        Mrw::Tiff(_) | Mrw::Panics => None,
    }
}

/// A Sigma X3F (`FOVb`): rawloader 0.37 walks its embedded TIFF root (unbounded like any other)
/// and then decodes no X3F image (its one compressed format returns "not implemented"; X3F
/// holds three colours per pixel, not a mosaic), so such files are refused before rawloader.
pub(super) fn is_x3f(bytes: &[u8]) -> bool {
    bytes.starts_with(b"FOVb")
}

/// `ArwDecoder::sony_decrypt(buf, off, len, key)`: `len / 4 + 1` little-endian words from `off`,
/// each XORed with the next word of a pad generated from `key`; `None` where rawloader reads out
/// of bounds (it panics). The block is at most the file's size.
fn sony_decrypt(buf: &Padded<'_>, off: usize, len: usize, key: u32) -> Option<Vec<u8>> {
    let words = len / 4 + 1;
    if off.checked_add(words.checked_mul(4)?)? > buf.len() {
        return None;
    }
    let mut pad = [0u32; 128];
    let mut k = key;
    for p in pad.iter_mut().take(4) {
        k = k.wrapping_mul(48_828_125).wrapping_add(1);
        *p = k;
    }
    pad[3] = (pad[3] << 1) | ((pad[0] ^ pad[2]) >> 31);
    for p in 4..127 {
        pad[p] = ((pad[p - 4] ^ pad[p - 2]) << 1) | ((pad[p - 3] ^ pad[p - 1]) >> 31);
    }
    for p in pad.iter_mut().take(127) {
        *p = u32::from_be(*p);
    }
    let mut out = Vec::with_capacity(words * 4);
    for i in 0..words {
        let p = i + 127;
        pad[p & 127] = pad[(p + 1) & 127] ^ pad[(p + 1 + 64) & 127];
        let w = buf.u32(off + i * 4, false)? ^ pad[p & 127];
        out.extend(w.to_le_bytes());
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (tag, type, count, inline value).
    type TestEntry = (u16, u16, u32, u32);

    /// A little-endian TIFF: header, then IFDs given as (entries, next) laid out from offset 8,
    /// each entry (tag, type, count, value) with its value inline.
    fn tiff(ifds: &[(Vec<TestEntry>, u32)]) -> Vec<u8> {
        let mut out = b"II*\0\x08\0\0\0".to_vec();
        for (entries, next) in ifds {
            out.extend((entries.len() as u16).to_le_bytes());
            for &(tag, typ, count, value) in entries {
                out.extend(tag.to_le_bytes());
                out.extend(typ.to_le_bytes());
                out.extend(count.to_le_bytes());
                out.extend(value.to_le_bytes());
            }
            out.extend(next.to_le_bytes());
        }
        out
    }

    /// Offset of the `k`-th IFD of [`tiff`] when every IFD before it has `n` entries.
    fn at(k: u32, n: u32) -> u32 {
        8 + k * (2 + 12 * n + 4)
    }

    #[test]
    fn a_legitimate_sub_ifd_is_two_visits() {
        let t = tiff(&[
            (vec![(0x0100, 3, 1, 8), (0x014A, 4, 1, at(1, 2))], 0),
            (vec![(0x0100, 3, 1, 8), (0x0101, 3, 1, 8)], 0),
        ]);
        assert_eq!(rawloader_ifd_visits(&t, MAX_TIFF_IFD_VISITS), 2);
        // A chain of two roots, the first with an Exif IFD: three.
        let t = tiff(&[
            (vec![(0x8769, 4, 1, at(2, 1))], at(1, 1)),
            (vec![(0x0100, 3, 1, 8)], 0),
            (vec![(0x0100, 3, 1, 8)], 0),
        ]);
        assert_eq!(rawloader_ifd_visits(&t, MAX_TIFF_IFD_VISITS), 3);
    }

    #[test]
    fn a_self_referencing_sub_ifd_is_followed_to_depth_ten() {
        // One pointer to itself: the IFD at depths 0..=10, eleven visits (rawloader's own bound).
        let t = tiff(&[(vec![(0x014A, 4, 1, 8)], 0)]);
        assert_eq!(rawloader_ifd_visits(&t, MAX_TIFF_IFD_VISITS), 11);
        // Two pointers to itself (type LONG, count 2: the values at offset 26): 2^11 - 1 visits.
        let mut t = tiff(&[(vec![(0x014A, 4, 2, 26)], 0)]);
        t.extend([8, 0, 0, 0, 8, 0, 0, 0]);
        assert_eq!(rawloader_ifd_visits(&t, u64::MAX), 2047);
        // Over the limit: the walk stops early with a lower bound above it.
        let v = rawloader_ifd_visits(&t, MAX_TIFF_IFD_VISITS);
        assert!(v > MAX_TIFF_IFD_VISITS, "{v}");
    }

    #[test]
    fn not_tiff_and_truncations_never_panic() {
        assert_eq!(rawloader_ifd_visits(b"not a raw file", 10), 0);
        assert_eq!(rawloader_ifd_visits(b"", 10), 0);
        let mut t = tiff(&[(vec![(0x014A, 4, 2, 26)], 0)]);
        t.extend([8, 0, 0, 0, 8, 0, 0, 0]);
        for n in 0..t.len() {
            let v = rawloader_ifd_visits(&t[..n], u64::MAX);
            assert!(v <= 2047, "{n}: {v}");
        }
        // Pointers and counts at their extremes: the root IFD, its makernote (2 bytes inline,
        // read as an IFD of 0xFFF0 entries: refused by rawloader, still one visit), the SubIFDs
        // entry whose data lies beyond the file (rawloader panics there: not followed), and the
        // next IFD at 2^32 - 1 (counted once: rawloader panics reading it).
        let t = tiff(&[(
            vec![(0x927C, 7, 2, 0xFFFF_FFF0), (0x014A, 4, u32::MAX, u32::MAX)],
            u32::MAX,
        )]);
        assert_eq!(rawloader_ifd_visits(&t, MAX_TIFF_IFD_VISITS), 3);
    }

    /// Write `bytes` to a temporary `.dng` and load it through [`super::super::load_camera_raw`].
    fn load(bytes: &[u8]) -> Result<crate::raw::RawFrame, crate::raw::RawError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.dng");
        std::fs::write(&p, bytes).unwrap();
        super::super::load_camera_raw(&p)
    }

    #[test]
    fn the_fuzzers_subifd_explosion_is_refused_quickly() {
        let bytes = include_bytes!("../../../fuzz/seeds/camera_raw/tiff-subifd-explosion.bin");
        let t = std::time::Instant::now();
        let e = load(bytes).unwrap_err();
        let took = t.elapsed();
        match e {
            crate::raw::RawError::TiffWalk { visits, limit, .. } => {
                assert_eq!(limit, MAX_TIFF_IFD_VISITS);
                assert!(visits > limit, "{visits}");
            }
            e => panic!("want TiffWalk, got {e}"),
        }
        assert!(took < std::time::Duration::from_millis(200), "{took:?}");
        // The whole walk rawloader would do, counted without a limit (memoised: still quick).
        let all = rawloader_ifd_visits(bytes, u64::MAX);
        assert!(all > 1_000_000, "{all}");
        eprintln!("fuzz input refused in {took:?}: {e:?}; the whole walk is {all} IFD visits");
    }

    #[test]
    fn hand_built_tiffs_reach_rawloader_unless_they_loop() {
        // A legitimate SubIFD: past the pre-check, refused by rawloader (no Make: no decoder).
        let ok = tiff(&[
            (vec![(0x0100, 3, 1, 8), (0x014A, 4, 1, at(1, 2))], 0),
            (vec![(0x0100, 3, 1, 8), (0x0101, 3, 1, 8)], 0),
        ]);
        let e = load(&ok).unwrap_err();
        assert!(matches!(e, crate::raw::RawError::Format { .. }), "{e}");
        assert!(e.to_string().contains("no camera raw decoder"), "{e}");
        // A SubIFD that points at itself twice: 2047 visits, refused naming count and limit.
        let mut bomb = tiff(&[(vec![(0x014A, 4, 2, 26)], 0)]);
        bomb.extend([8, 0, 0, 0, 8, 0, 0, 0]);
        let e = load(&bomb).unwrap_err();
        assert!(
            matches!(e, crate::raw::RawError::TiffWalk { limit: 1000, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("more than the limit of 1000"), "{e}");
        // Every truncation of both is an error, never a panic.
        for b in [&ok, &bomb] {
            for n in 0..b.len() {
                assert!(load(&b[..n]).is_err(), "{n}");
            }
        }
    }

    /// A committed hand-made seed of `fuzz/seeds/camera_raw/`.
    fn seed(name: &str) -> Vec<u8> {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/seeds/camera_raw")
            .join(name);
        std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
    }

    /// Load `bytes` as a camera raw file; the error and how long it took.
    fn refused(bytes: &[u8]) -> (crate::raw::RawError, std::time::Duration) {
        let t = std::time::Instant::now();
        let e = load(bytes).unwrap_err();
        (e, t.elapsed())
    }

    #[test]
    fn every_embedded_tiff_walk_is_counted_and_refused_quickly() {
        // Each seed holds one IFD (or CIFF heap) listing itself 8 times, reached through a
        // different path of rawloader: 8^10 + ... visits in rawloader (the CIFF: 8^9 + ...), a few
        // dozen distinct (IFD, depth) pairs here.
        for (name, least) in [
            ("mrw-tiff-explosion.bin", 1_000_000_000),
            ("arw-private-explosion.bin", 1_000_000_000),
            ("arw-sr2-explosion.bin", 1_000_000_000),
            ("ciff-heap-explosion.bin", 150_000_000),
        ] {
            let bytes = seed(name);
            let all = rawloader_ifd_visits(&bytes, u64::MAX);
            assert!(all > least, "{name}: {all}");
            let (e, took) = refused(&bytes);
            match e {
                crate::raw::RawError::TiffWalk { visits, limit, .. } => {
                    assert_eq!(limit, MAX_TIFF_IFD_VISITS);
                    assert!(visits > limit, "{name}: {visits}");
                }
                e => panic!("{name}: want TiffWalk, got {e}"),
            }
            assert!(took < std::time::Duration::from_millis(200), "{name}: {took:?}");
            eprintln!("{name}: refused in {took:?}; the whole walk is {all} IFD visits");
        }
    }

    #[test]
    fn sony_private_walks_need_their_tags_and_a_readable_block() {
        let sr2 = seed("arw-sr2-explosion.bin");
        // The same file with the key changed decrypts to noise: only the root (1) and the private
        // IFD (1) are walked, the decrypted block's first IFD refused or small.
        let key_at = sr2
            .windows(4)
            .position(|w| w == 0x1234_5678u32.to_le_bytes())
            .unwrap();
        let mut wrong_key = sr2.clone();
        wrong_key[key_at] ^= 1;
        assert!(rawloader_ifd_visits(&wrong_key, u64::MAX) < 100);
        // Cut inside the encrypted block: rawloader reads past the end (a caught panic), no walk.
        let cut = &sr2[..sr2.len() - 30];
        assert_eq!(rawloader_ifd_visits(cut, u64::MAX), 2);
        // Without DNGPrivateArea (tag renamed to an unknown one): the root alone.
        let mut no_private = sr2.clone();
        let tag_at = no_private
            .windows(4)
            .position(|w| w == [0x34, 0xC6, 4, 0])
            .unwrap();
        no_private[tag_at] = 0x35;
        assert_eq!(rawloader_ifd_visits(&no_private, u64::MAX), 1);
        // The key stream is an XOR: decrypting twice gives the bytes back (that it matches the seed
        // writer's encryption is shown by the explosion the seed decrypts to, above).
        let buf = Padded {
            bytes: &sr2,
            pad: PAD,
        };
        let block = sony_decrypt(&buf, 0, 40, 7).unwrap();
        let again = sony_decrypt(
            &Padded {
                bytes: &block,
                pad: 0,
            },
            0,
            40,
            7,
        )
        .unwrap();
        assert_eq!(&again[..40], &sr2[..40]);
    }

    #[test]
    fn an_mrw_length_that_wraps_is_refused_before_rawloader() {
        let bytes = seed("mrw-length-wrap.bin");
        assert_eq!(mrw_length_wrap(&bytes), Some((12, 0xFFFF_FFF8)));
        let (e, took) = refused(&bytes);
        assert!(
            matches!(
                e,
                crate::raw::RawError::MrwLength {
                    offset: 12,
                    len: 0xFFFF_FFF8,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("0xfffffff8 at byte 12"), "{e}");
        assert!(took < std::time::Duration::from_millis(200), "{took:?}");
        // Every length that wraps, in the header or a block; none that does not.
        let mrw = |head: u32, len: u32| {
            let mut b = b"\0MRM".to_vec();
            b.extend(head.to_be_bytes());
            b.extend(b"\0PRD");
            b.extend(len.to_be_bytes());
            b.extend([0u8; 32]);
            b
        };
        for len in 0xFFFF_FFF8..=u32::MAX {
            assert_eq!(mrw_length_wrap(&mrw(100, len)), Some((12, len)));
            assert_eq!(mrw_length_wrap(&mrw(len, 8)), Some((4, len)));
        }
        assert_eq!(mrw_length_wrap(&mrw(100, 0xFFFF_FFF7)), None);
        assert_eq!(mrw_length_wrap(&mrw(100, 16)), None);
        // Not an MRW, and every truncation: no answer, no panic.
        assert_eq!(mrw_length_wrap(b"II*\0"), None);
        for n in 0..bytes.len() {
            let _ = mrw_length_wrap(&bytes[..n]);
            let _ = rawloader_ifd_visits(&bytes[..n], u64::MAX);
        }
    }

    #[test]
    fn an_mrw_tiff_block_is_found_where_rawloader_finds_it() {
        let bytes = seed("mrw-tiff-explosion.bin");
        assert!(matches!(mrw_blocks(&bytes), Mrw::Tiff(16)));
        // A benign MRW: a TTW block with one IFD of no entries, one visit.
        let mut ok = b"\0MRM".to_vec();
        let tiff = b"MM\0*\0\0\0\x08\0\0\0\0\0\0";
        ok.extend((8 + tiff.len() as u32).to_be_bytes());
        ok.extend(b"\0TTW");
        ok.extend((tiff.len() as u32).to_be_bytes());
        ok.extend(tiff);
        assert_eq!(rawloader_ifd_visits(&ok, MAX_TIFF_IFD_VISITS), 1);
        let e = load(&ok).unwrap_err();
        assert!(matches!(e, crate::raw::RawError::Format { .. }), "{e}");
    }

    /// A little-endian Sony TIFF as `fuzz/make_seeds.py`'s `srf` writes it (ImageWidth, ImageLength,
    /// Make "SONY", Model `model`), `extra` entries after those, zero-filled to `size` bytes.
    fn srf(w: u32, h: u32, model: &str, extra: &[TestEntry], size: usize) -> Vec<u8> {
        let n = 4 + extra.len() as u32;
        let make = 8 + 2 + 12 * n + 4;
        let model_at = make + 6;
        let mut entries: Vec<TestEntry> = vec![
            (0x0100, 4, 1, w),
            (0x0101, 4, 1, h),
            (0x010F, 2, 5, make),
            (0x0110, 2, model.len() as u32 + 1, model_at),
        ];
        entries.extend_from_slice(extra);
        let mut out = tiff(&[(entries, 0)]);
        out.extend(b"SONY\0\0");
        out.extend(model.as_bytes());
        out.push(0);
        out.resize(size, 0);
        out
    }

    #[test]
    fn an_srf_declaring_more_than_its_bytes_is_refused_before_rawloader() {
        // 1,000,000 x 1,000,000 in a 200,960-byte file: rawloader 0.37 reserves 2 TB for it and
        // the process aborts ("memory allocation of 2000000000004 bytes failed").
        let bytes = seed("srf-huge-dimensions.bin");
        assert_eq!(sony_srf_size(&bytes), Some((1_000_000, 1_000_000)));
        let (e, took) = refused(&bytes);
        match &e {
            crate::raw::RawError::SrfSize {
                width,
                height,
                data_offset,
                needed,
                file_len,
                ..
            } => {
                assert_eq!((*width, *height), (1_000_000, 1_000_000));
                assert_eq!(*data_offset, SRF_DATA_OFFSET);
                assert_eq!(*needed, SRF_DATA_OFFSET + 2_000_000_000_000);
                assert_eq!(*file_len, bytes.len() as u64);
            }
            e => panic!("want SrfSize, got {e}"),
        }
        let msg = e.to_string();
        assert!(
            msg.contains("1000000x1000000") && msg.contains("2000000862144"),
            "{msg}"
        );
        assert!(took < std::time::Duration::from_millis(200), "{took:?}");
        eprintln!("srf-huge-dimensions.bin: refused in {took:?}: {e}");
        // Dimensions whose product wraps 64 bits: saturated, still refused.
        let (e, _) = refused(&srf(u32::MAX, u32::MAX, "DSC-F828", &[], 1000));
        assert!(
            matches!(e, crate::raw::RawError::SrfSize { needed: u64::MAX, .. }),
            "{e}"
        );
    }

    #[test]
    fn an_srf_whose_samples_fit_reaches_rawloader() {
        // 16x2 samples end exactly at the file's end: past the check, decoded by rawloader, then
        // refused by us for the F828's four-colour "ERBG" pattern (not a Bayer mosaic).
        let fits = (SRF_DATA_OFFSET + 16 * 2 * 2) as usize;
        let ok = srf(16, 2, "DSC-F828", &[], fits);
        assert_eq!(sony_srf_size(&ok), Some((16, 2)));
        let (e, _) = refused(&ok);
        assert!(e.to_string().contains("\"ERBG\""), "{e}");
        // One byte short: refused before rawloader.
        let (e, _) = refused(&ok[..fits - 1]);
        assert!(
            matches!(e, crate::raw::RawError::SrfSize { needed, file_len, .. } if needed == file_len + 1),
            "{e}"
        );
        // Within the file but a side above the frame-size limit's: refused.
        let side = crate::raw::limits::MAX_SIDE as u32 + 1;
        let wide = srf(
            side,
            1,
            "DSC-F828",
            &[],
            SRF_DATA_OFFSET as usize + 2 * side as usize,
        );
        let (e, _) = refused(&wide);
        assert!(
            matches!(e, crate::raw::RawError::SrfSize { width, .. } if width == u64::from(side)),
            "{e}"
        );
    }

    #[test]
    fn only_rawloaders_srf_path_is_checked() {
        let size = 1000;
        let huge = |model: &str, extra: &[TestEntry]| srf(1_000_000, 1_000_000, model, extra, size);
        assert_eq!(
            sony_srf_size(&huge("DSC-F828", &[])),
            Some((1_000_000, 1_000_000))
        );
        // StripOffsets anywhere: the ARW path (whose allocations rawloader bounds at 500 MP).
        assert_eq!(sony_srf_size(&huge("DSC-F828", &[(0x0111, 4, 1, 8)])), None);
        // DNGVersion: the DNG decoder.
        assert_eq!(sony_srf_size(&huge("DSC-F828", &[(0xC612, 1, 4, 0x0104)])), None);
        // The A100 (fixed 3881x2608) and the DCS560C (CR2) take other paths.
        assert_eq!(sony_srf_size(&huge("DSLR-A100", &[])), None);
        assert_eq!(sony_srf_size(&huge("DCS560C", &[])), None);
        // Another make.
        let mut other = huge("DSC-F828", &[]);
        let at = other.windows(5).position(|w| w == b"SONY\0").unwrap();
        other[at + 1] = b'o';
        assert_eq!(sony_srf_size(&other), None);
        // The height is the one of the IFD holding the width (its own, else its sub-IFD's), not
        // an ImageLength found earlier: root IFD with ImageLength 7 and a SubIFD holding width
        // 3 and its own SubIFD with ImageLength 5 (IFDs of 3, 2 and 1 entries: at 8, 50, 80).
        let t = tiff(&[
            (
                vec![
                    (0x0101, 4, 1, 7),
                    (0x010F, 2, 4, u32::from_le_bytes(*b"SONY")),
                    (0x014A, 4, 1, 50),
                ],
                0,
            ),
            (vec![(0x0100, 4, 1, 3), (0x014A, 4, 1, 80)], 0),
            (vec![(0x0101, 4, 1, 5)], 0),
        ]);
        assert_eq!(sony_srf_size(&t), Some((3, 5)));
        // Every truncation of the seed: no panic.
        let bytes = seed("srf-huge-dimensions.bin");
        for n in 0..300 {
            let _ = sony_srf_size(&bytes[..n]);
        }
    }

    #[test]
    fn x3f_is_refused_before_rawloader_walks_it() {
        let bytes = seed("x3f-tiff-explosion.bin");
        assert!(is_x3f(&bytes));
        let (e, took) = refused(&bytes);
        assert!(matches!(e, crate::raw::RawError::Format { .. }), "{e}");
        assert!(e.to_string().contains("Sigma X3F is not supported"), "{e}");
        assert!(took < std::time::Duration::from_millis(200), "{took:?}");
    }
}
