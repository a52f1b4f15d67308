"""rosbag2 bags in MCAP storage: the writer behind the recorder and the reader behind every tool.

Writing goes through ``rosbags.rosbag2.Writer`` (metadata.yaml + one .mcap).
The writer closes its MCAP chunk every ``flush_period`` of sim time and
flushes it to disk, so a recorder killed with SIGKILL loses at most that
much: the file then has no summary, footer or metadata.yaml.

Reading never needs the summary: :func:`read_bag` streams the .mcap
records front to back (mcap's StreamReader), decodes CDR with rosbags'
typestore and stops cleanly at a truncated tail, reporting what it read.
So a bag of a killed recorder is readable up to its last flushed chunk.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

_TYPESTORE = None


def typestore():
    global _TYPESTORE
    if _TYPESTORE is None:
        from rosbags.typesys import Stores, get_typestore
        _TYPESTORE = get_typestore(Stores.ROS2_KILTED)
    return _TYPESTORE


class BagError(RuntimeError):
    """A bag that cannot be read at all; one line naming the bag."""


def header_stamp_ns(raw: bytes, default: int) -> int:
    """Sim-time stamp of a CDR message whose first field is a builtin_interfaces/Time.

    Header-stamped messages and rosgraph_msgs/Clock all start with it, right
    after the 4-byte encapsulation header (byte 1 = 1: little endian).
    """
    if len(raw) < 12:
        return default
    fmt = "<iI" if raw[1] == 1 else ">iI"
    sec, nsec = struct.unpack_from(fmt, raw, 4)
    return sec * 1_000_000_000 + nsec


def _rosbags_version() -> str:
    from importlib.metadata import version
    return version("rosbags")


class BagWriter:
    """A rosbag2 (MCAP) writer that flushes a chunk every ``flush_period_ns`` of log time."""

    def __init__(self, path, flush_period_ns: int = 10_000_000_000):
        from rosbags.rosbag2 import StoragePlugin, Writer
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f"{self.path}: already exists")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        # rosbags keeps MCAP chunks in memory and has no public call to close one early; the flush
        # reaches into its MCAP storage. Should an upgrade move that, say so at once: a silent
        # no-op would let a SIGKILLed recorder lose its whole bag (rosbags is pinned in requirements).
        storage = getattr(self.writer, "storage", None)
        if not all(hasattr(storage, name) for name in ("chunk", "close_chunk", "bio")):
            self.writer.close()
            raise BagError(f"rosbags {_rosbags_version()}: its MCAP writer no longer has the chunk internals "
                           "storage/bag.py flushes through; pin rosbags==0.11.9 or update BagWriter.flush")
        self.connections = {}
        self.flush_period_ns = flush_period_ns
        self.next_flush = flush_period_ns
        self.count = 0

    def add_topic(self, topic: str, type_name: str):
        self.connections[topic] = self.writer.add_connection(topic, type_name, typestore=typestore())

    def write(self, topic: str, log_time_ns: int, raw: bytes):
        self.writer.write(self.connections[topic], log_time_ns, raw)
        self.count += 1
        if log_time_ns >= self.next_flush:
            self.flush()
            self.next_flush = log_time_ns + self.flush_period_ns

    def write_message(self, topic: str, log_time_ns: int, msg):
        """Write a rosbags message object (tests and offline tools that make bags)."""
        self.write(topic, log_time_ns, typestore().serialize_cdr(msg, self.connections[topic].msgtype))

    def flush(self):
        """Close the pending MCAP chunk and push it to disk (rosbags keeps chunks in memory)."""
        storage = self.writer.storage
        if storage.chunk is not None and storage.chunk.bio.tell():
            storage.close_chunk()
        storage.bio.flush()

    def set_custom_data(self, key: str, value: str):
        self.writer.set_custom_data(key, value)

    def close(self):
        self.writer.close()


@dataclass
class BagData:
    """Decoded messages per topic, in log-time order, and how complete the file was."""

    path: Path
    types: dict = field(default_factory=dict)
    messages: dict = field(default_factory=dict)   # topic -> list[(log_time_ns, msg)]
    complete: bool = False
    note: str = ""

    def topic(self, name):
        return self.messages.get(name, [])

    def vectors(self, name):
        """(time [s], values (n, 3)) of a Vector3Stamped topic, by header stamp."""
        rows = sorted(((m.header.stamp.sec, m.header.stamp.nanosec), m.vector) for _, m in self.topic(name))
        t = np.array([sec + nsec * 1e-9 for (sec, nsec), _ in rows])   # exact for whole seconds
        v = np.array([[r[1].x, r[1].y, r[1].z] for r in rows]).reshape(-1, 3)
        return t, v

    def joint_states(self, name):
        """(time [s], position, velocity, effort) of a sensor_msgs/JointState topic by header stamp;
        each (n, joints), (n, 0) where the messages leave a field out."""
        rows = sorted(((m.header.stamp.sec, m.header.stamp.nanosec), m) for _, m in self.topic(name))
        t = np.array([sec + nsec * 1e-9 for (sec, nsec), _ in rows])
        def field(f):
            return np.array([np.asarray(getattr(m, f), float) for _, m in rows]).reshape(len(rows), -1)
        return t, field("position"), field("velocity"), field("effort")

    @property
    def scenario_text(self):
        msgs = self.topic("/scenario")
        return msgs[0][1].data if msgs else None


def mcap_file(path) -> Path:
    path = Path(path)
    if path.is_file():
        return path
    files = sorted(path.glob("*.mcap")) if path.is_dir() else []
    if not files:
        raise BagError(f"{path}: no .mcap file (not a bag directory)")
    return files[0]


def read_bag(path, topics=None, raw: bool = False) -> BagData:
    """Every message of a bag (or of the given topics), tolerant of a truncated or summary-less file.

    ``raw=True`` keeps the CDR bytes instead of decoding (what a player republishes)."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Footer, Message, Schema
    from mcap.stream_reader import StreamReader

    path = Path(path)
    data = BagData(path=path)
    store = typestore()
    channels, schemas = {}, {}
    wanted = set(topics) if topics else None
    with open(mcap_file(path), "rb") as fh:
        try:
            for rec in StreamReader(fh).records:
                if isinstance(rec, Schema):
                    schemas[rec.id] = rec.name
                elif isinstance(rec, Channel):
                    channels[rec.id] = rec.topic
                    data.types[rec.topic] = schemas.get(rec.schema_id, "")
                elif isinstance(rec, Message):
                    topic = channels.get(rec.channel_id)
                    if topic is None or (wanted and topic not in wanted):
                        continue
                    msg = bytes(rec.data) if raw else store.deserialize_cdr(rec.data, data.types[topic])
                    data.messages.setdefault(topic, []).append((rec.log_time, msg))
                elif isinstance(rec, Footer):
                    data.complete = True
        except (McapError, EOFError, struct.error, ValueError) as exc:
            data.note = f"truncated ({type(exc).__name__}); read up to the last complete chunk"
    if not channels:
        raise BagError(f"{path}: no readable messages ({data.note or 'empty file'})")
    if data.complete and path.is_dir() and not (path / "metadata.yaml").exists():
        data.complete = False
        data.note = "metadata.yaml missing"
    for rows in data.messages.values():
        rows.sort(key=lambda r: r[0])
    return data


def bag_is_complete(path) -> bool:
    """True for a finished bag: metadata.yaml written and the MCAP footer present."""
    path = Path(path)
    if not (path / "metadata.yaml").exists():
        return False
    try:
        f = mcap_file(path)
    except BagError:
        return False
    with open(f, "rb") as fh:
        fh.seek(max(f.stat().st_size - 8, 0))
        return fh.read(8) == b"\x89MCAP0\r\n"
