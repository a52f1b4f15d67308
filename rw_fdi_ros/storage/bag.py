"""rosbag2 bags in MCAP storage: the readers behind every tool (the writer: writer.py).

A bag is a directory with one .mcap and, once closed, metadata.yaml. A
recorder killed with SIGKILL leaves the chunks its writer flushed: the file
then has no summary, footer or metadata.yaml.

Reading never needs the summary: :func:`iter_messages` streams the .mcap
records front to back (mcap's StreamReader) and stops cleanly at a truncated
tail, reporting what it read. Every chunk is checked against its CRC as it
is read: a damaged one is skipped and counted (``BagInfo.damaged``), the
rest read; a bag is complete only with its footer, a readable metadata.yaml
that counts what the file holds, and at least one message. The tools that
train, fit or judge read with ``intact=True``: a damaged bag is a BagError
naming it, which they skip and count. So a bag of a killed recorder is readable up
to its last flushed chunk. Memory stays bounded by design: the tools that
summarise a run read it as a stream into numbers (:func:`read_series`: a
Vector3Stamped row costs 32 bytes, not a message object) or counts
(:func:`bag_info`); :func:`read_bag` keeps decoded messages, for short reads.
"""
from __future__ import annotations

import struct
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from ..core.mission.yaml_text import read_yaml_file

import numpy as np

_TYPESTORE = None


def typestore():
    """The rosbags type store of ROS 2 Kilted messages, built on the first call and kept.

    Returns
    -------
    rosbags.typesys.store.Typestore
        The shared type store (it decodes a message's CDR bytes by its type name).
    """
    global _TYPESTORE
    if _TYPESTORE is None:
        from rosbags.typesys import Stores, get_typestore
        _TYPESTORE = get_typestore(Stores.ROS2_KILTED)
    return _TYPESTORE


class BagError(RuntimeError):
    """A bag that cannot be read at all; one line naming the bag."""


def _wheel_values(bag, name):
    """(time [s], values (n, wheels)) of a per-wheel topic of a :class:`BagData` or :class:`BagSeries`: a
    JointState's efforts (what the graph writes, one column per joint), or a Vector3Stamped's x, y, z (bags
    recorded before the redundant wheel, one column per axis wheel)."""
    if bag.types.get(name) == _VECTOR3_STAMPED:
        return bag.vectors(name)
    t, _, _, effort = bag.joint_states(name)
    return t, effort


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

    def last(self, name):
        """The last message of a topic in log-time order, or None."""
        rows = self.topic(name)
        return rows[-1][1] if rows else None

    def vectors(self, name):
        """(time [s], values (n, 3)) of a Vector3Stamped topic, by header stamp."""
        rows = sorted((((m.header.stamp.sec, m.header.stamp.nanosec), m.vector) for _, m in self.topic(name)),
                      key=lambda r: r[0])
        t = np.array([sec + nsec * 1e-9 for (sec, nsec), _ in rows])   # exact for whole seconds
        v = np.array([[r[1].x, r[1].y, r[1].z] for r in rows]).reshape(-1, 3)
        return t, v

    def joint_states(self, name):
        """(time [s], position, velocity, effort) of a sensor_msgs/JointState topic by header stamp;
        each (n, joints), (n, 0) where the messages leave a field out."""
        rows = sorted((((m.header.stamp.sec, m.header.stamp.nanosec), m) for _, m in self.topic(name)),
                      key=lambda r: r[0])
        t = np.array([sec + nsec * 1e-9 for (sec, nsec), _ in rows])
        def field(f):
            if not rows:
                return np.zeros((0, 0))
            return np.array([np.asarray(getattr(m, f), float) for _, m in rows]).reshape(len(rows), -1)
        return t, field("position"), field("velocity"), field("effort")

    wheel_values = _wheel_values   # one function for both readers

    @property
    def scenario_text(self):
        msgs = self.topic("/scenario")
        return msgs[0][1].data if msgs else None


