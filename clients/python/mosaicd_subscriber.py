#!/usr/bin/env python3
"""A mosaicd subscriber in Python: the daemon's iceoryx2 messages as ctypes structures.

mosaicd publishes fixed-layout ``#[repr(C)]`` messages over iceoryx2 shared memory
(``src/wire/messages.rs``). This module declares the same layouts with :mod:`ctypes`, under
the same iceoryx2 type names, so a Python process reads them without copies or a serialisation
step, and a layout that does not match (another message version) is refused by iceoryx2 when the
service is opened instead of being misread. It needs the ``iceoryx2`` wheel of the same version
as the daemon's crate (0.10; ``pip install iceoryx2==0.10.0``).

Run as a script it is the Python twin of ``mosaicd listen``: it prints what a daemon publishes as
JSON lines, one object per sample with a ``"topic"`` key, in the same form::

    python3 clients/python/mosaicd_subscriber.py --camera front --until-final --keypoints

Used as a module::

    from mosaicd_subscriber import DetectionsMsg, create_node, open_service

    node = create_node("my-subscriber")       # under the daemon's root, DEFAULT_ROOT
    sub = open_service(node, "mosaicd", "front", "detections", DetectionsMsg, 64)
    sub = sub.subscriber_builder().buffer_size(64).create()
    sample = sub.receive()          # None when nothing is waiting
    if sample is not None:
        msg = sample.payload().contents
        boxes = msg.boxes[: min(msg.box_count, MAX_BOXES)]

Descriptors (``compute.keypoint_descriptors = true``) come on their own service as
:class:`DescriptorsMsg`, in the order of the keypoints message with the same ``index``:
``bytes(msg.descriptors[i])``, or ``numpy.frombuffer(msg.descriptors, numpy.uint8).reshape(MAX_KEYPOINTS,
128)[:msg.descriptor_count]`` for all of them.
``--layout`` prints each structure's size, alignment and field offsets (the Rust tests compare
them with the daemon's).
"""

from __future__ import annotations

import argparse
import base64
import ctypes
import json
import os
import stat
import sys
import time
from typing import Any

import iceoryx2 as iox2

#: Capacity of ``DetectionsMsg.boxes`` (``MAX_BOXES`` in the daemon).
MAX_BOXES = 64
#: Capacity of ``KeypointsMsg.keypoints`` (``MAX_KEYPOINTS``).
MAX_KEYPOINTS = 512
#: Bytes of one SIFT descriptor (``DESCRIPTOR_BYTES``).
DESCRIPTOR_BYTES = 128
#: ``DetectionsMsg.sensor_sequence`` when the source has none.
NO_SENSOR_SEQUENCE = 2**64 - 1

#: ``--root`` / ``publish.root`` value that resolves the root as the daemon does (:func:`resolve_root`).
AUTO_ROOT = "auto"
#: Default root: the daemon's default, ``"auto"``.
DEFAULT_ROOT = AUTO_ROOT
#: Longest root iceoryx2 accepts, in bytes (``MAX_ROOT_LEN`` in src/publish/service.rs).
MAX_ROOT_LEN = 255
#: Start of the daemon's iceoryx2 file and segment names (``SHM_PREFIX``; :func:`segment_prefix`).
SHM_PREFIX = "mosaicd_"

# The daemon's service settings (src/publish/service.rs); a subscriber opens with the same ones.
_HISTORY = 1
_MAX_PUBLISHERS = 1  # only the daemon publishes
_MAX_SUBSCRIBERS = 16


