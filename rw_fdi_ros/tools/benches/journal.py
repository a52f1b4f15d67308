"""A bench's finished work kept as it finishes, so that an interrupted bench resumes where it stopped.

:func:`resumable_map` maps a bench's work (chunks or batches of runs) like the executor's ``map_unordered``
and keeps each finished item's result in ``<out>/.<name>_journal/<index>.npz``: the result's structure as
JSON and its arrays beside it, read back with ``allow_pickle=False`` (a journal is data, never code). The
same command on the same code resumes: it takes the kept items and runs only the rest. A journal of other
work or other code (the signature: the work's and the function's description, a digest of the package and its
config, and of every file or folder the description names: a user's FDI, observer or vehicle) is set aside
and the bench starts over, saying so. The report written (kit.write_report), its journals are removed
(:func:`finish`): a bench of several stages resumes at the stage it stopped in.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import re
import shutil
import sys
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ...paths import config_dir

SIGNATURE = "signature.txt"


def encode(obj, arrays: list):
    """``obj`` as JSON-able data, its numpy arrays appended to ``arrays`` and referred to by position; dicts,
    tuples, ranges, namespaces and the package's dataclasses keep their type."""
    if isinstance(obj, np.ndarray):
        arrays.append(obj)
        return {"__array__": len(arrays) - 1}
    if isinstance(obj, np.generic):
        return obj.item()
    if obj is None or isinstance(obj, (str, bool, int, float)):
        return obj
    if isinstance(obj, list):
        return [encode(v, arrays) for v in obj]
    if isinstance(obj, tuple):
        return {"__tuple__": [encode(v, arrays) for v in obj]}
    if isinstance(obj, range):
        return {"__range__": [obj.start, obj.stop, obj.step]}
    if isinstance(obj, dict):
        return {"__dict__": [[encode(k, arrays), encode(v, arrays)] for k, v in obj.items()]}
    if isinstance(obj, SimpleNamespace):
        return {"__namespace__": encode(vars(obj), arrays)}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type) and _ours(type(obj)):
        return {"__dataclass__": f"{type(obj).__module__}:{type(obj).__qualname__}",
                "fields": {f.name: encode(getattr(obj, f.name), arrays) for f in dataclasses.fields(obj)}}
    raise TypeError(f"a bench journal cannot keep a {type(obj).__name__}")


def decode(data, arrays):
    """The object :func:`encode` described; a dataclass only of this package, its fields set as kept."""
    if isinstance(data, list):
        return [decode(v, arrays) for v in data]
    if not isinstance(data, dict):
        return data
    if "__array__" in data:
        return arrays[f"arr_{data['__array__']}"]
    if "__tuple__" in data:
        return tuple(decode(v, arrays) for v in data["__tuple__"])
    if "__range__" in data:
        return range(*data["__range__"])
    if "__namespace__" in data:
        return SimpleNamespace(**decode(data["__namespace__"], arrays))
    if "__dict__" in data:
        return {_hashable(decode(k, arrays)): decode(v, arrays) for k, v in data["__dict__"]}
    module, _, name = data["__dataclass__"].partition(":")
    # only a class of a module already loaded: reading a journal never runs a module's code
    cls = getattr(sys.modules.get(module), name, None) if module.startswith(f"{__package__.split('.')[0]}.") \
        else None
    if cls is None or not isinstance(cls, type) or not dataclasses.is_dataclass(cls) or not _ours(cls):
        raise ValueError(f"not a class of this package: {data['__dataclass__']}")
    obj = cls.__new__(cls)   # as kept: no __init__ / __post_init__ to run again (frozen ones too)
    for key, value in data["fields"].items():
        object.__setattr__(obj, key, decode(value, arrays))
    return obj


def _ours(cls) -> bool:
    return cls.__module__.startswith(f"{__package__.split('.')[0]}.")


def _hashable(key):
    return tuple(key) if isinstance(key, list) else key