def mcap_file(path) -> Path:
    """The .mcap file of a bag.

    Parameters
    ----------
    path : str or Path
        A bag directory, or an .mcap file itself.

    Returns
    -------
    Path
        ``path`` where it is a file, else the directory's one .mcap (BagError where it has none or several).
    """
    path = Path(path)
    if path.is_file():
        return path
    files = sorted(path.glob("*.mcap")) if path.is_dir() else []
    if not files:
        raise BagError(f"{path}: no .mcap file (not a bag directory)")
    if len(files) > 1:   # ours write one; reading the first alone would drop the others' messages silently
        raise BagError(f"{path}: {len(files)} .mcap files ({', '.join(f.name for f in files[:3])}); a bag here "
                       "holds one")
    return files[0]


@dataclass
class BagInfo:
    """What one pass over a bag saw: types, message counts and log-time span per topic, completeness."""

    path: Path
    types: dict = field(default_factory=dict)      # topic -> message type
    counts: dict = field(default_factory=dict)     # topic -> messages read
    span: dict = field(default_factory=dict)       # topic -> [first, last] log time [ns]
    complete: bool = False
    note: str = ""
    damaged: int = 0      # chunks that failed their CRC or did not decode, and damaged record headers
    messages: int = 0     # messages in the file, every topic
    damaged_at: list = field(default_factory=list)   # the records (1-based) whose header was damaged
    after_damage: int = 0   # messages read after the first damaged record header, in the chunks beyond it

    def damage(self) -> str:
        """'' for an undamaged file, else what is damaged and what was still read (one line).

        Returns
        -------
        str
            'damaged at record N: ...' or 'damaged: K chunk(s) ...', with the messages read.
        """
        if not self.damaged:
            return ""
        chunks = self.damaged - len(self.damaged_at)
        parts = ([f"damaged at record {', '.join(map(str, self.damaged_at))} (the record skipped, "
                  f"{self.after_damage} messages after it read)"] if self.damaged_at else []) + \
            ([f"{chunks} chunk(s) fail their CRC or do not decode (their messages skipped)"] if chunks else [])
        return "damaged: " + "; ".join(parts) + f"; {sum(self.counts.values())} messages read"


def _counted(path: Path):
    """The messages metadata.yaml counts (None without a readable one)."""
    try:
        return sum(message_counts(path).values()) if path.is_dir() and (path / "metadata.yaml").exists() else None
    except BagError:
        return None


def _next_chunk(fh, start: int, size: int):
    """The offset of the first whole chunk at or after ``start`` whose CRC holds (None: none): where reading
    goes on after a damaged record header. Candidates are the chunk opcode followed by a length that fits."""
    import mmap
    from io import BytesIO
    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk
    from mcap.stream_reader import breakup_chunk
    if start >= size:
        return None
    with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as view:
        at = view.find(b"\x06", start)
        while at != -1 and at + 9 <= size:
            length = int.from_bytes(view[at + 1:at + 9], "little")
            if at + 9 + length <= size:
                try:
                    chunk = Chunk.read(ReadDataStream(BytesIO(view[at + 9:at + 9 + length])))
                    if chunk.uncompressed_crc != 0:   # a CRC to hold: a chance match cannot pass it
                        breakup_chunk(chunk, validate_crc=True)
                        return at
                except Exception:   # noqa: BLE001 -- not a chunk here: look further
                    pass
            at = view.find(b"\x06", at + 1)
    return None


