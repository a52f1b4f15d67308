"""A recorded run's figure: |residual| against threshold per observer and wheel, and the FDIR chain below."""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from ..core.mission.scenario import parse_scenario
from ..core.physics.spacecraft import BODY_AXES, nearest_setpoint
from ..graph import topics as T
from ..scoring import bag_series
from .summary import POINTING_DEG
from .verdict import fdi_verdict, observer_label


def envelope(t, y, buckets: int = 2000):
    """At most 2 ``buckets`` samples of the line (t, y) keeping each bucket's smallest and largest value in
    time order: all a figure ~1500 px wide can show, spikes included, in memory that does not grow with
    the run (a 6 h run has 21,600 FDI samples per line)."""
    t, y = np.asarray(t), np.asarray(y)
    if len(t) <= 2 * buckets:
        return t, y
    edges = np.linspace(0, len(t), buckets + 1).astype(int)
    keep = []
    for a, b in zip(edges[:-1], edges[1:]):
        lo, hi = a + int(np.argmin(y[a:b])), a + int(np.argmax(y[a:b]))
        keep += [lo, hi] if lo < hi else [hi, lo] if hi < lo else [lo]
    keep = np.asarray(keep)
    return t[keep], y[keep]


_PLOT_LOCK = threading.Lock()   # matplotlib (its mathtext parser above all) is not thread-safe


def plot_residuals(data, path: Path) -> Path:
    """|Residual| against threshold per observer and wheel (like thesis Figs. 4.19-4.23, 5.2/5.3).

    Speed-aware runs (a non-zero ripple bound) are drawn on a log scale: their thresholds sit
    two orders of magnitude below the fault signatures. Campaign threads plot one at a time."""
    with _PLOT_LOCK:
        return _plot_residuals(data, path)


def _plot_residuals(data, path: Path) -> Path:
    from matplotlib.figure import Figure   # no pyplot: its global figure stack is not thread-safe
    verdict = fdi_verdict(data)
    observers = verdict["observers"] or ["elman"]
    wheels = list(verdict["truth"])
    fig = Figure(figsize=(3.6 * len(wheels) + 3, 3.25 * (len(observers) + 1)))
    grid = fig.add_gridspec(len(observers) + 1, len(wheels))
    axes = np.array([[fig.add_subplot(grid[r, c]) for c in range(len(wheels))] for r in range(len(observers))])
    chain = fig.add_subplot(grid[-1, :], sharex=axes[0, 0])
    for row, obs in enumerate(observers):
        t_c, thr = data.wheel_values(T.fdi_output_topics(obs)["threshold"])
        t_r, res = bag_series.observer_vectors(data, obs, wheels=tuple(wheels))
        _, bound = bag_series.observer_vectors(data, obs, "ripple_bound", wheels=tuple(wheels))
        for i, a in enumerate(wheels):
            ax = axes[row, i]
            speed_aware = bound.size and np.any(bound[:, i] != 0.0)
            ax.plot(*envelope(t_r, np.abs(res[:, i]) * 1e3), label="|residual|", lw=1.2)
            ax.plot(*envelope(t_c, thr[:, i] * 1e3), "--", label="threshold (c + bound)" if speed_aware else
                    "threshold (mean + 3σ)", lw=1.2, color="tab:red")
            if speed_aware:
                ax.set_yscale("log")
                floor = thr[:, i][thr[:, i] > 0]
                if floor.size:   # a residual of exactly 0 (an observer's first sample) would stretch the axis
                    ax.set_ylim(bottom=max(ax.get_ylim()[0], float(floor.min()) * 1e3 * 1e-3))
            for f in verdict["truth"][a]:
                ax.axvline(f["onset"], color="k", lw=0.8, alpha=0.6)
                ax.text(f["onset"], ax.get_ylim()[1] * 0.9, f" {f['kind']}={f['value']:g}", fontsize=7)
            for s, e in verdict.get(obs, {}).get(a, []):
                ax.axvspan(s, e if e is not None else t_r[-1], color="tab:orange", alpha=0.15)
            ax.set_title(f"{observer_label(obs)}, wheel {a}", fontsize=10)
            ax.set_ylabel("10⁻³ N m")
            ax.grid(alpha=0.3)
    _plot_pointing(data, verdict, chain)
    chain.set_xlabel("sim time [s]")
    axes[0, 0].legend(fontsize=8, loc="upper right")
    fig.suptitle(f"{data.path.name}: residuals vs threshold curves (shaded: alarm); last row: the FDIR chain")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def _plot_pointing(data, verdict, ax):
    """The chain in one row: the pointing error per axis against the 0.2 deg requirement, with the fault's
    onset, the verdict's first alarm and each reconfiguration (/fdir/wheels) marked, and in orbit the
    momentum dumps shaded."""
    from ..core.physics.environment import MAGNETOMETER_PERIOD
    from ..core.physics.magnetorquers import DumpLog
    from ..core.mission.scenario import setpoint_at
    scenario = parse_scenario(data.scenario_text or "{}", origin=f"{data.path}:/scenario")
    times, values = scenario.setpoint_schedule()
    t, attitude, _, _ = data.joint_states(T.ATTITUDE)
    if len(t):
        error = np.degrees(np.abs(attitude - nearest_setpoint(np.array([setpoint_at(times, values, x) for x in t]),
                                                              attitude)))
        for i, a in enumerate(BODY_AXES):
            ax.semilogy(*envelope(t, np.maximum(error[:, i], 1e-5)), label=f"axis {a}", lw=1.0)
    ax.axhline(POINTING_DEG, color="k", ls="--", lw=0.8)
    t_m, dipole = data.vectors(T.DIPOLE_COMMAND)
    dumps = DumpLog()
    for x, m in zip(t_m, dipole):
        dumps.add(x, m)
    for n, (start, end) in enumerate(dumps.done()):   # a dipole holds until the next reading's
        ax.axvspan(start, min(end + MAGNETOMETER_PERIOD, t[-1]) if len(t) else end, color="tab:blue", alpha=0.08,
                   label="momentum dumping" if n == 0 else None)
    marks = [(f.onset, f"{f.kind}", "k") for f in scenario.faults]
    marks += [(iv[0][0], f"verdict {a}", "tab:orange") for a, iv in verdict.get("verdict", {}).items() if iv]
    fdir = data.last(T.FDIR_WHEELS)
    for status in getattr(fdir, "status", []):
        values_ = {kv.key: kv.value for kv in status.values}
        if "since" in values_:
            marks.append((float(values_["since"]), f"{status.hardware_id.removeprefix('reaction_wheel_')} "
                          f"{values_['state'].replace('_', ' ')}", "tab:green"))
    # marks at one time (a verdict, a wheel given up, the standby brought in) get their labels side by side
    gap, last = 0.018 * (t[-1] - t[0] if len(t) > 1 else 1.0), -np.inf
    for x, label, color in sorted(marks, key=lambda m: m[0]):
        ax.axvline(x, color=color, lw=0.8, ls=":")
        last = max(x, last + gap)
        ax.text(last, POINTING_DEG * 3, f" {label}", fontsize=7, rotation=90, color=color, va="bottom")
    ax.set_title("pointing error [deg]: fault, verdict, reconfiguration" + (", momentum dumps (shaded)"
                                                                             if dumps.done() else ""), fontsize=10)
    ax.legend(fontsize=7, loc="lower left")
    ax.grid(alpha=0.3)
