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
//! Not pre-walked: the TIFF block inside a Minolta MRW, Sigma X3F's embedded root and Sony ARW's
//! private IFD (each read by rawloader after the container's own parsing).

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
const OLYMPUS_IMG_PROC: u16 = 0x2040;
/// log2 of the size of a TIFF type, as rawloader reads them (types 0 and > 13 read as bytes).
const SHIFTS: [u8; 14] = [0, 0, 0, 1, 2, 3, 0, 0, 1, 2, 3, 2, 3, 2];

/// The number of IFDs `rawloader::decode` would build for `bytes` (0 for files it does not parse
/// as TIFF), computed without building them.
///
/// The walk stops as soon as the count exceeds `limit`: a result above `limit` is a lower bound
/// (the file asks for at least that many). Never panics, whatever the bytes.
pub fn rawloader_ifd_visits(bytes: &[u8], limit: u64) -> u64 {
    let mut w = Walker {
        buf: Padded(bytes),
        limit,
        memo: HashMap::new(),
    };
    match w.file() {
        Ok(v) | Err(Exceeded(v)) => v,
    }
}

/// The file's bytes followed by [`PAD`] zeros, read with bounds checks.
struct Padded<'a>(&'a [u8]);

impl Padded<'_> {
    fn len(&self) -> usize {
        self.0.len() + PAD
    }

    fn byte(&self, pos: usize) -> Option<u8> {
        if pos < self.0.len() {
            Some(self.0[pos])
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

/// What rawloader's `TiffIFD::new` returns for one IFD, as far as the walk needs it.
#[derive(Clone, Copy)]
struct Ifd {
    /// IFDs built in this subtree (this one included).
    visits: u64,
    /// rawloader returned `Ok` (it is kept as a sub-IFD of its parent).
    parsed: bool,
    /// The next-IFD link (`None`: out of bounds).
    next: Option<u32>,
    /// The first Olympus ImgProc offset `find_entry` finds in this subtree.
    img_proc: Option<u32>,
}

impl Ifd {
    /// A branch where rawloader panics (or builds nothing).
    const DEAD: Ifd = Ifd {
        visits: 0,
        parsed: false,
        next: None,
        img_proc: None,
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
}

impl Walker<'_> {
    /// `RawLoader::get_decoder`'s order: MRW, CIFF, ARRI and X3F are not TIFF files; a RAF has two
    /// TIFF roots; anything else is a TIFF root at 0 when it starts with `II` or `MM`.
    fn file(&mut self) -> Result<u64, Exceeded> {
        let b = &self.buf;
        let not_tiff = b.u32(0, true) == Some(0x004D_524D)
            || b.has(6, b"HEAPCCDR") == Some(true)
            || b.has(0, b"ARRI") == Some(true)
            || b.has(0, b"FOVb") == Some(true);
        if not_tiff {
            return Ok(0);
        }
        if b.has(0, b"FUJIFILM") == Some(true) {
            let Some(first) = b.u32(84, true).and_then(|o| o.checked_add(12)) else {
                return Ok(0);
            };
            let Some(v1) = self.root(first as usize)? else {
                return Ok(0);
            };
            let v2 = match self.buf.u32(100, true) {
                Some(o) => self.root(o as usize)?.unwrap_or(0),
                None => 0,
            };
            return self.add(v1, v2);
        }
        Ok(self.root(0)?.unwrap_or(0))
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

    /// `TiffIFD::new_root`: the visits of the chain at `r`, `None` when `r` holds no byte-order mark.
    fn root(&mut self, r: usize) -> Result<Option<u64>, Exceeded> {
        let big = match self.buf.u16(r, false) {
            Some(0x4949) => false,
            Some(0x4d4d) => true,
            _ => return Ok(None),
        };
        let Some(mut next) = r.checked_add(4).and_then(|p| self.buf.u32(p, big)) else {
            return Ok(Some(0));
        };
        let mut total = 0;
        for _ in 0..MAX_CHAIN {
            let ifd = self.ifd(r, next as usize, 0, 0, big)?;
            total = self.add(total, ifd.visits)?;
            match ifd.next {
                Some(n) if ifd.parsed && n != 0 => next = n,
                _ => break,
            }
        }
        Ok(Some(total))
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
        let (mut own_img_proc, mut sub_img_proc) = (None, None);
        for i in 0..num as usize {
            let Some(eo) = o.checked_add(2 + 12 * i) else {
                break;
            };
            let Some(tag) = at(eo).and_then(|p| self.buf.u16(p, big)) else {
                break;
            };
            let special = SUB_IFD_TAGS.contains(&tag) || tag == MAKERNOTE || tag == OLYMPUS_IMG_PROC;
            if !special {
                continue;
            }
            let Some(entry) = self.entry(s, eo, b, big) else {
                break;
            };
            if tag == OLYMPUS_IMG_PROC {
                // The map of entries keeps the last one.
                own_img_proc = self.value(&entry, 0);
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
                if child.parsed && sub_img_proc.is_none() {
                    sub_img_proc = child.img_proc;
                }
            }
        }
        out.img_proc = own_img_proc.or(sub_img_proc);
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
            let ioff = main.img_proc.filter(|&v| v != 0);
            if main.parsed && olympus {
                if let Some(ioff) = ioff {
                    let Some(is) = d.checked_add(ioff as usize) else {
                        return Ok(main);
                    };
                    let ip = self.ifd(is, 0, ioff as usize, depth, big)?;
                    main.visits = self.add(main.visits, ip.visits)?;
                    main.parsed = ip.parsed;
                    main.img_proc = main.img_proc.or(ip.img_proc);
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
}
