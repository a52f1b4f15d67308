"""A run with the FDI half live: which wheel is faulty and since when, per observer, beside the truth."""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np


from ...fdi_config import FdiConfig
from ...core.scenario import parse_scenario
from ...core.spacecraft import BODY_AXES
from ...graph import topics as T
from ...storage.bag import read_series
from .. import bag_series, metrics
from .run import RunOutcome, run_scenario


def run_with_fdi(ref: str, seed=None, out_dir="bags", fdi=None, figure: bool = False, **kw) -> RunOutcome:
    """Run the full graph (plant, PIDs, wheel allocation, observers, isolation, recorder) with the FDI ``fdi``
    (FdiConfig or its mapping; None: the shipped one); attach the FDI verdict. ``fdi.fdir`` False: the wheel
    allocation keeps every wheel in use (detection alone)."""
    outcome = run_scenario(ref, seed=seed, out_dir=out_dir, fdi=FdiConfig.of(fdi), **kw)
    if outcome.bag.exists():
        try:
            data = read_series(outcome.bag, verdict_topics(FdiConfig.of(fdi).plugin_slots))
            outcome.summary = {**(outcome.summary or {}), "fdi": {**fdi_verdict(data),
                                                                  "health": bag_series.health_from_bag(outcome.bag)}}
            if figure:
                figure = outcome.bag.parent / f"{outcome.bag.name}_fdi.png"
                outcome.summary["figure"] = str(plot_residuals(data, figure))
        except Exception as exc:  # the run's own failure reason matters more
            if outcome.ok:
                outcome.ok, outcome.reason = False, f"reading FDI results: {exc}"
    return outcome


def verdict_topics(plugins=()) -> list:
    """What :func:`fdi_verdict` and :func:`plot_residuals` read of a bag (with the plug-in slots ``plugins``')."""
    from ...core.wheel_set import ALL_WHEEL_NAMES   # any set's Elman topics
    bounds = [T.bound_topic(obs, a) for obs in (*T.OBSERVERS, *plugins)
              for a in (ALL_WHEEL_NAMES if obs == "elman" else (None,))]
    return [T.SCENARIO, T.ATTITUDE, T.FDIR_WHEELS, T.DIPOLE_COMMAND, *bag_series.fdi_output_topics(plugins), *bounds]


def fdi_verdict(data) -> dict:
    """Per observer: alarm intervals per wheel from the recorded /fdi/<observer>/alarm and the shared
    verdict of the run (metrics.judge: correct, false alarm, delays); plus the truth.

    ``data``: a storage.bag BagSeries (or BagData) holding :func:`verdict_topics`."""
    scenario = parse_scenario(data.scenario_text or "{}", origin=f"{data.path}:/scenario")
    wheels = scenario.wheel_set(recorded=True).names
    out = {"truth": {a: [f.as_dict(wheels) for f in scenario.faults if wheels[f.wheel] == a] for a in wheels},
           "observers": bag_series.observers_in_bag(data)}
    for obs in out["observers"]:
        t, alarm = data.wheel_values(T.fdi_output_topics(obs)["alarm"])
        out[obs] = {a: metrics.alarm_intervals(t, alarm[:, i] > 0.5) for i, a in enumerate(wheels)}
    if "linear" in out["observers"] and "model" not in out["observers"]:
        _, bound = data.wheel_values(T.bound_topic("linear"))
        if bound.size and np.any(bound != 0):   # speed-aware without a model slot: an older bag
            out["note"] = ("recorded before the observers had three slots: its linear observer is the model "
                           "observer (the nominal wheel model), not the Luenberger observer")
    t_diag, faulty = bag_series.diagnostics_alarms(data.path)
    if len(t_diag):   # what /diagnostics said: the decision observer's alarm, latched
        out["verdict"] = {a: metrics.alarm_intervals(t_diag, faulty[:, i]) for i, a in enumerate(wheels)}
    out["identification"] = bag_series.identification_from_bag(data)
    try:
        series = bag_series.series_from_bag(data)
    except ValueError:   # no FDI outputs (a run stopped before the first sample): intervals only
        return out
    if len(t_diag):
        zeros = np.zeros(faulty.shape)
        series[metrics.VERDICT] = metrics.Series(t_diag, zeros, zeros, faulty)
    end = float(series[next(iter(series))].time[-1])
    # a run that stopped early (interrupted) is judged over the time it covers: a later fault is not missed
    out["not_reached"] = {"end_s": end, "faults": [f.as_dict(wheels) for f in scenario.faults if f.onset > end]}
    run = metrics.RunEval(bag=str(data.path), scenario=scenario.name, seed=scenario.seed,
                          faults=[f for f in scenario.faults if f.onset <= end], series=series, wheels=wheels)
    out["judged"] = {obs: metrics.judge(run, obs) for obs in series}
    return out


