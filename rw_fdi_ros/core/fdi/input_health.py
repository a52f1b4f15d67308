"""Whether an FDI node's input stream lets it judge: the order of its stamps and the finiteness of its values.

A monitor that cannot judge must say so, never read OK: a silent monitor would
pass for a healthy wheel. Each FDI sample stamp t_k = k T_FDI arrives once, in order. What can go wrong with a
stream, and what the FDI nodes do about it:

- a stamp back at a run's first sample (t <= T_FDI): a new run starts (a
  replay feeds many bags through one graph; a late copy of a run's first
  sample would read so too: the stamps carry no run number);
- any other stamp not later than the last (a duplicate, or a message that
  arrives late): dropped, and said; it must not reset the run, which would
  forget an alarm;
- a stamp more than one period after the last: samples were lost; the
  sample is judged, and the gap is said;
- a non-finite value: the sample is not judged (NaN > threshold is False: it
  would read as healthy, or clear an alarm); the wheel is reported as unable to
  judge, and its alarm state is held.

Levels are diagnostic_msgs/DiagnosticStatus': OK 0, WARN 1, ERROR 2, STALE 3.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

OK, WARN, ERROR, STALE = 0, 1, 2, 3

NEXT, NEW_RUN, OUT_OF_ORDER = "next", "new_run", "out_of_order"


def stamp_order(last_ns: int | None, stamp_ns: int, period_ns: int) -> str:
    """How a sample stamped ``stamp_ns`` follows the last one accepted (``last_ns``, None at start).

    Parameters
    ----------
    last_ns : int or None
        Stamp of the last sample accepted [ns].
    stamp_ns : int
        The new sample's stamp [ns].
    period_ns : int
        FDI period [ns].

    Returns
    -------
    str
        NEXT, NEW_RUN (a stamp back at the run's first period) or OUT_OF_ORDER.
    """
    if last_ns is None or stamp_ns > last_ns:
        return NEXT
    return NEW_RUN if stamp_ns <= period_ns and stamp_ns != last_ns else OUT_OF_ORDER


def all_finite(*values) -> bool:
    """Whether every element of every argument is finite (no NaN, no inf).

    Parameters
    ----------
    *values : float or array_like
        Numbers or arrays of any shape.

    Returns
    -------
    bool
        True when all are finite (also for no arguments).
    """
    return all(np.all(np.isfinite(np.asarray(v, dtype=float))) for v in values)


@dataclass
class InputNote:
    """Something one input stream did that a person must read beside the verdict of its next sample."""

    level: int
    message: str


class InputMonitor:
    """One input stream's order, sample by sample: ``accept`` says whether to use a stamp.

    What the stream did (a gap, a dropped duplicate or late sample) is kept as a note on the
    stamp it concerns (a gap: the sample after it; a dropped one: the last accepted), for the
    status of that stamp or the next one published (``take_note``); ``last_note`` for a log line."""

    def __init__(self, name: str, period_s: float):
        self.name = name
        self.period_ns = int(round(period_s * 1e9))
        self.last_ns = None
        self.notes = {}      # stamp -> InputNote
        self.last_note = None
        self.dropped = 0

    def accept(self, stamp_ns: int) -> str:
        """NEXT, NEW_RUN (the caller resets its run) or OUT_OF_ORDER (the caller drops the sample).

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp [ns].

        Returns
        -------
        str
            NEXT, NEW_RUN or OUT_OF_ORDER.
        """
        order = stamp_order(self.last_ns, stamp_ns, self.period_ns)
        if order == OUT_OF_ORDER:
            self.dropped += 1
            what = "duplicate" if stamp_ns == self.last_ns else "late"
            self._say(self.last_ns, WARN, f"{self.name}: dropped a {what} sample stamped {stamp_ns * 1e-9:g} s "
                                          f"(after {self.last_ns * 1e-9:g} s)")
            return order
        if order == NEXT and self.last_ns is not None and stamp_ns - self.last_ns > 1.5 * self.period_ns:
            lost = int(round((stamp_ns - self.last_ns) / self.period_ns)) - 1
            self._say(stamp_ns, WARN, f"{self.name}: {lost} sample{'s' if lost > 1 else ''} missing before "
                            f"{stamp_ns * 1e-9:g} s (input gap)")
        if order == NEW_RUN:
            self.notes.clear()
        self.last_ns = stamp_ns
        return order

    def _say(self, stamp_ns, level, message):
        self.last_note = InputNote(level, message)
        old = self.notes.get(stamp_ns)
        self.notes[stamp_ns] = InputNote(max(level, old.level), f"{old.message}; {message}") if old else self.last_note

    def take_note(self, stamp_ns: int):
        """The notes on stamps up to ``stamp_ns`` as one (the highest level), or None; said once.

        Parameters
        ----------
        stamp_ns : int
            The stamp published [ns].

        Returns
        -------
        InputNote or None
            The note.
        """
        due = sorted(k for k in self.notes if k <= stamp_ns)
        if not due:
            return None
        notes = [self.notes.pop(k) for k in due]
        return InputNote(max(n.level for n in notes), "; ".join(n.message for n in notes))
