"""Fast DDS shared-memory files left by processes that died without closing them.

The graph's participants talk through Fast DDS' shared-memory transport (config/fastdds.xml). Each
segment and each port lives in /dev/shm beside a lock file (``*_el``/``*_sl``) that its owner holds
with flock(2) while it is alive. A process that is killed (SIGKILL, a crash, a test's teardown) leaves
its files behind; the ports a domain's discovery uses are shared by every participant of that domain,
and enough dead listeners left in them stop new participants of a later run from discovering each other
(seen: a one-process-per-node graph whose plant never saw the wheel allocation, after ~1000 such files
had gathered). What Fast DDS' own `fastdds shm clean` does, here before every graph starts: a file
whose lock nobody holds belongs to no live process, and goes.
"""
from __future__ import annotations

import fcntl
import os
import re
import time
from pathlib import Path

SHM_DIR = Path("/dev/shm")
# fastdds_<16 hex> segments and fastdds_port<N> ports, each with its lock file
_LOCK = re.compile(r"^fastdds_(?:[0-9a-z]{16}|port\d{1,5})(?:_el|_sl)$")
# a lock file younger than this may be one a starting process has made and not yet locked
MIN_AGE_S = 30.0


def _locked(path: Path) -> bool:
    """Whether a live process holds ``path``'s flock (an exclusive non-blocking lock fails)."""
    try:
        with open(path, "ab") as f:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            fcntl.flock(f, fcntl.LOCK_UN)
        return False
    except OSError:
        return True


def zombie_files(shm_dir: Path = SHM_DIR, min_age: float = MIN_AGE_S) -> list:
    """The Fast DDS files of ``shm_dir`` that no live process holds.

    Parameters
    ----------
    shm_dir : Path
        Where the shared memory lives (/dev/shm on Linux).
    min_age : float
        Lock files modified less than this many seconds ago are left alone.

    Returns
    -------
    list of Path
        Each zombie's lock file, its segment or port file and, for a port, its semaphore (sem.<port>_mutex);
        only those that exist.
    """
    try:
        names = os.listdir(shm_dir)
    except OSError:
        return []
    now = time.time()
    out = []
    for name in names:
        if not _LOCK.match(name):
            continue
        lock = shm_dir / name
        try:
            if now - lock.stat().st_mtime < min_age or _locked(lock):
                continue
        except OSError:   # gone meanwhile
            continue
        base = name[:-3]
        for path in (lock, shm_dir / base, shm_dir / f"sem.{base}_mutex"):
            if path.exists():
                out.append(path)
    return out


def clean_zombie_files(shm_dir: Path = SHM_DIR, min_age: float = MIN_AGE_S) -> int:
    """Remove :func:`zombie_files`; a file another cleaner removed first is no error.

    Returns
    -------
    int
        How many files were removed.
    """
    removed = 0
    for path in zombie_files(shm_dir, min_age):
        try:
            path.unlink()
            removed += 1
        except OSError:
            pass
    return removed