def iter_messages(path, topics=None, info: BagInfo | None = None):
    """(topic, log_time_ns, CDR bytes) of every message of a bag (or of ``topics``), in file order.

    One record at a time: memory does not grow with the bag. ``info`` is filled as the records
    pass (counts and spans of the wanted topics only); a truncated tail ends the stream with
    ``info.note`` saying so. A file without a single channel raises BagError, at the end.

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.
    topics : iterable of str, optional
        The topics to yield; None (or empty) for every topic.
    info : BagInfo, optional
        Filled in place as the records pass; a fresh one when None.

    Returns
    -------
    iterator of tuple (str, int, bytes)
        (topic, log time [ns], CDR bytes with the encapsulation header) per message, in file order.
    """
    from mcap.exceptions import McapError
    from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk

    path = Path(path)
    info = info if info is not None else BagInfo(path=path)
    channels, schemas = {}, {}
    wanted = set(topics) if topics else None
    records_seen, data_ended, start, last_time = 0, False, 0, None
    with open(mcap_file(path), "rb") as fh:
        size = fh.seek(0, 2)
        while start is not None:
            fh.seek(start)
            end = start   # where the last whole record ended: a damaged one starts there
            try:
                for outer in StreamReader(fh, skip_magic=start > 0, emit_chunks=True).records:
                    records_seen += 1
                    end = fh.tell()
                    records = [outer]
                    if isinstance(outer, Chunk):
                        try:
                            records = breakup_chunk(outer, validate_crc=True)
                        except Exception:   # noqa: BLE001 -- bad CRC, bad compression, bad records: counted
                            info.damaged += 1
                            continue
                    for rec in records:
                        if isinstance(rec, Message):
                            info.messages += 1
                            info.after_damage += bool(info.damaged_at)
                            topic = channels.get(rec.channel_id)
                            last_time = rec.log_time if last_time is None else max(last_time, rec.log_time)
                            if topic is None or (wanted and topic not in wanted):
                                continue
                            info.counts[topic] = info.counts.get(topic, 0) + 1
                            span = info.span.setdefault(topic, [rec.log_time, rec.log_time])
                            span[0], span[1] = min(span[0], rec.log_time), max(span[1], rec.log_time)
                            yield topic, rec.log_time, rec.data
                        elif isinstance(rec, Schema):
                            schemas[rec.id] = rec.name
                        elif isinstance(rec, Channel):
                            channels[rec.id] = rec.topic
                            info.types[rec.topic] = schemas.get(rec.schema_id, "")
                        elif isinstance(rec, DataEnd):
                            data_ended = True
                        elif isinstance(rec, Footer):
                            info.complete = True
                start = None
            except (McapError, EOFError, struct.error, ValueError) as exc:
                # a damaged record header, or the tail cut off: the next whole chunk, if any, goes on
                start = None if data_ended else _next_chunk(fh, end + 1, size)
                if start is not None:
                    info.damaged += 1
                    info.damaged_at.append(records_seen + 1)
                elif data_ended or _counted(path) == info.messages:   # past the data: its index, its summary
                    info.note = f"damaged after the data at byte {end} ({type(exc).__name__}): every message read"
                elif fh.tell() < size:   # not the file's end: damage with no whole chunk after it
                    info.damaged += 1
                    info.damaged_at.append(records_seen + 1)
                    info.note = f"nothing readable after byte {end} ({type(exc).__name__})"
                else:
                    at = "" if last_time is None else f" at {last_time * 1e-9:.1f} s"
                    info.note = f"truncated{at} ({type(exc).__name__}); read up to the last complete chunk"
    if not channels:
        raise BagError(f"{path}: no readable messages ({info.damage() or info.note or 'empty file'})")
    trouble = info.damage() or (_metadata_trouble(path, info) if info.complete else "")
    if trouble:
        info.complete = False
        info.note = "; ".join(x for x in (trouble, info.note) if x)


def _metadata_trouble(path: Path, info: BagInfo) -> str:
    """Why a file with its footer is still not a complete bag ('' when it is): no message at all, or a
    metadata.yaml missing, unreadable, or counting other messages than the file holds."""
    if not info.messages:
        return "no messages"
    if not path.is_dir():
        return ""
    if not (path / "metadata.yaml").exists():
        return "metadata.yaml missing"
    try:
        counted = sum(message_counts(path).values())
    except BagError as exc:
        return str(exc).split(": ", 1)[-1]
    if counted != info.messages:
        return f"metadata.yaml counts {counted} messages, the file holds {info.messages}"
    return ""