def health_lines(health: dict) -> list:
    """The FDI's own health in words, one line per status topic that had any."""
    lines = []
    for topic, wheels in health.items():
        who = "isolation (/diagnostics)" if topic == T.DIAGNOSTICS else observer_label(topic.split("/")[2])
        for axis, levels in sorted(wheels.items()):
            for level, seen in levels.items():
                what = "could not judge" if level == "cannot_judge" else "had input trouble in"
                lines.append(f"  health of the {who}, wheel {axis}: {what} {seen['samples']} sample"
                             f"{'s' if seen['samples'] > 1 else ''}, first at {seen['first_s']:g} s: "
                             f"{seen['message']}")
    return lines


def judged_line(v: dict) -> str:
    """One observer's shared verdict in words: what `rw-fdi evaluate` and `rw-fdi screen` count."""
    if v.get("false_alarm"):
        return f"false alarm on {', '.join(v['alarmed_wheels'])}"
    if "correct" not in v:
        return "no alarm"
    if v["correct"]:
        return "correct, " + ", ".join(f"{a} after {f['delay']:.0f} s" for a, f in v["axes"].items())
    missed = [a for a, f in v["axes"].items() if not f["detected"]]
    parts = ([f"missed {', '.join(missed)}"] if missed else []) + \
        ([f"alarmed healthy {', '.join(v['wrong_axes'])}"] if v["wrong_axes"] else [])
    return "wrong: " + "; ".join(parts)


def observer_label(observer: str) -> str:
    """What a person calls the observer in the ``observer`` slot (core/detection.OBSERVERS): the Elman
    network, the Luenberger observer of the linearised wheel (thesis 3.3), the nominal wheel model at
    the measured command and speed."""
    return "verdict (/diagnostics)" if observer == "verdict" else f"{observer} observer"


def format_verdict(v: dict) -> str:
    def fmt(intervals):
        if not intervals:
            return "healthy"
        parts = []
        for s, e in intervals:
            parts.append(f"faulty from {s:g} s" + (f" to {e:g} s (alarm lost)" if e is not None else ""))
        return "; ".join(parts)

    observers = v.get("observers", [o for o in T.OBSERVERS if o in v]) + (["verdict"] if "verdict" in v else [])
    wheels = list(v["truth"])
    truths = {a: "; ".join(f"{f['kind']}={f['value']:g} from {f['onset']:g} s" for f in v["truth"][a]) or "healthy"
              for a in wheels}
    columns = [("ground truth", truths)] + [(observer_label(o), {a: fmt(v[o][a]) for a in wheels}) for o in observers]
    widths = [max(34, *(len(c) + 2 for c in cells.values())) for _, cells in columns]
    lines = [(f"  {'wheel':6s}" + "".join(f"{h:{w}s}" for (h, _), w in zip(columns, widths))).rstrip()]
    for a in wheels:
        lines.append((f"  {a:6s}" + "".join(f"{cells[a]:{w}s}" for (_, cells), w in zip(columns, widths))).rstrip())
    if v.get("note"):
        lines.append(f"  note: {v['note']}")
    for a, found in v.get("identification", {}).items():
        lines.append(f"  identified on wheel {a}: {found['message']}")
    for obs, judged in v.get("judged", {}).items():
        who = "/diagnostics, the verdict users read" if obs == "verdict" else f"verdict of the {observer_label(obs)}"
        lines.append(f"  {who}: {judged_line(judged)}")
    later = v.get("not_reached", {}).get("faults")
    if later:
        lines.append(f"  the run ended at {v['not_reached']['end_s']:g} s, before "
                     + ", ".join(f"{f['kind']}={f['value']:g} on {f['wheel']} from {f['onset']:g} s" for f in later)
                     + ": not judged")
    health = v.get("health")
    if health is not None:
        lines += health_lines(health) or ["  health: every sample judged, no input trouble"]
    return "\n".join(lines)


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
        _, bound = bag_series.observer_vectors(data, obs, T.bound_topic, wheels=tuple(wheels))
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
    from ...core.environment import MAGNETOMETER_PERIOD
    from ...core.magnetorquers import DumpLog
    from ...core.scenario import setpoint_at
    from .summary import POINTING_DEG
    scenario = parse_scenario(data.scenario_text or "{}", origin=f"{data.path}:/scenario")
    times, values = scenario.setpoint_schedule()
    t, attitude, _, _ = data.joint_states(T.ATTITUDE)
    if len(t):
        error = np.degrees(np.abs(attitude - np.array([setpoint_at(times, values, x) for x in t])))
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
    for x, label, color in marks:
        ax.axvline(x, color=color, lw=0.8, ls=":")
        ax.text(x, POINTING_DEG * 3, f" {label}", fontsize=7, rotation=90, color=color, va="bottom")
    ax.set_title("pointing error [deg]: fault, verdict, reconfiguration" + (", momentum dumps (shaded)"
                                                                             if dumps.done() else ""), fontsize=10)
    ax.legend(fontsize=7, loc="lower left")
    ax.grid(alpha=0.3)
