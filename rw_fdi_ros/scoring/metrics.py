"""Evaluation figures of evaluation.md from FDI outputs and ground truth (pure functions, no ROS).

A run is judged from the series the isolation node publishes (residual,
threshold, alarm per observer and axis) and from its scenario (ground
truth). Definitions (evaluation.md, our choices where it is open):
- detected: the faulty axis alarms at or after onset;
- detection delay: first alarm at or after onset - onset;
- time above threshold: length of the first alarm interval after onset
  (to the end of the run if never lost): the thesis' "detection time";
- gap [N m]: detected: largest residual - threshold after onset;
  missed: smallest threshold - residual after onset;
- correct: every faulty axis detected and no other axis alarmed at any time;
- false alarm (fault-free, ripple runs): any axis alarmed at any time;
  also, over the faulty runs, any alarm before the onset (their fault-free part).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.fdi.identification import NONE, UNKNOWN, Identification
from ..core.fdi.residuals import speed_noise_reach
from ..core.mission.plant_choices import FDI_PERIOD
from ..core.physics.faults import NOMINAL_VALUES
from ..core.physics.wheel_set import AXIS_WHEELS, fitted_for
from ..graph import topics as T

OBSERVERS = T.OBSERVERS
DISTURBANCE_KINDS = ("ripple_gain",)   # changes that must not alarm


@dataclass
class Series:
    time: np.ndarray
    residual: np.ndarray    # (n, N): one column per wheel of the run (RunEval.wheels)
    threshold: np.ndarray   # (n, N)
    alarm: np.ndarray       # (n, N) bool


@dataclass
class RunEval:
    bag: str
    scenario: str
    seed: int
    faults: list                      # Fault objects
    series: dict                      # observer -> Series
    fault_effect_peak: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (N,) after onset [N m]
    # wheel -> the last fault identification of an alarmed wheel (its /diagnostics values, strings)
    identification: dict = field(default_factory=dict)
    # what the FDI said about itself (health_from_bag): status topic -> wheel -> cannot_judge / input_trouble
    health: dict = field(default_factory=dict)
    wheels: tuple = AXIS_WHEELS   # the run's wheel names (its wheel set's), the order of the series' columns
    # FDIR's acts, [(time [s], wheel, action, reason)] (fdir.Decision; the graph's /fdir/wheels states)
    reconfiguration: list = field(default_factory=list)

    @property
    def faulty_wheels(self):
        return sorted({self.wheels[f.wheel] for f in self.faults if f.kind not in DISTURBANCE_KINDS})

    @property
    def onset(self):
        return min((f.onset for f in self.faults), default=None)

    @property
    def category(self) -> str:
        kinds = {f.kind for f in self.faults}
        if not kinds:
            return "fault_free"
        if kinds <= set(DISTURBANCE_KINDS):
            return "disturbance"
        return "multiple" if len(self.faulty_wheels) > 1 else "single"


def observers_of_runs(runs) -> list:
    """The observer slots every one of ``runs`` was judged by, in slot order, then ``verdict`` (what
    /diagnostics says) where the runs hold it.

    Parameters
    ----------
    runs : list of RunEval
        The judged runs.

    Returns
    -------
    list of str
        The slots (of OBSERVERS, the plug-ins', then VERDICT); empty for no runs.
    """
    extra = sorted({k for r in runs for k in r.series if k.startswith(VERDICT + " ")})   # other decisions'
    plugins = sorted({k for r in runs for k in r.series} - {*OBSERVERS, VERDICT, *extra})   # a user's observers
    return [obs for obs in (*OBSERVERS, *plugins, VERDICT, *extra) if runs and all(obs in r.series for r in runs)]


VERDICT = "verdict"   # the series of /diagnostics' verdict beside the observers' (offline.judge)


def decision_slot(label: str) -> str:
    """The series of the verdict another decision (core/fdi/verdict.DecisionRule.label, e.g. '2of3') would give,
    judged beside the run's own: 'verdict 2of3'."""
    return f"{VERDICT} {label}"


def health_rows(runs) -> list:
    """One row per run, status topic, wheel and kind where the FDI could not judge or had input trouble.

    Parameters
    ----------
    runs : list of RunEval
        The judged runs.

    Returns
    -------
    list of dict
        bag (its name), topic, wheel, kind ('cannot_judge' or 'input_trouble') and what
        bag_series.health_from_bag saw: samples, first_s [s], message.
    """
    return [{"bag": Path(r.bag).name, "topic": topic, "wheel": axis, "kind": kind, **seen}
            for r in runs for topic, wheels in r.health.items() for axis, kinds in sorted(wheels.items())
            for kind, seen in kinds.items()]


def axis_figures(s: Series, i: int, onset: float) -> dict:
    """Detection figures of one axis after ``onset``.

    Parameters
    ----------
    s : Series
        One observer's series of a run, (n, N) each.
    i : int
        The column of the wheel (its index in the run's wheels).
    onset : float
        The fault's onset [s].

    Returns
    -------
    dict
        detected (bool), delay [s] and time_above [s] (None where not detected), held_to_end (bool, only
        where detected), gap [N m] (largest residual - threshold where detected, smallest threshold - residual
        where not; None without samples after onset).
    """
    after = s.time >= onset
    alarm = s.alarm[:, i] & after
    gap = s.residual[after, i] - s.threshold[after, i]
    if not alarm.any():
        return {"detected": False, "delay": None, "time_above": None,
                "gap": float(-gap.max()) if gap.size else None}
    start, end = alarm_intervals(s.time, alarm)[0]
    t_end = s.time[-1] if end is None else end
    return {"detected": True, "delay": float(start - onset), "time_above": float(t_end - start),
            "held_to_end": end is None, "gap": float(gap.max())}


def alarm_intervals(times, flags) -> list:
    """[(start, end)] of the alarm flag series, end None for an alarm still up at the last sample:
    the one definition of an alarm interval (detection, time above threshold, held to end, and
    `rw-fdi run`'s verdict).

    Parameters
    ----------
    times : array_like, shape (n,)
        Sample times [s].
    flags : array_like of bool, shape (n,)
        The alarm at each sample.

    Returns
    -------
    list of tuple (float, float or None)
        (start [s], end [s]) per interval, end the first sample without the alarm, or None.
    """
    out, start = [], None
    for t, f in zip(times, flags):
        if f and start is None:
            start = float(t)
        elif not f and start is not None:
            out.append((start, float(t)))
            start = None
    if start is not None:
        out.append((start, None))
    return out


def judge(run: RunEval, observer: str) -> dict:
    """Verdict of one run for one observer: alarms per axis, correctness, per-faulty-axis figures.

    Parameters
    ----------
    run : RunEval
        One judged run.
    observer : str
        The series to judge: an observer slot of OBSERVERS, or VERDICT.

    Returns
    -------
    dict
        alarmed_wheels (list of str), false_alarm (bool); for a faulty run also axes (wheel -> the
        :func:`axis_figures` at its first onset), wrong_axes (list of str) and correct (bool).
    """
    s = run.series[observer]
    alarmed = [a for i, a in enumerate(run.wheels) if s.alarm[:, i].any()]
    out = {"alarmed_wheels": alarmed, "false_alarm": bool(alarmed) and run.category in ("fault_free", "disturbance")}
    if run.category in ("single", "multiple"):
        figures = {}
        for a in run.faulty_wheels:
            onset = min(f.onset for f in run.faults if run.wheels[f.wheel] == a)
            figures[a] = axis_figures(s, run.wheels.index(a), onset)
        others = [a for a in alarmed if a not in run.faulty_wheels]
        out["axes"] = figures
        out["wrong_axes"] = others
        out["correct"] = all(f["detected"] for f in figures.values()) and not others
    return out


def run_row(run: RunEval) -> dict:
    """One run as a flat record (a table row: tools/benches/kit.write_runs_table): seed, scenario, faults,
    each observer's verdict (alarmed wheels, correct, false alarm, first delay) and the identification.

    Parameters
    ----------
    run : RunEval
        One judged run.

    Returns
    -------
    dict
        seed, scenario, category, faults (kind, wheel, onset [s], value, ramp [s]), per observer
        alarmed, false_alarm, correct and delay_s [s], and identification (wheel -> kind, size, size_low,
        size_high, as recorded: strings; Identification.brief).
    """
    row = {"seed": run.seed, "scenario": run.scenario, "category": run.category,
           "faults": [{"kind": f.kind, "wheel": run.wheels[f.wheel], "onset": f.onset, "value": f.value,
                       "ramp": f.ramp} for f in run.faults]}
    for obs in observers_of_runs([run]):
        v = judge(run, obs)
        delays = [f["delay"] for f in v.get("axes", {}).values() if f["detected"]]
        row[obs] = {"alarmed": v["alarmed_wheels"], "false_alarm": v["false_alarm"], "correct": v.get("correct"),
                    "delay_s": min(delays) if delays else None}
    found = {wheel: Identification.from_values(values) for wheel, values in sorted(run.identification.items())}
    row["identification"] = {wheel: f.brief() for wheel, f in found.items() if f is not None}
    if run.reconfiguration:   # FDIR acted in the loop (screen --fdir)
        row["reconfiguration"] = [{"time_s": t, "wheel": w, "action": a, "reason": r}
                                  for t, w, a, r in run.reconfiguration]
    return row


def size_tolerance(kind: str, value: float, strict_bus: bool = False) -> float:
    """Temperature within 10 C, limiter share and bus voltage within 10 % of the true value (``strict_bus``:
    the bus within 0.1 V, the target of the units and operations benches).

    Parameters
    ----------
    kind : str
        The scenario's fault kind ('temperature', 'current_limiter', 'bus_voltage').
    value : float
        The true value, in the kind's unit ([C], share, [V]).
    strict_bus : bool
        Hold the bus voltage to 0.1 V where that is tighter than 10 %.

    Returns
    -------
    float
        The largest admitted |estimate - truth|, in the kind's unit.
    """
    if kind == "temperature":
        return 10.0
    return min(0.1, 0.1 * abs(value)) if strict_bus and kind == "bus_voltage" else 0.1 * abs(value)


def size_at(fault, at_s: float, nominal: dict | None = None) -> float:
    """The truth an identified size is judged against: the fault's value at the identification's last sample
    (``at_s``, its stamp; the middle of that FDI period), a ramp's value then where it was still growing or its
    wheel's driver was switched off before it ended; the final value where the time is not known.

    Parameters
    ----------
    fault : Fault
        The scenario's fault (kind, onset [s], value in the kind's unit, ramp [s]).
    at_s : float
        The identification's stamp [s]; NaN where not known.
    nominal : dict or None
        The wheel type's healthy values (faults.nominal_values: a ramp starts from its bus); None: the thesis'.

    Returns
    -------
    float
        The fault's value at ``at_s`` - FDI_PERIOD / 2, in the kind's unit.
    """
    if not np.isfinite(at_s):
        return float(fault.value)
    return float(fault.value_at(float(at_s) - 0.5 * FDI_PERIOD, *([nominal] if nominal else [])))


def judge_size(fault, size: float, low: float, high: float, at_s: float = float("nan"),
               strict_bus: bool = False, nominal: dict | None = None) -> dict:
    """size_error (estimate - truth, in the kind's unit), size_right (within :func:`size_tolerance`), covered
    (truth inside [low, high]) of an identification of the right kind (truth: :func:`size_at`).

    Parameters
    ----------
    fault : Fault
        The scenario's fault (kind, onset [s], value in the kind's unit, ramp [s]).
    size, low, high : float
        The identified size and its interval, in the kind's unit.
    at_s : float
        The identification's stamp [s]; NaN where not known.
    strict_bus : bool
        Passed to :func:`size_tolerance`.

    nominal : dict or None
        As :func:`size_at`.
    Returns
    -------
    dict
        size, truth, size_error (float, in the kind's unit), size_right, covered (bool).
    """
    truth = size_at(fault, at_s, nominal)
    return {"size": float(size), "truth": truth, "size_error": float(size) - truth,
            "size_right": bool(abs(size - truth) <= size_tolerance(fault.kind, truth, strict_bus)),
            "covered": bool(low <= truth <= high)}


def judge_identification(run: RunEval, strict_bus: bool = False) -> dict:
    """Per faulty wheel with one fault: the last identification against the truth.

    kind_right, size_error (estimate - truth, in the kind's unit), size_right (within
    :func:`size_tolerance`), covered (truth inside [low, high]); identified False when the
    wheel was never alarmed or the kind stayed 'unknown'.

    Parameters
    ----------
    run : RunEval
        One judged run.
    strict_bus : bool
        Passed to :func:`size_tolerance`.

    Returns
    -------
    dict of str to dict
        Wheel -> true_kind, kind, identified, kind_right and, where the kind is right, the
        :func:`judge_size` figures; disturbances and wheels with more than one fault left out.
    """
    out = {}
    for f in run.faults:
        a = run.wheels[f.wheel]
        if f.kind in DISTURBANCE_KINDS or sum(g.wheel == f.wheel for g in run.faults) > 1:
            continue
        found = Identification.from_values(run.identification.get(a) or {})
        kind = NONE if found is None else found.kind
        row = {"true_kind": f.kind, "kind": kind, "identified": kind not in (NONE, UNKNOWN),
               "kind_right": kind == f.kind}   # the identifier names a kind as the scenario does
        if row["kind_right"]:
            nominal = {**NOMINAL_VALUES, "bus_voltage": found.bus_nominal}   # a ramp from the wheel's own bus
            row.update(judge_size(f, found.size, found.low, found.high, found.at_s, strict_bus, nominal))
        out[a] = row
    return out


def reliability(runs, curves_seeds, observer: str) -> dict:
    """Share of fitting runs (seed in the curves' seeds, fault-free) under the curve at every point.

    Parameters
    ----------
    runs : list of RunEval
        The judged runs.
    curves_seeds : iterable of int
        The seeds the threshold curves were fitted on.
    observer : str
        The observer slot.

    Returns
    -------
    dict
        runs (int), seeds (list of int) and per wheel of the runs the share (0..1) whose residual stayed at
        or under the threshold at every sample; only ``{"runs": 0}`` without a fitting run.
    """
    fit = [r for r in runs if r.category == "fault_free" and r.seed in set(curves_seeds)]
    if not fit:
        return {"runs": 0}
    out = {"runs": len(fit), "seeds": [r.seed for r in fit]}
    for i, a in enumerate(fit[0].wheels):   # the run's wheels, a standby one included
        out[a] = float(np.mean([np.all(r.series[observer].residual[:, i] <= r.series[observer].threshold[:, i])
                                for r in fit]))
    return out


def fault_label(run: RunEval) -> tuple:
    """(kind, size) of a single-kind run, sizes as the thesis states them.

    Parameters
    ----------
    run : RunEval
        One judged run.

    Returns
    -------
    tuple of (str, str)
        The kind and its first fault's size as text; ('multiple', the kinds joined by '+') for several kinds.
    """
    kinds = sorted({f.kind for f in run.faults})
    if len(kinds) != 1:
        return ("multiple", "+".join(kinds))
    f = run.faults[0]
    sev = severity(f.kind, f.value)
    if f.kind == "bus_voltage":
        return ("bus_voltage", f"{round(sev)}% off ({f.value:g} V)")
    if f.kind == "current_limiter":
        return ("current_limiter", f"{round(sev)}% loss")
    if f.kind == "temperature":
        return ("temperature", f"+{sev:g} C")
    return (f.kind, f"+{round(sev)}%")


def severity(kind: str, value: float) -> float:
    """How far a fault is from nominal in the thesis' own units: % off, % loss, degrees C, % ripple.

    Parameters
    ----------
    kind : str
        The fault kind ('bus_voltage', 'current_limiter', 'temperature', else a ripple gain).
    value : float
        The fault's value: bus voltage [V], current share, temperature [C] or ripple gain.

    Returns
    -------
    float
        % under 8 V, % current lost, [C] over 23 C, or % ripple over nominal.
    """
    if kind == "bus_voltage":
        return 100.0 * (1.0 - value / 8.0)
    if kind == "current_limiter":
        return 100.0 * (1.0 - value)
    if kind == "temperature":
        return value - 23.0
    return 100.0 * (value - 1.0)


def _rate(flags):
    flags = list(flags)
    return {"rate": float(np.mean(flags)) if flags else None, "n": len(flags)}


def alarm_before_onset(run: RunEval, observer: str) -> bool:
    """Any alarm in the fault-free first part of a faulty run: a false alarm there.

    Parameters
    ----------
    run : RunEval
        A run with at least one fault (an onset).
    observer : str
        The series to judge: an observer slot of OBSERVERS, or VERDICT.

    Returns
    -------
    bool
        Whether any wheel alarmed before the first onset.
    """
    if run.onset is None:   # a fault-free run has no before: its alarms are false_alarm's
        return False
    s = run.series[observer]
    return bool(s.alarm[s.time < run.onset].any())


def observable(run: RunEval, level: dict) -> bool:
    """Every faulty wheel's recorded fault effect peaks above ``level[axis]``, the fault-free residual
    level [N m]: a fault below it is physically invisible, not missed by the observer.

    Parameters
    ----------
    run : RunEval
        One judged run.
    level : dict of str to float
        Fitted wheel -> fault-free residual level [N m] (:func:`observable_level`).

    Returns
    -------
    bool
        Whether every faulty wheel's fault effect peak [N m] exceeds its level (True without faulty wheels).
    """
    return all(run.fault_effect_peak[run.wheels.index(a)] > max(level[k] for k in fitted_for(a, level))
               for a in run.faulty_wheels)


def observable_level(curves: dict, wheel=None) -> dict:
    """axis -> the fault-free residual level [N m] a fault effect must rise above to count as observable
    (:func:`observable`), one physical criterion for every observer of an FDI set (``curves``: observer ->
    ThresholdCurves): the largest of the observers' median thresholds after the manoeuvre (a band may be
    negative: it is a level over the ripple bound, not a residual level), plus the tachometer's noise floor
    s / n of a full window (residuals.speed_noise_reach) that every threshold carries above its band. With
    the model observer in the set the Luenberger observer is left out: its band is its linearised model's
    own error, not what the wheel shows.

    Parameters
    ----------
    curves : dict of str to ThresholdCurves
        Observer -> its threshold curves [N m], of one FDI set.
    wheel : WheelParams, optional
        The fitted wheel type (its ``speed_noise`` and ``inertia``); None: exact speeds, no noise floor.

    Returns
    -------
    dict of str to float
        Fitted wheel -> level [N m].
    """
    judges = [c for obs, c in curves.items() if obs != "linear" or "model" not in curves]
    # why: where speeds are read with noise, a torque derived from them cannot show less than its floor,
    # whatever the band (Basilisk's HR16: a band of 0 above a floor of 0.084 mN m)
    floor = speed_noise_reach(wheel, judges[0].sample_period) / judges[0].window
    return {a: floor + max(float(np.median(c.curves[a][60:] if len(c.curves[a]) > 60 else c.curves[a]))
                           for c in judges)
            for a in judges[0].curves}   # the fitted wheels; another of their type: observable()


def aggregate(runs, curves_seeds: dict, observable_level: dict, training_seeds=(), observers=None) -> dict:
    """All figures per observer (``observers``, default those every run was judged by);
    ``observable_level[obs][axis]``: the fault-free residual level [N m].

    Held-out runs are fault-free runs the thresholds were not fitted on and the models not trained on.

    Parameters
    ----------
    runs : list of RunEval
        The judged runs.
    curves_seeds : dict of str to list of int
        Observer -> the seeds its threshold curves were fitted on.
    observable_level : dict of str to dict of str to float
        Observer -> wheel -> fault-free residual level [N m] (:func:`observable_level`).
    training_seeds : iterable of int
        The seeds the models were trained on.
    observers : iterable of str, optional
        The series to report; None: :func:`observers_of_runs`.

    Returns
    -------
    dict of str to dict
        Observer -> reliability, false alarm rates (held-out, disturbance, before onset) and faults: one
        cell per (kind, size) with rates, delays and times above [s] and gaps [mN m].
    """
    report = {}
    for obs in observers_of_runs(runs) if observers is None else observers:
        verdicts = {r.bag: judge(r, obs) for r in runs}
        rep = {"reliability": reliability(runs, curves_seeds.get(obs, []), obs)}
        used = set(curves_seeds.get(obs, [])) | set(training_seeds)
        heldout = [r for r in runs if r.category == "fault_free" and r.seed not in used]
        rep["false_alarm_heldout"] = {**_rate(verdicts[r.bag]["false_alarm"] for r in heldout),
                                      "seeds": [r.seed for r in heldout]}
        dist = [r for r in runs if r.category == "disturbance"]
        rep["false_alarm_disturbance"] = {**_rate(verdicts[r.bag]["false_alarm"] for r in dist),
                                          "seeds": [r.seed for r in dist]}
        # the fault-free first part of every faulty run: at thesis scale 11x the held-out runs' fault-free time
        faulty = [r for r in runs if r.category in ("single", "multiple")]
        early = [alarm_before_onset(r, obs) for r in faulty]
        rep["false_alarm_before_onset"] = {**_rate(early),
                                           "alarmed_seeds": [r.seed for r, e in zip(faulty, early) if e]}
        rep["faults"] = _fault_cells(faulty, verdicts, observable_level[obs])
        report[obs] = rep
    return report


def _fault_cells(faulty, verdicts: dict, level: dict) -> list:
    """One cell per fault (kind, size) of the ``faulty`` runs, by kind and severity: rates, delays, times above
    [s], gaps [mN m]; ``level``: wheel -> the fault-free residual level [N m] (what is observable)."""
    groups = {}
    for r in faulty:
        groups.setdefault(fault_label(r), []).append(r)

    def order(item):
        (kind, _), members = item
        return kind, max(severity(f.kind, f.value) for f in members[0].faults)
    cells = []
    for (kind, size), members in sorted(groups.items(), key=order):
        v = [verdicts[r.bag] for r in members]
        seen = [r for r in members if observable(r, level)]
        figs = [f for x in v for f in x["axes"].values()]
        det = [f for f in figs if f["detected"]]
        cells.append({
            "kind": kind, "size": size, "runs": len(members), "seeds": [r.seed for r in members],
            "severity": None if kind == "multiple" else severity(members[0].faults[0].kind,
                                                                 members[0].faults[0].value),
            "axes": sorted({a for r in members for a in r.faulty_wheels}),
            "correctness": _rate(x["correct"] for x in v),
            "correctness_observable": _rate(verdicts[r.bag]["correct"] for r in seen),
            "detected": _rate(f["detected"] for f in figs),
            "delay_s": _stats([f["delay"] for f in det]),
            "time_above_s": _stats([f["time_above"] for f in det]),
            "held_to_end": _rate(f["held_to_end"] for f in det),
            "gap_detected_mNm": _stats([f["gap"] * 1e3 for f in det]),
            "gap_missed_mNm": _stats([f["gap"] * 1e3 for f in figs if not f["detected"] and f["gap"] is not None]),
            "wrong_axis_runs": int(sum(bool(x["wrong_axes"]) for x in v)),
        })
    return cells


def identification_figures(runs) -> list:
    """Per (kind, size) of the single-fault runs: how often the identified kind was right and how
    close the size was (:func:`judge_identification` on each faulty wheel).

    Parameters
    ----------
    runs : list of RunEval
        The judged runs.

    Returns
    -------
    list of dict
        One cell per (kind, size): wheels, rates of identified, kind_right and size_right, abs_size_error
        (in the kind's unit) and how often each kind was identified.
    """
    groups = {}
    for r in runs:
        if r.category == "single":
            groups.setdefault(fault_label(r), []).extend(judge_identification(r).values())
    cells = []
    for (kind, size), rows in sorted(groups.items()):
        right = [v for v in rows if v["kind_right"]]
        cells.append({"kind": kind, "size": size, "wheels": len(rows),
                      "identified": _rate(v["identified"] for v in rows),
                      "kind_right": _rate(v["kind_right"] for v in rows),
                      "size_right": _rate(v["size_right"] for v in right),
                      "abs_size_error": _stats([abs(v["size_error"]) for v in right]),
                      "identified_as": {k: sum(v["kind"] == k for v in rows)
                                        for k in sorted({v["kind"] for v in rows})}})
    return cells


def _stats(values):
    values = [v for v in values if v is not None]
    if not values:
        return None
    a = np.asarray(values, float)
    return {"median": float(np.median(a)), "min": float(a.min()), "max": float(a.max()), "n": len(a),
            "values": [float(v) for v in a]}


def wilson(k: int, n: int, z: float = 1.96):
    """95 % Wilson score interval of k successes in n trials."""
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def rate(flags) -> dict:
    """k of n flags set, the share and its 95 % Wilson interval."""
    flags = [bool(f) for f in flags]
    k, n = sum(flags), len(flags)
    lo, hi = wilson(k, n)
    return {"k": k, "n": n, "rate": k / n if n else None, "ci95": [lo, hi]}