def check_intact(info: BagInfo):
    """A BagError naming the bag where a chunk was damaged (what trains, fits or judges must not read it).

    Parameters
    ----------
    info : BagInfo
        What a pass over the bag saw.

    Returns
    -------
    None
        Returns only where no chunk was damaged.
    """
    if info.damaged:
        raise BagError(f"{info.path}: {info.damage()}")


def bag_info(path, topics=None) -> BagInfo:
    """Types, counts and spans per topic of a bag, read as a stream without decoding a message.

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.
    topics : iterable of str, optional
        The topics to count; None for every topic.

    Returns
    -------
    BagInfo
        Types of every topic, counts and log-time spans [ns] of the ``topics``, completeness and damage.
    """
    info = BagInfo(path=Path(path))
    for _ in iter_messages(path, topics, info):
        pass
    return info


def read_bag(path, topics=None, raw: bool = False, intact: bool = False) -> BagData:
    """Every message of a bag (or of the given topics), decoded, tolerant of a truncated or summary-less file.

    Memory grows with what is read: ask for the topics you need (or use :func:`read_series`).
    ``raw=True`` keeps the CDR bytes instead of decoding (what a player republishes); ``intact``: a damaged
    chunk is a BagError, not a skip.

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.
    topics : iterable of str, optional
        The topics to read; None for every topic.
    raw : bool
        Keep each message's CDR bytes instead of decoding it.
    intact : bool
        Raise BagError where a chunk is damaged, instead of skipping it.

    Returns
    -------
    BagData
        Per topic a list of (log time [ns], message or CDR bytes), in log-time order; completeness and note.
    """
    info = BagInfo(path=Path(path))
    data = BagData(path=info.path, types=info.types)
    for topic, log_time, raw_msg in iter_messages(path, topics, info):
        msg = bytes(raw_msg) if raw else _decode(raw_msg, info.types[topic], path, topic)
        data.messages.setdefault(topic, []).append((log_time, msg))
    if intact:
        check_intact(info)
    data.complete, data.note = info.complete, info.note
    for rows in data.messages.values():
        rows.sort(key=lambda r: r[0])
    return data


def iter_time_order(path, topics, rank=None):
    """(log_time_ns, topic, CDR bytes) of a bag's ``topics`` in log-time order, ties by ``rank(topic)``
    and then file order: what a player republishes.

    A complete bag is merged through its MCAP chunk index (mcap's SeekingReader), holding only the
    chunks that overlap in time; a bag without a summary (a killed recorder) is read whole and sorted.

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.
    topics : iterable of str or None
        The topics to yield; None for every topic.
    rank : callable, optional
        ``rank(topic)`` -> a sortable key, lower first among messages of one log time; None: all alike.

    Returns
    -------
    iterator of tuple (int, str, bytes)
        (log time [ns], topic, CDR bytes) per message.
    """
    from mcap.exceptions import McapError
    from mcap.reader import SeekingReader
    rank = rank or (lambda topic: 0)
    group, at = [], None
    for row in _log_time_ordered(path, topics, McapError, SeekingReader):
        if row[0] != at and group:
            yield from sorted(group, key=lambda r: rank(r[1]))   # stable: file order within a rank
            group = []
        at = row[0]
        group.append(row)
    yield from sorted(group, key=lambda r: rank(r[1]))


def _log_time_ordered(path, topics, McapError, SeekingReader):
    with open(mcap_file(path), "rb") as fh:
        try:
            reader = SeekingReader(fh)
            summary = reader.get_summary()
        except (McapError, EOFError, struct.error, ValueError):
            summary = None
        if summary is None or not summary.chunk_indexes:
            rows = [(t, topic, bytes(raw)) for topic, t, raw in iter_messages(path, topics)]
            yield from sorted(rows, key=lambda r: r[0])
            return
        for _, channel, msg in reader.iter_messages(topics=topics, log_time_order=True):
            yield msg.log_time, channel.topic, bytes(msg.data)


