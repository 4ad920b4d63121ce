#!/usr/bin/env python3
"""Read a mosaicd MCAP recording in Python: raw Bayer frames at full bit depth, and the JSON channels.

A recording (``mosaicd record``, or the daemon with ``[record] enabled = true``) holds per camera
``/<camera>/raw`` (``mosaicd.RawFrame``: the frame, lossless), a Foxglove preview, detections,
keypoints, SIFT features and stats (docs/recording.md). Foxglove Studio shows the JSON channels;
this module gives Python the raw frames as numpy arrays with their metadata, using the ``mcap``
package from PyPI::

    from read_recording import raw_frames
    for header, mosaic in raw_frames("recordings/synthetic_pan.mcap"):
        print(header["sequence"], header["cfa"], header["bit_depth"], mosaic.shape, mosaic.dtype)

``header`` is the frame's JSON header (``sequence``, ``timestamp_ns``, ``width``, ``height``,
``cfa``, ``bit_depth``, ``black`` per 2x2 tile position ``(y & 1) * 2 + (x & 1)``, ``white``,
``wb_gains``, ...); ``mosaic`` is ``height x width``, ``uint8`` or ``uint16`` (values as stored,
LSB-aligned). Records are checked against their CRCs, and sizes against the daemon's default
frame-size limit (:data:`MAX_FRAME_PIXELS`, :data:`MAX_RECORD_BYTES`) before anything is allocated. A truncated recording (a crash mid-write)
yields every complete message before the cut and then stops with :class:`TruncatedRecording`,
which says how many were read; a file that is not MCAP, a record whose CRC does not match and a
corrupt frame message raise :class:`ValueError` naming what is wrong.

As a script: one JSON line per raw frame (its header and pixel statistics), ``--topic T`` prints
the JSON messages of a channel instead, ``--npy DIR`` also writes each frame as
``DIR/<sequence>.npy``::

    python3 clients/python/read_recording.py recordings/synthetic_pan.mcap
    python3 clients/python/read_recording.py out/demo.mcap --topic /demo/detections

Exit status: 0 after printing at least one message; 1 when the recording holds no raw frame (or,
with ``--topic``, no message on that topic): the channels it does hold are listed on stderr (a
results-only recording, ``mosaicd replay --out-frames none``, has no raw channel); 2 for a file
that is not a readable recording; 3 for a recording cut short.
"""

from __future__ import annotations

import argparse
import json
import os
import struct
import sys
from typing import Any, Iterator

import numpy as np
from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import CRCValidationError, StreamReader, breakup_chunk

#: Message encoding of the raw-frame channel.
RAW_FRAME_ENCODING = "mosaicd.rawframe.v1"
_MAGIC = b"MRF1"
#: The daemon's default frame-size limit (``limits.max_frame_pixels``; docs/recording.md): pixels in
#: all, and per side.
MAX_FRAME_PIXELS = 1 << 26
MAX_SIDE = 16384
#: Largest record or uncompressed chunk read, bytes, derived from the frame-size limit as the daemon
#: does: a recorder's largest chunk-size target (64 MiB) plus one 16-bit frame and its header. A chunk
#: claiming more (a few KB of zstd can claim gigabytes) is refused before it is decompressed.
MAX_RECORD_BYTES = (64 << 20) + 2 * MAX_FRAME_PIXELS + (64 << 10)


class TruncatedRecording(Exception):
    """The file ends inside a record: everything before the cut was read."""

    def __init__(self, path: str, messages: int, why: str):
        super().__init__(f"{path}: the recording is cut short after {messages} complete messages ({why})")
        self.messages = messages


def decode_raw_frame(data: bytes, where: str = "message") -> tuple[dict, np.ndarray]:
    """One ``mosaicd.RawFrame`` v1 message: its JSON header and the pixels (height x width)."""
    if len(data) < 8 or data[:4] != _MAGIC:
        raise ValueError(f"{where}: not a mosaicd.RawFrame v1 message (magic {data[:4]!r})")
    (n,) = struct.unpack_from("<I", data, 4)
    if 8 + n > len(data):
        raise ValueError(f"{where}: header length {n} runs past the message ({len(data)} bytes)")
    try:
        header = json.loads(data[8 : 8 + n])
        w, h, bits = int(header["width"]), int(header["height"]), int(header["container_bits"])
    except (ValueError, KeyError, TypeError) as e:
        raise ValueError(f"{where}: bad frame header: {e}") from None
    if bits not in (8, 16):
        raise ValueError(f"{where}: container_bits {bits} is neither 8 nor 16")
    if not (0 <= w <= MAX_SIDE and 0 <= h <= MAX_SIDE and w * h <= MAX_FRAME_PIXELS):
        raise ValueError(
            f"{where}: a {w}x{h} frame exceeds the frame-size limit ({MAX_SIDE} per side, {MAX_FRAME_PIXELS} pixels)"
        )
    dtype = np.dtype(np.uint8) if bits == 8 else np.dtype("<u2")
    pixels = data[8 + n :]
    if len(pixels) != w * h * dtype.itemsize:
        raise ValueError(
            f"{where}: {len(pixels)} pixel bytes for a {w}x{h} frame of {bits}-bit samples "
            f"(expected {w * h * dtype.itemsize})"
        )
    mosaic = np.frombuffer(pixels, dtype=dtype).reshape(h, w)
    return header, mosaic.astype(np.uint16) if bits == 16 else mosaic