class BoxMsg(ctypes.Structure):
    """One box: full-frame pixel coordinates and the SVM score."""

    _fields_ = [
        ("x", ctypes.c_float),
        ("y", ctypes.c_float),
        ("width", ctypes.c_float),
        ("height", ctypes.c_float),
        ("score", ctypes.c_float),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.BoxMsg.v1"


class DetectionsMsg(ctypes.Structure):
    """Detections of one frame (``<prefix>/<camera>/detections``)."""

    _fields_ = [
        ("index", ctypes.c_uint64),
        ("sequence", ctypes.c_uint64),
        ("sensor_sequence", ctypes.c_uint64),
        ("capture_timestamp_ns", ctypes.c_uint64),
        ("publish_timestamp_ns", ctypes.c_uint64),
        ("latency_ns", ctypes.c_uint64),
        ("frame_width", ctypes.c_uint32),
        ("frame_height", ctypes.c_uint32),
        ("box_count", ctypes.c_uint32),
        ("overflow", ctypes.c_uint32),
        ("mean_magnitude", ctypes.c_float),
        ("reserved", ctypes.c_uint32),
        ("boxes", BoxMsg * MAX_BOXES),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.DetectionsMsg.v1"


class KeypointMsg(ctypes.Structure):
    """One mosaic SIFT keypoint: full-resolution mosaic pixel coordinates, scale, orientation."""

    _fields_ = [
        ("x", ctypes.c_float),
        ("y", ctypes.c_float),
        ("size", ctypes.c_float),
        ("angle", ctypes.c_float),
        ("response", ctypes.c_float),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.KeypointMsg.v1"


class KeypointsMsg(ctypes.Structure):
    """Mosaic SIFT keypoints of one frame, strongest first (``<prefix>/<camera>/keypoints``)."""

    _fields_ = [
        ("index", ctypes.c_uint64),
        ("sequence", ctypes.c_uint64),
        ("capture_timestamp_ns", ctypes.c_uint64),
        ("publish_timestamp_ns", ctypes.c_uint64),
        ("frame_width", ctypes.c_uint32),
        ("frame_height", ctypes.c_uint32),
        ("keypoint_count", ctypes.c_uint32),
        ("overflow", ctypes.c_uint32),
        ("keypoints", KeypointMsg * MAX_KEYPOINTS),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.KeypointsMsg.v1"


class DescriptorsMsg(ctypes.Structure):
    """SIFT descriptors of one frame's keypoints (``<prefix>/<camera>/descriptors``), in the order
    of the keypoints message with the same ``index``, published just before it."""

    _fields_ = [
        ("index", ctypes.c_uint64),
        ("sequence", ctypes.c_uint64),
        ("capture_timestamp_ns", ctypes.c_uint64),
        ("descriptor_count", ctypes.c_uint32),
        ("overflow", ctypes.c_uint32),
        ("descriptors", (ctypes.c_uint8 * DESCRIPTOR_BYTES) * MAX_KEYPOINTS),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.DescriptorsMsg.v1"


class StatsMsg(ctypes.Structure):
    """Counters of one camera's pipeline (``<prefix>/<camera>/stats``)."""

    _fields_ = [
        ("timestamp_ns", ctypes.c_uint64),
        ("captured", ctypes.c_uint64),
        ("processed", ctypes.c_uint64),
        ("dropped_queue_full", ctypes.c_uint64),
        ("dropped_driver", ctypes.c_uint64),
        ("failed_source", ctypes.c_uint64),
        ("failed_compute", ctypes.c_uint64),
        ("failed_sink", ctypes.c_uint64),
        ("sink_frames_lost", ctypes.c_uint64),
        ("detections", ctypes.c_uint64),
        ("box_overflow", ctypes.c_uint64),
        ("fps", ctypes.c_float),
        ("latency_p50_us", ctypes.c_float),
        ("latency_p99_us", ctypes.c_float),
        ("is_final", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.StatsMsg.v3"


class GradientsHeader(ctypes.Structure):
    """User header of a gradients sample; the payload is ``u8`` bytes: ``width * height``
    little-endian ``u16`` magnitudes, then ``width * height`` orientation bins."""

    _fields_ = [
        ("index", ctypes.c_uint64),
        ("capture_timestamp_ns", ctypes.c_uint64),
        ("width", ctypes.c_uint32),
        ("height", ctypes.c_uint32),
        ("decimation", ctypes.c_uint32),
        ("orientation_bins", ctypes.c_uint32),
        ("mag_shift", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "mosaicd.GradientsHeader.v2"


#: Every message structure, for ``--layout``.
STRUCTS = [BoxMsg, DetectionsMsg, KeypointMsg, KeypointsMsg, DescriptorsMsg, StatsMsg, GradientsHeader]


def service_name(prefix: str, camera: str, topic: str) -> str:
    """``<prefix>/<camera>/<topic>``, as the daemon names its services."""
    return f"{prefix}/{camera}/{topic}"


def _with_daemon_settings(builder: Any, buffer: int) -> Any:
    return (
        builder.enable_safe_overflow(True)
        .subscriber_max_buffer_size(buffer)
        .history_size(_HISTORY)
        .max_publishers(_MAX_PUBLISHERS)
        .max_subscribers(_MAX_SUBSCRIBERS)
    )


def _absolute_dir(value: str | None, first_entry: bool = False) -> str | None:
    if value is None:
        return None
    if first_entry:
        value = value.split(":", 1)[0]
    return value if os.path.isabs(value) else None


def _dir_owned_by(path: str, uid: int) -> bool:
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISDIR(st.st_mode) and st.st_uid == uid


def resolve_root(root: str = AUTO_ROOT, uid: int | None = None, env: dict[str, str] | None = None,
                 system_dir: str = "/run/mosaicd", tmp_dir: str = "/tmp") -> str:
    """The daemon's iceoryx2 root: ``root`` itself unless it is ``"auto"``, which resolves as the
    daemon's ``publish.root = "auto"`` does for the same user (``resolve_root`` in
    src/publish/service.rs; docs/daemon.md): ``$RUNTIME_DIRECTORY/iceoryx2`` (first ``:`` entry),
    else ``/run/mosaicd/iceoryx2`` for root or the owner of ``/run/mosaicd``, else
    ``$XDG_RUNTIME_DIR/mosaicd/iceoryx2`` when that is a directory of this user (and the path fits
    :data:`MAX_ROOT_LEN`), else ``/tmp/mosaicd-<uid>/iceoryx2``. Relative or empty variables count
    as unset. Creates nothing (:func:`create_node` prepares ``/tmp/mosaicd-<uid>``).
    """
    if root != AUTO_ROOT:
        return root
    uid = os.geteuid() if uid is None else uid
    env = os.environ if env is None else env
    rd = _absolute_dir(env.get("RUNTIME_DIRECTORY"), first_entry=True)
    if rd is not None:
        return os.path.join(rd, "iceoryx2")
    if uid == 0 or _dir_owned_by(system_dir, uid):
        return os.path.join(system_dir, "iceoryx2")
    xdg = _absolute_dir(env.get("XDG_RUNTIME_DIR"))
    if xdg is not None:
        cand = os.path.join(xdg, "mosaicd", "iceoryx2")
        if _dir_owned_by(xdg, uid) and len(os.fsencode(cand)) <= MAX_ROOT_LEN:
            return cand
    return os.path.join(tmp_dir, f"mosaicd-{uid}", "iceoryx2")


def segment_prefix(root: str) -> str:
    """The segment-name prefix of the nodes under ``root``: :data:`SHM_PREFIX`, the 32-bit FNV-1a hash
    of the root's bytes in hex, ``_`` (``segment_prefix`` in src/publish/service.rs)."""
    h = 0x811C9DC5
    for b in os.fsencode(root):
        h = ((h ^ b) * 0x01000193) & 0xFFFFFFFF
    return f"{SHM_PREFIX}{h:08x}_"


def _prepare_private_dir(path: str) -> None:
    """Create ``/tmp/mosaicd-<uid>`` 0700, refuse it when another user owns it (as the daemon)."""
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    st = os.lstat(path)
    if st.st_uid != os.geteuid():
        raise PermissionError(f"iceoryx2 root: {path} belongs to uid {st.st_uid}, not to this "
                              f"process's user uid {os.geteuid()}: another user created it; remove "
                              "it, or pass --root with a directory of this user")
    if not stat.S_ISDIR(st.st_mode):
        raise NotADirectoryError(f"iceoryx2 root {path}: exists and is not a directory")
    if stat.S_IMODE(st.st_mode) != 0o700:
        os.chmod(path, 0o700)


def create_node(name: str, root: str = DEFAULT_ROOT) -> Any:
    """An iceoryx2 node under the daemon's root (``publish.root``, ``"auto"`` resolved by
    :func:`resolve_root`), with the daemon's segment prefix.

    The config is built here, so no ``config/iceoryx2.toml`` of the working directory (or of the
    user) is read. Subscribers run as the daemon's user: iceoryx2 0.10 keeps a service's shared
    memory readable by its creator only (docs/daemon.md).
    """
    resolved = resolve_root(root)
    if root == AUTO_ROOT and os.path.dirname(resolved) == f"/tmp/mosaicd-{os.geteuid()}":
        _prepare_private_dir(os.path.dirname(resolved))
    cfg = iox2.config.default()
    cfg.global_cfg.root_path = iox2.Path.new(resolved)
    cfg.global_cfg.prefix = iox2.FileName.new(segment_prefix(resolved))
    return iox2.NodeBuilder.new().name(iox2.NodeName.new(name)).config(cfg).create(iox2.ServiceType.Ipc)


def open_service(node: Any, prefix: str, camera: str, topic: str, payload: type, buffer: int) -> Any:
    """Open (or create, if this process is first) a fixed-size service with the daemon's settings.

    ``buffer`` must not exceed the daemon's ``publish.subscriber_buffer``; iceoryx2 refuses an
    incompatible service (settings or message layout) with an error naming it.
    """
    name = iox2.ServiceName.new(service_name(prefix, camera, topic))
    builder = node.service_builder(name).publish_subscribe(payload)
    return _with_daemon_settings(builder, buffer).open_or_create()


def open_gradients_service(node: Any, prefix: str, camera: str, buffer: int) -> Any:
    """Open (or create) the gradients service (``u8`` slices with a :class:`GradientsHeader`)."""
    name = iox2.ServiceName.new(service_name(prefix, camera, "gradients"))
    builder = (
        node.service_builder(name)
        .publish_subscribe(iox2.Slice[ctypes.c_uint8])
        .user_header(GradientsHeader)
    )
    return _with_daemon_settings(builder, buffer).open_or_create()


def _fields(s: ctypes.Structure) -> dict:
    """Every field of a structure of scalars, by name."""
    return {name: getattr(s, name) for name, _ in s._fields_}


def detections_json(m: DetectionsMsg) -> dict:
    """A detections message as ``mosaicd listen`` prints it."""
    n = min(m.box_count, MAX_BOXES)
    return {
        "topic": "detections",
        "index": m.index,
        "sequence": m.sequence,
        "sensor_sequence": None if m.sensor_sequence == NO_SENSOR_SEQUENCE else m.sensor_sequence,
        "capture_timestamp_ns": m.capture_timestamp_ns,
        "publish_timestamp_ns": m.publish_timestamp_ns,
        "latency_ns": m.latency_ns,
        "frame_width": m.frame_width,
        "frame_height": m.frame_height,
        "box_count": m.box_count,
        "overflow": m.overflow,
        "mean_magnitude": m.mean_magnitude,
        "boxes": [_fields(b) for b in m.boxes[:n]],
    }


def descriptors(m: DescriptorsMsg) -> list[bytes]:
    """The valid descriptors (128 bytes each, in the keypoints' order)."""
    n = min(m.descriptor_count, MAX_KEYPOINTS)
    return [bytes(m.descriptors[i]) for i in range(n)]


def descriptors_json(m: DescriptorsMsg) -> dict:
    """A descriptors message as ``mosaicd listen --descriptors`` prints it (base64)."""
    return {
        "topic": "descriptors",
        "index": m.index,
        "sequence": m.sequence,
        "capture_timestamp_ns": m.capture_timestamp_ns,
        "descriptor_count": m.descriptor_count,
        "overflow": m.overflow,
        "descriptors": [base64.b64encode(x).decode("ascii") for x in descriptors(m)],
    }


def keypoints_json(m: KeypointsMsg) -> dict:
    """A keypoints message as ``mosaicd listen`` prints it."""
    n = min(m.keypoint_count, MAX_KEYPOINTS)
    return {
        "topic": "keypoints",
        "index": m.index,
        "sequence": m.sequence,
        "capture_timestamp_ns": m.capture_timestamp_ns,
        "publish_timestamp_ns": m.publish_timestamp_ns,
        "frame_width": m.frame_width,
        "frame_height": m.frame_height,
        "keypoint_count": m.keypoint_count,
        "overflow": m.overflow,
        "keypoints": [_fields(p) for p in m.keypoints[:n]],
    }


def stats_json(m: StatsMsg) -> dict:
    """A stats message as ``mosaicd listen`` prints it."""
    v = _fields(m)
    v["topic"] = "stats"
    return v


def _finite(v: Any) -> Any:
    """``v`` with every NaN or infinite float replaced by ``None`` (JSON has no NaN/Infinity)."""
    if isinstance(v, float):
        return v if v == v and v not in (float("inf"), float("-inf")) else None
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    return v


def json_line(v: Any) -> str:
    """One line of strict JSON: non-finite numbers (a stats field before any frame, a NaN score)
    become ``null``; bare ``NaN``/``Infinity`` are not JSON."""
    return json.dumps(_finite(v), allow_nan=False)


def layout() -> dict:
    """Size, alignment and field offsets of every message structure, by iceoryx2 type name."""
    return {
        s.type_name(): {
            "size": ctypes.sizeof(s),
            "align": ctypes.alignment(s),
            "fields": {name: getattr(s, name).offset for name, _ in s._fields_},
        }
        for s in STRUCTS
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--camera", help="camera name (as in the daemon's config)")
    p.add_argument("--prefix", default="mosaicd", help="service name prefix (publish.service_prefix)")
    p.add_argument("--root", default=DEFAULT_ROOT,
                   help="the daemon's iceoryx2 root (publish.root; default auto: as the daemon's auto)")
    p.add_argument("--buffer", type=int, default=64, help="samples buffered per service")
    p.add_argument("--count", type=int, help="exit after this many detections messages")
    p.add_argument("--until-final", action="store_true", help="exit after the daemon's final stats")
    p.add_argument("--timeout-s", type=float, help="exit with an error after this many seconds")
    p.add_argument("--keypoints", action="store_true", help="also print the keypoints service")
    p.add_argument("--descriptors", action="store_true", help="also print the descriptors service (base64)")
    p.add_argument("--gradients", action="store_true", help="also print the gradients service")
    p.add_argument("--layout", action="store_true", help="print the structures' sizes and field offsets, and exit")
    a = p.parse_args(argv)
    if a.layout:
        print(json.dumps(layout(), sort_keys=True))
        return 0
    if not a.camera:
        p.error("--camera is required")
    if a.buffer < 1:
        p.error("--buffer must be at least 1")

    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    node = create_node(f"mosaicd-py-listen-{os.getpid()}", a.root)

    def subscribe(topic: str, payload: type | None) -> Any:
        # iceoryx2 refuses a service whose settings or message layout differ from ours (another
        # daemon version, a smaller publish.subscriber_buffer): say which, in one line.
        try:
            if payload is None:
                svc = open_gradients_service(node, a.prefix, a.camera, a.buffer)
            else:
                svc = open_service(node, a.prefix, a.camera, topic, payload, a.buffer)
            return svc.subscriber_builder().buffer_size(a.buffer).create()
        except Exception as e:  # iceoryx2 raises its own exception types per builder
            name = service_name(a.prefix, a.camera, topic)
            raise SystemExit(
                f"mosaicd_subscriber: cannot subscribe to {name}: {type(e).__name__}: {e} "
                f"(a different message version, or --buffer {a.buffer} above the daemon's "
                "publish.subscriber_buffer?)"
            ) from None

    det = subscribe("detections", DetectionsMsg)
    st = subscribe("stats", StatsMsg)
    kp = subscribe("keypoints", KeypointsMsg) if a.keypoints else None
    desc = subscribe("descriptors", DescriptorsMsg) if a.descriptors else None
    grad = subscribe("gradients", None) if a.gradients else None
    services = ["detections", "stats"] + [
        name for on, name in ((a.keypoints, "keypoints"), (a.descriptors, "descriptors"), (a.gradients, "gradients")) if on
    ]
    print(f"mosaicd_subscriber: subscribed to {a.prefix}/{a.camera}/{{{','.join(services)}}}", file=sys.stderr, flush=True)

    out = sys.stdout
    received = 0
    start = time.monotonic()

    def emit(v: dict) -> None:
        out.write(json_line(v) + "\n")

    def drain_detections() -> None:
        nonlocal received
        # Keypoints go out before their frame's detections: draining them first keeps a frame's
        # lines together, as `mosaicd listen` does.
        while kp is not None and (s := kp.receive()) is not None:
            emit(keypoints_json(s.payload().contents))
        while desc is not None and (s := desc.receive()) is not None:
            emit(descriptors_json(s.payload().contents))
        while (s := det.receive()) is not None:
            emit(detections_json(s.payload().contents))
            received += 1

    cycle = iox2.Duration.from_millis(1)
    finished = False
    while True:
        try:
            node.wait(cycle)
        except iox2.NodeWaitFailure:
            break  # SIGINT / SIGTERM
        drain_detections()
        while grad is not None and (s := grad.receive()) is not None:
            v = _fields(s.user_header().contents)
            v["topic"] = "gradients"
            v["payload_bytes"] = s.payload().len()
            emit(v)
        while (s := st.receive()) is not None:
            m = s.payload().contents
            emit(stats_json(m))
            if m.is_final:
                finished = True
        out.flush()
        if finished and a.until_final:
            drain_detections()
            break
        if a.count is not None and received >= a.count:
            break
        if a.timeout_s is not None and time.monotonic() - start >= a.timeout_s:
            out.flush()
            print(f"timed out after {a.timeout_s} s with {received} detections messages", file=sys.stderr)
            return 1
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
