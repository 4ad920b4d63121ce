#!/usr/bin/env python3
"""Write the small committed seeds of the fuzz targets into fuzz/seeds/<target>/.

Run once when a format changes: ``python3 fuzz/make_seeds.py [--mosaicd target/release/mosaicd]``.
With ``--mosaicd`` the recording seeds (``mcap_source``, ``raw_frame_message``) are made by mosaicd
itself (``mosaicd record`` of two 8x8 raw frames); the other seeds are written here from the formats'
definitions (PGM, PNG, npy, the sidecar, OpenCV YAML, V4L2 packings).
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
SEEDS = os.path.join(HERE, "seeds")


def put(target: str, name: str, data: bytes) -> None:
    d = os.path.join(SEEDS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def png(w: int, h: int, colour: int, depth: int, rows: list[bytes], text: str | None = None) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, 0))
    if text is not None:
        out += chunk(b"tEXt", b"mosaicd-mosaic\x00" + text.encode())
    out += chunk(b"IDAT", zlib.compress(b"".join(b"\x00" + r for r in rows)))
    return out + chunk(b"IEND", b"")


def npy(values: list[float]) -> bytes:
    header = "{'descr': '<f4', 'fortran_order': False, 'shape': (%d,), }" % len(values)
    header += " " * ((64 - (10 + len(header) + 1) % 64) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + struct.pack(f"<{len(values)}f", *values)


def dng(w: int, h: int, px: list[int], cfa: bytes, black: int, white: int, active: list[int]) -> bytes:
    """A minimal uncompressed 16-bit little-endian DNG with one IFD (as tests/raw_dng.rs writes)."""
    shorts = lambda v: b"".join(struct.pack("<H", x) for x in v)
    longs = lambda v: b"".join(struct.pack("<I", x) for x in v)
    entries = [
        [254, 4, 1, longs([0])], [256, 4, 1, longs([w])], [257, 4, 1, longs([h])], [258, 3, 1, shorts([16])],
        [259, 3, 1, shorts([1])], [262, 3, 1, shorts([32803])], [271, 2, 6, b"Synth\0"], [272, 2, 7, b"Mosaic\0"],
        [273, 4, 1, b""], [277, 3, 1, shorts([1])], [278, 4, 1, longs([h])], [279, 4, 1, longs([w * h * 2])],
        [33421, 3, 2, shorts([2, 2])], [33422, 1, 4, cfa], [50706, 1, 4, bytes([1, 4, 0, 0])],
        [50714, 3, 1, shorts([black])], [50717, 3, 1, shorts([white])],
        [50728, 5, 3, longs([1, 2, 1, 1, 1, 4])], [50829, 4, 4, longs(active)],
    ]
    extra_start = 8 + 2 + 12 * len(entries) + 4
    extra, offsets = b"", []
    for e in entries:
        if len(e[3]) > 4:
            offsets.append(extra_start + len(extra))
            extra += e[3] + (b"\0" if len(e[3]) % 2 else b"")
        else:
            offsets.append(None)
    entries[8][3] = longs([extra_start + len(extra)])
    out = b"II*\0" + longs([8]) + struct.pack("<H", len(entries))
    for e, off in zip(entries, offsets):
        out += struct.pack("<HHI", e[0], e[1], e[2]) + (longs([off]) if off is not None else e[3].ljust(4, b"\0"))
    return out + longs([0]) + extra + shorts(px)


def ifd_loop(big: bool, at: int, n: int) -> bytes:
    """A TIFF IFD (placed at offset ``at`` of its slice) whose SubIFDs entry lists itself ``n`` times:
    rawloader 0.37 follows each pointer to depth 10, n^10 visits."""
    e = ">" if big else "<"
    data = at + 2 + 12 + 4
    return struct.pack(e + "HHHII", 1, 0x014A, 4, n, data) + struct.pack(e + "I", 0) + struct.pack(e + f"{n}I", *[at] * n)


def sony_crypt(block: bytes, key: int) -> bytes:
    """rawloader's ``ArwDecoder::sony_decrypt`` (an XOR with a key stream: it also encrypts)."""
    m32 = 0xFFFFFFFF
    pad = [0] * 128
    for p in range(4):
        key = (key * 48828125 + 1) & m32
        pad[p] = key
    pad[3] = ((pad[3] << 1) | ((pad[0] ^ pad[2]) >> 31)) & m32
    for p in range(4, 127):
        pad[p] = (((pad[p - 4] ^ pad[p - 2]) << 1) | ((pad[p - 3] ^ pad[p - 1]) >> 31)) & m32
    for p in range(127):
        pad[p] = int.from_bytes(pad[p].to_bytes(4, "little"), "big")
    block = block + b"\0" * (-len(block) % 4)
    out = b""
    for i in range(len(block) // 4):
        p = i + 127
        pad[p & 127] = pad[(p + 1) & 127] ^ pad[(p + 65) & 127]
        out += struct.pack("<I", struct.unpack_from("<I", block, 4 * i)[0] ^ pad[p & 127])
    return out


def hostile_camera_raw() -> dict[str, bytes]:
    """Camera raw files whose structure rawloader 0.37 cannot bound, one per path it walks outside
    the file's own TIFF tree (tested by src/raw/load/tiff_walk.rs; docs/fuzzing.md)."""
    out = {}
    # MRW: a TTW block whose TIFF (big-endian, IFD at 8 of the block) lists itself 8 times.
    tiff = b"MM\0*" + struct.pack(">I", 8) + ifd_loop(True, 8, 8)
    out["mrw-tiff-explosion.bin"] = b"\0MRM" + struct.pack(">I", 8 + len(tiff)) + b"\0TTW" + struct.pack(">I", len(tiff)) + tiff
    # MRW: a block length of 2^32 - 8: rawloader steps by (len + 8) mod 2^32 = 0, forever (release).
    out["mrw-length-wrap.bin"] = b"\0MRM" + struct.pack(">I", 100) + b"\0WBG" + struct.pack(">II", 0xFFFFFFF8, 0) + bytes(32)
    # X3F: one IMA2 directory entry, camera info (type 2, format 0x12) holding "Exif" and a TIFF
    # root whose IFD lists itself 8 times; the directory's offset in the last 4 bytes.
    img = 16
    root = img + 28 + 12
    body = b"FOVb" + bytes(img - 4)
    body += struct.pack("<IIIIIII", 0, 0, 2, 0x12, 0, 0, 0) + b"\0" * 6 + b"Exif" + b"\0\0"
    assert len(body) == root
    body += b"II*\0" + struct.pack("<I", 8) + ifd_loop(False, 8, 8)
    d = len(body)
    body += b"SECd" + struct.pack("<II", 0x00020000, 1) + struct.pack("<II", img, 28) + b"IMA2"
    out["x3f-tiff-explosion.bin"] = body + struct.pack("<I", d)

    def sony(private: bytes, tail: bytes = b"") -> bytes:
        """A little-endian Sony DSLR-A700 TIFF with a 16x2 16-bit uncompressed image (so that
        rawloader decodes it and then reads the white balance), its DNGPrivateArea pointing at
        ``private`` (placed at the returned offset), then ``tail``."""
        n = 9
        first = 8 + 2 + 12 * n + 4
        make, model = first, first + 6
        pix = model + 10
        prv = pix + 64
        entries = [
            (0x0100, 4, 1, 16), (0x0101, 4, 1, 2), (0x0102, 3, 1, 16), (0x0103, 3, 1, 1),
            (0x010F, 2, 5, make), (0x0110, 2, 10, model), (0x0111, 4, 1, pix), (0x0117, 4, 1, 64),
            (0xC634, 4, 1, prv),
        ]
        out = b"II*\0" + struct.pack("<IH", 8, n) + b"".join(struct.pack("<HHII", *e) for e in entries) + struct.pack("<I", 0)
        out += b"SONY\0\0" + b"DSLR-A700\0" + bytes(64)
        assert len(out) == prv
        return out + private(prv) + tail

    # Sony: the private IFD itself lists itself 8 times.
    out["arw-private-explosion.bin"] = sony(lambda at: ifd_loop(False, at, 8))
    # Sony: the private IFD names an encrypted block (offset, length, key) whose decrypted IFD
    # (data pointers relative to the block) lists itself 8 times.
    key = 0x1234_5678

    def private(at: int) -> bytes:
        block_at = at + 2 + 12 * 3 + 4
        plain = struct.pack("<HHHII", 1, 0x014A, 4, 8, block_at + 18) + struct.pack("<I", 0) + struct.pack("<8I", *[0] * 8)
        ifd = struct.pack("<H", 3) + b"".join(
            struct.pack("<HHII", t, 4, 1, v) for t, v in ((0x7200, block_at), (0x7201, len(plain)), (0x7221, key))
        )
        return ifd + struct.pack("<I", 0) + sony_crypt(plain, key)

    out["arw-sr2-explosion.bin"] = sony(private)
    # Canon CIFF: the root heap's directory has 8 sub-heap entries (type 0x2800), each the root
    # heap itself; rawloader follows them to depth 10, 8^9 + ... heaps.
    start, n = 14, 8
    size = 2 + 10 * n + 4
    heap = struct.pack("<H", n) + struct.pack("<HII", 0x2800 | 0x000A, size, 0) * n + struct.pack("<I", 0)
    out["ciff-heap-explosion.bin"] = b"II" + struct.pack("<I", start) + b"HEAPCCDR" + heap
    out["srf-huge-dimensions.bin"] = srf(1_000_000, 1_000_000, 200_960)
    return out


def srf(w: int, h: int, size: int) -> bytes:
    """A little-endian Sony DSC-F828 TIFF with no StripOffsets (rawloader 0.37's SRF path) declaring
    a ``w`` x ``h`` image, zero-filled to ``size`` bytes. rawloader reads a key at byte 200896
    (so the file must reach it) and then reserves ``w * h * 2`` bytes for the samples it would
    read from byte 862144 (src/raw/load/tiff_walk.rs, ``sony_srf_size``)."""
    n = 4
    make = 8 + 2 + 12 * n + 4
    model = make + 6
    entries = [(0x0100, 4, 1, w), (0x0101, 4, 1, h), (0x010F, 2, 5, make), (0x0110, 2, 9, model)]
    out = b"II*\0" + struct.pack("<IH", 8, n) + b"".join(struct.pack("<HHII", *e) for e in entries) + struct.pack("<I", 0)
    out += b"SONY\0\0" + b"DSC-F828\0"
    assert len(out) <= size
    return out + bytes(size - len(out))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--mosaicd", help="the mosaicd binary, to make the recording seeds")
    a = p.parse_args()
    px8 = bytes((x * 29 + y * 7) & 0xFF for y in range(8) for x in range(8))
    # pgm_png
    put("pgm_png", "grey8.pgm", b"P5\n8 8\n255\n" + px8)
    put("pgm_png", "grey12.pgm", b"P5\n# 12-bit\n4 4\n4095\n" + b"".join(struct.pack(">H", v * 255) for v in range(16)))
    put("pgm_png", "grey8.png", png(8, 8, 0, 8, [px8[y * 8 : y * 8 + 8] for y in range(8)]))
    rows16 = [b"".join(struct.pack(">H", (x + y) * 1000) for x in range(4)) for y in range(4)]
    put("pgm_png", "grey16_described.png", png(4, 4, 0, 16, rows16, "cfa=GRBG bit_depth=14 black=600,600,600,600 white=15520"))
    put("pgm_png", "rgb8.png", png(4, 2, 2, 8, [bytes(range(12)), bytes(range(12, 24))]))
    # headerless_sidecar: sidecar text, NUL, the file's bytes
    put("headerless_sidecar", "u8.bin", b'width = 4\nheight = 2\nbit_depth = 8\ncfa = "RGGB"\nblack = 12\n\x00' + bytes(range(8)))
    put(
        "headerless_sidecar",
        "u16_big_stride.bin",
        b'width = 2\nheight = 2\nbit_depth = 12\ncfa = "GBRG"\nblack = [1, 2, 3, 4]\nwhite = 4000\n'
        b'endian = "big"\nstride_bytes = 6\ncontainer = "u16"\n\x00'
        + b"\x00\x01\x0f\xa0\xee\xee\x00\x02\x00\x03\xee\xee",
    )
    # model_files: selector byte, then the file
    blocks = 1  # a 16x16 window: one block of 4 cells x 9 bins
    weights = [((i * 37) % 11 - 5) / 10 for i in range(blocks * 36)]
    model = {
        "format": "mosaicd-hog-svm", "version": 1, "win_width": 16, "win_height": 16, "cell_size": 8,
        "block_size": 16, "block_stride": 8, "nbins": 9, "gamma_correction": True, "l2hys_threshold": 0.2,
        "domain": "mosaic", "mosaic_taps": "same-site", "mosaic_tone": "linear", "bias": -0.5, "weights": weights,
    }
    put("model_files", "model.json", b"\x00" + json.dumps(model).encode())
    put("model_files", "vector.npy", b"\x01" + npy(weights + [0.25]))
    yml = "%YAML:1.0\n---\nhog:\n   winSize: [ 64, 128 ]\n   blockSize: [ 16, 16 ]\n   nbins: 9\n   gammaCorrection: 1\n   L2HysThreshold: 0.2\n   SVMDetector: [ 0.5, -1.5, 2e-3 ]\n"
    put("model_files", "hog.yml", b"\x02" + yml.encode())
    put("model_files", "numbers.txt", b"\x03" + b"0.1 0.2, -3e-2\n4\n")
    # v4l2_unpack: FourCC index, width, height, bytesperline (u32 LE each), buffer
    def v4l2(index: int, w: int, h: int, bpl: int, buf: bytes) -> bytes:
        return bytes([index]) + struct.pack("<III", w, h, bpl) + buf
    put("v4l2_unpack", "u8.bin", v4l2(3, 4, 2, 5, bytes(range(10))))
    put("v4l2_unpack", "u16le.bin", v4l2(7, 3, 2, 8, bytes([1, 0, 2, 0, 3, 0, 0, 0] * 2)))
    put("v4l2_unpack", "mipi10.bin", v4l2(23, 6, 2, 10, bytes(range(20))))
    put("v4l2_unpack", "mipi12.bin", v4l2(24 + 3, 5, 2, 9, bytes(range(18))))
    # camera_raw: a little-endian TIFF header with an empty IFD, and a Kodak-looking one
    put("camera_raw", "tiff_le.bin", b"II*\x00\x08\x00\x00\x00\x00\x00\x00\x00\x00\x00")
    put("camera_raw", "tiff_be.bin", b"MM\x00*\x00\x00\x00\x08\x00\x00\x00\x00\x00\x00")
    put("camera_raw", "synth.dng", dng(10, 8, [64 + (i * 37) % 3900 for i in range(80)], bytes([1, 0, 2, 1]), 64, 4000, [1, 1, 7, 9]))
    for name, data in hostile_camera_raw().items():
        put("camera_raw", name, data)
    if a.mosaicd:
        with tempfile.TemporaryDirectory() as d:
            for i in range(2):
                with open(os.path.join(d, f"f{i}.raw"), "wb") as f:
                    f.write(bytes((v + 40 * i) & 0xFF for v in px8))
            with open(os.path.join(d, "mosaicd-raw.toml"), "w") as f:
                f.write('width = 8\nheight = 8\nbit_depth = 8\ncfa = "RGGB"\n')
            out = os.path.join(d, "seed.mcap")
            subprocess.run([a.mosaicd, "record", d, "-o", out], check=True, stdout=subprocess.DEVNULL)
            data = open(out, "rb").read()
            put("mcap_source", "two_frames.mcap", data)
            sys.path.insert(0, os.path.join(os.path.dirname(HERE), "clients", "python"))
            from read_recording import RAW_FRAME_ENCODING, messages

            for k, (ch, _, m) in enumerate(messages(out)):
                if ch.message_encoding == RAW_FRAME_ENCODING:
                    put("raw_frame_message", f"frame{k}.bin", m.data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