class _WholeReads:
    """The recording file as the MCAP stream reader reads it: past the 8-byte magic, a read that the
    end of the file cuts short raises :class:`EndOfFile`, as an empty read does. (The reader unpacks
    what it got, so a file cut inside a record's opcode and length, or inside a bare Message's fixed
    fields, failed with ``struct.error`` and was reported as unreadable instead of cut short.) A
    regular file returns fewer bytes than asked only at its end. A file shorter than the magic is
    left to the reader's magic check: it is not known to be a recording."""

    def __init__(self, f):
        self._f = f

    def read(self, n: int = -1) -> bytes:
        start = self._f.tell()
        data = self._f.read(n)
        if start >= 8 and n > 0 and len(data) < n:
            raise EndOfFile(f"the file ends after {len(data)} of the {n} bytes of a field or record")
        return data


def messages(path: str, channels: dict[int, Channel] | None = None) -> Iterator[tuple[Channel, Schema | None, Message]]:
    """Every message of the recording in file order, with its channel and schema; read as a stream
    with CRC checks, so a recording without its summary (cut short) is read up to the cut.
    ``channels``, when given, is filled with every channel declared so far (id → channel)."""
    if channels is None:
        channels = {}
    schemas: dict[int, Schema] = {}
    count = 0
    def records(f):
        reader = StreamReader(
            _WholeReads(f), skip_magic=False, emit_chunks=True, validate_crcs=True, record_size_limit=MAX_RECORD_BYTES
        )
        for r in reader.records:
            if isinstance(r, Chunk):
                if r.uncompressed_size > MAX_RECORD_BYTES:
                    raise ValueError(
                        f"{path}: a chunk claims {r.uncompressed_size} bytes uncompressed, more than the "
                        f"{MAX_RECORD_BYTES} bytes a chunk of frames within the frame-size limit takes"
                    )
                yield from breakup_chunk(r, validate_crc=True)
            else:
                yield r

    with open(path, "rb") as f:
        try:
            for r in records(f):
                if isinstance(r, Schema):
                    schemas[r.id] = r
                elif isinstance(r, Channel):
                    channels[r.id] = r
                elif isinstance(r, Message):
                    ch = channels.get(r.channel_id)
                    if ch is None:
                        raise ValueError(f"{path}: message {count} on channel {r.channel_id}, which was never declared")
                    count += 1
                    yield ch, schemas.get(ch.schema_id), r
        except (EndOfFile, EOFError) as e:
            raise TruncatedRecording(path, count, f"{type(e).__name__}: {e}") from None
        except (McapError, CRCValidationError, struct.error) as e:
            raise ValueError(f"{path}: not a readable MCAP recording after {count} messages: {type(e).__name__}: {e}") from None


def raw_frames(
    path: str, topic: str | None = None, channels: dict[int, Channel] | None = None
) -> Iterator[tuple[dict, np.ndarray]]:
    """The raw frames (``mosaicd.rawframe.v1`` channels, or only ``topic``) as (header, mosaic);
    ``channels`` as for :func:`messages`."""
    for ch, _, m in messages(path, channels):
        if ch.message_encoding == RAW_FRAME_ENCODING and (topic is None or ch.topic == topic):
            yield decode_raw_frame(m.data, f"{path}: {ch.topic} message {m.sequence}")


def json_messages(path: str, topic: str, channels: dict[int, Channel] | None = None) -> Iterator[tuple[int, Any]]:
    """(log time ns, decoded JSON) of each message on a JSON channel; ``channels`` as for
    :func:`messages`."""
    for ch, _, m in messages(path, channels):
        if ch.topic == topic:
            if ch.message_encoding != "json":
                raise ValueError(f"{path}: {topic} is {ch.message_encoding!r}, not JSON")
            yield m.log_time, json.loads(m.data)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("recording")
    p.add_argument("--topic", help="print this JSON channel's messages instead of the raw frames")
    p.add_argument("--npy", help="also write each raw frame as DIR/<sequence>.npy")
    a = p.parse_args(argv)
    channels: dict[int, Channel] = {}
    printed = 0
    try:
        if a.topic:
            for t, v in json_messages(a.recording, a.topic, channels):
                print(json.dumps({"log_time": t, "message": v}))
                printed += 1
        else:
            if a.npy:
                os.makedirs(a.npy, exist_ok=True)
            for header, mosaic in raw_frames(a.recording, channels=channels):
                print(json.dumps({**header, "min": int(mosaic.min()), "max": int(mosaic.max()), "mean": float(mosaic.mean())}))
                printed += 1
                if a.npy:
                    np.save(os.path.join(a.npy, f"{header['sequence']}.npy"), mosaic)
    except TruncatedRecording as e:
        print(f"read_recording: {e}", file=sys.stderr)
        return 3
    except (OSError, ValueError) as e:
        print(f"read_recording: {e}", file=sys.stderr)
        return 2
    if printed == 0:
        what = f"no message on {a.topic}" if a.topic else f"no raw frame (no message on a {RAW_FRAME_ENCODING} channel)"
        held = ", ".join(f"{c.topic} ({c.message_encoding})" for c in sorted(channels.values(), key=lambda c: c.topic))
        print(f"read_recording: {a.recording} holds {what}; its channels: {held or 'none'}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