def _seconds(stamps_ns: np.ndarray) -> np.ndarray:
    """sec + nsec * 1e-9, the same float as a message's header stamp gives (exact for whole seconds)."""
    return stamps_ns // 1_000_000_000 + (stamps_ns % 1_000_000_000) * 1e-9


class _Rows:
    """One topic's rows as flat numbers: int64 stamps and float64 fields of a fixed width each."""

    def __init__(self, topic: str):
        self.topic, self.stamps, self.values, self.widths = topic, array("q"), array("d"), None

    def add(self, stamp_ns: int, fields):
        widths = tuple(len(f) for f in fields)
        if self.widths is None:
            self.widths = widths
        elif widths != self.widths:
            raise BagError(f"{self.topic}: rows of different lengths {self.widths} and {widths}")
        self.stamps.append(stamp_ns)
        for f in fields:
            self.values.extend(f)

    def columns(self):
        """(time [s], [field (n, width) ...]) sorted by stamp."""
        stamps = np.frombuffer(self.stamps, dtype=np.int64) if len(self.stamps) else np.zeros(0, np.int64)
        widths = self.widths or ()
        flat = np.frombuffer(self.values, dtype=np.float64).reshape(len(stamps), sum(widths)) \
            if len(stamps) else np.zeros((0, sum(widths)))
        order = np.argsort(stamps, kind="stable")
        edges = np.cumsum((0,) + widths)
        return _seconds(stamps[order]), [flat[order, a:b] for a, b in zip(edges[:-1], edges[1:])]


_VECTOR3_STAMPED = "geometry_msgs/msg/Vector3Stamped"
_JOINT_STATE = "sensor_msgs/msg/JointState"


@dataclass
class BagSeries:
    """A bag read as numbers: Vector3Stamped and JointState topics as arrays, every other topic as
    its first and last message. The same accessors as :class:`BagData`, in bounded memory."""

    path: Path
    info: BagInfo
    rows: dict = field(default_factory=dict)        # topic -> _Rows
    first_last: dict = field(default_factory=dict)  # topic -> [first msg, last msg]

    types = property(lambda self: self.info.types)
    complete = property(lambda self: self.info.complete)
    note = property(lambda self: self.info.note)

    def vectors(self, name):
        """(time [s], values (n, 3)) of a Vector3Stamped topic, by header stamp."""
        t, fields = self._columns(name, 1)
        return t, fields[0].reshape(-1, 3)

    def joint_states(self, name):
        """(time [s], position, velocity, effort) of a JointState topic by header stamp, each (n, joints)."""
        t, fields = self._columns(name, 3)
        return (t, *(f.reshape(len(t), -1) if len(t) else np.zeros((0, 0)) for f in fields))

    wheel_values = _wheel_values   # one function for both readers

    def _columns(self, name, n_fields):
        rows = self.rows.get(name)
        if rows is None:
            return np.zeros(0), [np.zeros((0, 0))] * n_fields
        return rows.columns()

    def first(self, name):
        return self.first_last.get(name, (None, None))[0]

    def last(self, name):
        return self.first_last.get(name, (None, None))[1]

    @property
    def scenario_text(self):
        msg = self.first("/scenario")
        return msg.data if msg is not None else None


def _decode(raw, kind: str, path, topic: str):
    """A message decoded, or a BagError naming the bag and topic (bytes that pass the CRC and still do not
    decode: a file written wrong)."""
    try:
        return typestore().deserialize_cdr(raw, kind)
    except Exception as exc:   # noqa: BLE001 -- rosbags' SerdeError and the struct errors under it
        raise BagError(f"{path}: a {topic} message does not decode as {kind} ({type(exc).__name__})") from None


