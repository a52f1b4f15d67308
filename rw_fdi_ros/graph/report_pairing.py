"""Each FDI report decided with its bus-voltage grid, in stamp order, whatever order the two topics bring them.

The FDI telemetry report and its grid (the identification's bus-voltage terms) come on two topics from one
publisher; a loaded machine may bring either first, and a replay of several runs starts its stamps again with
each run, where a new run's first grids may come before its first report. So each topic counts the runs it has
seen begin (a stamp back at the first FDI period: input_health.stamp_order), and a message is keyed by
(run, stamp). No ROS here: the isolation node feeds it and decides what it hands back.
"""
from __future__ import annotations

import time

from ..core.fdi.input_health import NEW_RUN, OUT_OF_ORDER, stamp_order

GRIDS_KEPT = 100   # grids whose report never came (a broken input): not kept forever


class ReportGridPairing:
    """Hands each report to ``decide(report, grid or None)`` in order, once its grid came, or once a later
    grid says its own was lost (one publisher on one reliable topic: the grids come in order); ``awaited``:
    whether a report waits for its grid at all (else it is decided at once, with the grid if it came first)."""

    def __init__(self, period_ns: int, decide):
        self.period_ns = int(period_ns)
        self.decide = decide
        self.grids, self.reports = {}, {}   # key -> grid; key -> (report, wall time it came) waiting for it
        self.grid_run, self.last_grid_ns = 0, None       # the grid topic's run and latest stamp
        self.report_run, self.last_report_ns = 0, None   # the report topic's
        self.last_decided = None                         # the key of the latest report decided

    def report(self, msg, stamp: int, awaited: bool) -> None:
        """Take an FDI telemetry report: decide it once its grid is in (at once unless ``awaited``).

        Parameters
        ----------
        msg : object
            The report.
        stamp : int
            Its stamp [ns].
        awaited : bool
            Whether it waits for its grid.
        """
        order = stamp_order(self.last_report_ns, stamp, self.period_ns)   # as the reports come, decided or not
        if order == OUT_OF_ORDER and self.grid_run > self.report_run:
            order = NEW_RUN   # the grids began a run whose first report was lost: this one is of that run
        if order == NEW_RUN:   # a new run: the last run's reports decided with what they have, its grids dropped
            self.flush()
            self.report_run = max(self.report_run + 1, self.grid_run)
            self.grids = {k: g for k, g in self.grids.items() if k[0] >= self.report_run}
        if order != OUT_OF_ORDER:
            self.last_report_ns = stamp
        key = (self.report_run, stamp)
        if key in self.reports:
            return   # a copy of a report still waiting: the first one is decided, in its turn, with its grid
        if awaited and order != OUT_OF_ORDER:
            self.reports[key] = (msg, time.monotonic())
            self._drain()
            return
        self._decide(msg, self.grids.pop(key, None), key)   # late or twice: the decider drops it, and says so
        if order != OUT_OF_ORDER:   # the grids of earlier stamps (their reports lost) are of no use now
            self.grids = {k: g for k, g in self.grids.items() if k > key}

    def grid(self, msg, stamp: int) -> None:
        """Take a bus-voltage grid: keep it for its report, and decide the reports it completes.

        Parameters
        ----------
        msg : object
            The grid.
        stamp : int
            Its stamp [ns].
        """
        order = stamp_order(self.last_grid_ns, stamp, self.period_ns)
        if (order == OUT_OF_ORDER or self.last_grid_ns is None) and self.report_run > self.grid_run:
            order = NEW_RUN   # the reports began a run whose first grid was lost (or came before any grid)
        if order == NEW_RUN:
            self.grid_run = max(self.grid_run + 1, self.report_run) if self.last_grid_ns is not None \
                else self.report_run
        if order != OUT_OF_ORDER:
            self.last_grid_ns = stamp
        key = (self.grid_run, stamp)
        if key not in self.reports and self.last_decided is not None and key <= self.last_decided:
            return   # its report was decided without it
        self.grids[key] = msg
        while len(self.grids) > GRIDS_KEPT:
            del self.grids[min(self.grids)]
        self._drain()

    def flush(self, waited: float | None = None) -> None:
        """Decide the waiting reports, oldest first, with their grid if it came: all, or those that waited
        ``waited`` wall seconds (a grid stream that went silent), then the rest as their grids allow.

        Parameters
        ----------
        waited : float or None
            Decide only the reports that waited longer than this [s] (wall time); None: all.
        """
        now = time.monotonic()
        for key in sorted(self.reports):
            msg, since = self.reports[key]
            if waited is not None and now - since <= waited:
                break
            del self.reports[key]
            self._decide(msg, self.grids.pop(key, None), key)
        self._drain()

    def _drain(self) -> None:
        while self.reports:
            key = min(self.reports)
            if key in self.grids:
                grid = self.grids.pop(key)
            elif any(k > key for k in self.grids):
                grid = None   # its identification skipped (the decider says so once)
            else:
                return
            self._decide(self.reports.pop(key)[0], grid, key)
            self.grids = {k: g for k, g in self.grids.items() if k > key}   # theirs lost with them

    def _decide(self, msg, grid, key) -> None:
        self.last_decided = key if self.last_decided is None else max(self.last_decided, key)
        self.decide(msg, grid)