def code_digest() -> str:
    """A digest of the package's code and its config (vehicles, FDI, scenarios): what a kept result depends on
    besides its work."""
    digest = hashlib.sha256()
    for root, pattern in ((Path(__file__).resolve().parents[2], "*.py"), (config_dir(), "*")):
        for path in sorted(root.rglob(pattern)):
            if path.is_file():
                digest.update(str(path.relative_to(root)).encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()


def work_signature(fn, work) -> str:
    """The description of ``fn`` and ``work`` (objects' addresses dropped), the code's digest and that of the
    files and folders the description names (a user's FDI directory, vehicle file or observer)."""
    described = re.sub(r" at 0x[0-9a-f]+", "", repr(fn) + repr(list(work)))
    digest = hashlib.sha256(described.encode())
    for text in sorted(set(re.findall(r"'(/[^']+)'", described))):
        path = Path(text)
        files = sorted(p for p in path.rglob("*") if not _ignored(p, path)) if path.is_dir() else [path]
        for f in files:
            if f.is_file():
                digest.update(str(f).encode())
                digest.update(f.read_bytes())
    return digest.hexdigest() + " " + code_digest()


def _ignored(path: Path, root: Path) -> bool:
    """What a named folder holds that the work does not read: the reports (and journals) benches write there."""
    parts = path.relative_to(root).parts
    return any(p.startswith(".") or p == "reports" for p in parts)


def _keyed(fn, item):
    index, work = item
    return index, fn(work)


def resumable_map(executor, fn, work: list, out, name: str, processes: bool = True):
    """``fn(item)`` of every item of ``work`` on ``executor`` (``map_unordered``), unordered; the results
    kept in ``<out>/.<name>_journal`` are given first without running them again."""
    journal = Path(out) / f".{name}_journal"
    signature = work_signature(fn, work)
    kept = {}
    if journal.is_dir():
        if (journal / SIGNATURE).is_file() and (journal / SIGNATURE).read_text() == signature:
            kept = _read(journal)
            print(f"{name}: resuming, {len(kept)} of {len(work)} parts kept in {journal}", file=sys.stderr)
        else:
            print(f"{name}: {journal} holds other work or code: starting over", file=sys.stderr)
            shutil.rmtree(journal)
    journal.mkdir(parents=True, exist_ok=True)
    (journal / SIGNATURE).write_text(signature)
    yield from kept.values()
    todo = [(i, item) for i, item in enumerate(work) if i not in kept]
    finished = len(kept)
    try:
        for index, result in executor.map_unordered(partial(_keyed, fn), todo, processes=processes):
            _write(journal, index, result)
            finished += 1
            yield result
    except KeyboardInterrupt:
        print(f"\n{name}: interrupted; {finished} of {len(work)} parts kept in {journal}: the same command "
              "resumes", file=sys.stderr)
        raise


def finish(out, name: str):
    """Remove the journals of bench ``name`` in ``out`` (``.<name>*_journal``: each stage's): its report is whole."""
    for journal in Path(out).glob(f".{name}*_journal"):
        shutil.rmtree(journal, ignore_errors=True)


def _write(journal: Path, index: int, result):
    arrays = []
    tree = json.dumps(encode(result, arrays))
    part = journal / f"{index}.npz"
    with open(part.with_suffix(".tmp"), "wb") as f:   # whole or absent: a kill mid-write leaves a .tmp
        np.savez_compressed(f, tree=np.array(tree), **{f"arr_{i}": a for i, a in enumerate(arrays)})
    part.with_suffix(".tmp").replace(part)


def _read(journal: Path) -> dict:
    kept = {}
    for part in sorted(journal.glob("*.npz")):
        try:
            with np.load(part, allow_pickle=False) as arrays:
                kept[int(part.stem)] = decode(json.loads(str(arrays["tree"])), arrays)
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:   # a damaged part: run again
            print(f"journal: {part.name} unreadable ({exc}): run again", file=sys.stderr)
    return kept
