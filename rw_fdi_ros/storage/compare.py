"""Whether two bags hold the same run: topics, types, and per topic every message's stamp and contents.

Contents are compared decoded (rosbags' CDR reader), field by field and
exactly (floats bit for bit, NaN equal to NaN): two serialisations of one
message may differ in their padding bytes (rmw leaves them uninitialised,
DDS pads the payload to four bytes), never in what they say. Order across
topics is not compared: the graph's recorder takes messages from several
writers in whatever order they arrive; nor, for the same reason, the arrival
order of one topic's messages where it has two writers (/diagnostics: the
isolation node and the wheel allocation, each once per FDI period): a topic's
messages are compared in log-time order, those of one log time in any order.
"""
from __future__ import annotations

import bisect
import dataclasses
from pathlib import Path

import numpy as np

from .bag import BagInfo, iter_messages, typestore


def _same(a, b) -> bool:
    if dataclasses.is_dataclass(a):
        return type(a).__name__ == type(b).__name__ and all(
            _same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    if isinstance(a, (list, tuple)):
        return isinstance(b, (list, tuple)) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    return a == b


def _by_topic(bag: Path) -> tuple:
    """({topic: [(stamp, CDR bytes)]}, {topic: type}) of every channel of a bag."""
    out, info = {}, BagInfo(path=bag)
    for topic, stamp, raw in iter_messages(bag, None, info):
        out.setdefault(topic, []).append((stamp, bytes(raw)))
    for rows in out.values():   # two writers of a topic interleave as they arrive: their log times order them
        rows.sort(key=lambda row: row[0])
    return out, info.types


def _at(rows: list, stamp: int) -> list:
    """The messages of ``rows`` (sorted by log time) logged at ``stamp``."""
    lo = bisect.bisect_left(rows, stamp, key=lambda row: row[0])
    hi = bisect.bisect_right(rows, stamp, lo=lo, key=lambda row: row[0])
    return [raw for _, raw in rows[lo:hi]]


def _same_at_log_time(ma: list, mb: list, i: int, same) -> bool:
    """Whether message ``i``'s log time holds the same messages in ``ma`` and ``mb`` in some order (two writers of
    one topic at one log time arrive in either order)."""
    stamp = ma[i][0]
    group_a, group_b = _at(ma, stamp), _at(mb, stamp)
    if len(group_a) != len(group_b) or len(group_a) < 2:
        return False
    unmatched = list(group_b)
    for raw in group_a:
        match = next((j for j, other in enumerate(unmatched) if same(raw, other)), None)
        if match is None:
            return False
        del unmatched[match]
    return True


def bag_differences(a, b, limit: int = 10) -> list:
    """What differs between bags ``a`` and ``b`` (at most ``limit`` lines; empty: the same run).

    Parameters
    ----------
    a, b : str or Path
        The two bags (directories or .mcap files).
    limit : int
        The most lines to return.

    Returns
    -------
    list of str
        One line per difference: a topic's type, message count, or the first message whose log time [ns]
        or decoded contents differ.
    """
    a, b = Path(a), Path(b)
    (msgs_a, types_a), (msgs_b, types_b) = _by_topic(a), _by_topic(b)
    out = []
    for topic in sorted(set(types_a) | set(types_b)):
        if types_a.get(topic) != types_b.get(topic):
            out.append(f"{topic}: type {types_a.get(topic)} in {a.name}, {types_b.get(topic)} in {b.name}")
    store = typestore()
    for topic in sorted(set(msgs_a) | set(msgs_b)):
        ma, mb = msgs_a.get(topic, []), msgs_b.get(topic, [])
        if len(ma) != len(mb):
            out.append(f"{topic}: {len(ma)} messages in {a.name}, {len(mb)} in {b.name}")
            continue
        type_name = types_a.get(topic)

        def same(ra, rb, type_name=type_name):
            return ra == rb or _same(store.deserialize_cdr(ra, type_name), store.deserialize_cdr(rb, type_name))
        for i, ((sa, ra), (sb, rb)) in enumerate(zip(ma, mb)):
            if sa != sb:
                out.append(f"{topic} message {i}: stamp {sa} in {a.name}, {sb} in {b.name}")
                break
            if not same(ra, rb) and not _same_at_log_time(ma, mb, i, same):
                out.append(f"{topic} message {i} (t = {sa * 1e-9:g} s): contents differ")
                break
        if len(out) >= limit:
            break
    return out[:limit]