def read_series(path, topics, intact: bool = False) -> BagSeries:
    """The given topics of a bag as a stream into numbers (Vector3Stamped, JointState) or their first
    and last messages (the rest): memory grows only with the numbers kept, 8 bytes each. ``intact``: a
    damaged chunk is a BagError, not a skip.

    Parameters
    ----------
    path : str or Path
        A bag directory or its .mcap file.
    topics : iterable of str
        The topics to read (None: every topic).
    intact : bool
        Raise BagError where a chunk is damaged, instead of skipping it.

    Returns
    -------
    BagSeries
        Vector3Stamped and JointState topics as arrays by header stamp, every other topic as its first
        and last message (the last by header stamp).
    """
    from .cdr import read_joint_state_cdr, read_vector_cdr
    info = BagInfo(path=Path(path))
    out = BagSeries(path=info.path, info=info)
    for topic, _, raw in iter_messages(path, topics, info):
        kind = info.types[topic]
        if kind == _VECTOR3_STAMPED:
            stamp, values = read_vector_cdr(raw)
            out.rows.setdefault(topic, _Rows(topic)).add(stamp, (values,))
        elif kind == _JOINT_STATE:
            stamp, *fields = read_joint_state_cdr(raw)
            out.rows.setdefault(topic, _Rows(topic)).add(stamp, fields)
        else:
            msg = _decode(raw, kind, path, topic)
            pair = out.first_last.setdefault(topic, [msg, msg])
            if _stamp_of(msg) >= _stamp_of(pair[1]):
                pair[1] = msg
    if intact:
        check_intact(info)
    return out


def _stamp_of(msg):
    stamp = getattr(getattr(msg, "header", None), "stamp", None)
    return (stamp.sec, stamp.nanosec) if stamp is not None else (0, 0)


def message_counts(path) -> dict:
    """{topic: messages} of a finished bag, from its metadata.yaml (nothing of the data file is read);
    empty without one.

    Parameters
    ----------
    path : str or Path
        A bag directory.

    Returns
    -------
    dict of str to int
        Messages per topic as metadata.yaml counts them; empty without metadata.yaml (BagError where it is
        unreadable).
    """
    return _from_metadata(path, lambda info: {t["topic_metadata"]["name"]: int(t["message_count"])
                                              for t in info["topics_with_message_count"]})


def _from_metadata(path, read) -> dict:
    """``read(info)`` of a finished bag's metadata.yaml (its rosbag2_bagfile_information); {} without the file,
    BagError where it is unreadable."""
    meta = Path(path) / "metadata.yaml"
    if not meta.is_file():
        return {}
    try:
        return read(read_yaml_file(meta)["rosbag2_bagfile_information"])
    except (KeyError, TypeError, ValueError, OSError, UnicodeDecodeError) as exc:
        raise BagError(f"{meta}: unreadable metadata ({exc})") from None


def bag_custom_data(path) -> dict:
    """A finished bag's metadata.yaml custom_data: which engine recorded it ('engine': 'graph' or 'core') and,
    for a graph under a namespace, that namespace ('namespace'); {} when it says nothing (an unfinished bag).

    Parameters
    ----------
    path : str or Path
        A bag directory.

    Returns
    -------
    dict of str to str
        The custom data.
    """
    return _from_metadata(path, lambda info: dict(info.get("custom_data") or {}))


def bag_engine(path) -> str | None:
    """Which engine recorded a finished bag ('graph' or 'core'); None when it does not say (an unfinished bag,
    or one recorded before bags said).

    Parameters
    ----------
    path : str or Path
        A bag directory.

    Returns
    -------
    str or None
        'graph' or 'core' (what metadata.yaml says), or None.
    """
    return bag_custom_data(path).get("engine")


def bag_is_complete(path) -> bool:
    """True for a finished bag: metadata.yaml written and the MCAP footer present.

    Parameters
    ----------
    path : str or Path
        A bag directory.

    Returns
    -------
    bool
        Whether metadata.yaml exists and the .mcap ends in the MCAP magic bytes.
    """
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
