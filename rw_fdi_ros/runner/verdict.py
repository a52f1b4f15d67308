"""A recorded run's FDI verdict: which wheel is faulty and since when, per observer, beside the truth, judged
and told in words."""
from __future__ import annotations

import numpy as np

from ..core.mission.scenario import parse_scenario
from ..graph import topics as T
from ..scoring import bag_series, metrics


def verdict_topics(plugins=()) -> list:
    """What :func:`fdi_verdict` and :func:`plot_residuals` read of a bag (with the plug-in slots ``plugins``')."""
    bounds = bag_series.any_wheel_topics("ripple_bound", (*T.OBSERVERS, *plugins))
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
        _, bound = data.wheel_values(T.observer_topic("linear", "ripple_bound"))
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
    """What a person calls the observer in the ``observer`` slot (core/fdi/detection.OBSERVERS): the Elman
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
