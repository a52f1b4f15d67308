"""What each observer of a new FDI catches, and why one misses (`rw-fdi defaults --vehicle`, its last stage).

Every observer must hold up on its own (docs/fdi.md "Each observer on its own"): right on 10 % current losses
and +30 C. The FDI just made judges such runs of its vehicle on the core loop (datasheet wheels, manoeuvres every
100-300 s, one fault on a wheel in use at 60-300 s); an observer that misses some is named with the measured
cause, the residual of its worst miss beside the model observer's, and a figure of it. A small sample: it says
where an observer falls short, the figures of record are `rw-fdi bench operations --vehicle DIR`'s.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ...core.fdi.linear_observer import LinearObserver, steady_fault_gain
from ...core.mission.scenario import Manoeuvres, load_scenario
from ...core.physics.faults import drawn_fault, nominal_values
from ...core.physics.wheel import linearised_wheel
from ...core.physics.wheel_set import fitted_for
from ...scoring.metrics import judge as judge_verdict, observable, observable_level, wilson
from .offline import judge_run
from .samples import simulated_runs

GOAL = 0.99   # right on the faults below, each observer alone (the goal of docs/fdi.md)
ONSETS = (60.0, 300.0)                         # [s] the fault's onset, drawn from the seed
MANOEUVRES = Manoeuvres(interval_s=(100.0, 300.0))   # the operations bench's 400-s runs


def fault_cases(wheel_params) -> tuple:
    """(name, kind, value) of the faults every observer must see on wheels of the type ``wheel_params``."""
    return (("current loss 10 %", "current_limiter", 0.9),
            ("temperature +30 C", "temperature", nominal_values(wheel_params)["temperature"] + 30.0))


def fault_scenarios(fault_free_path, kind: str, value: float, seeds) -> list:
    """The vehicle's fault-free scenario with manoeuvres and one fault of ``kind`` of ``value`` per seed, on a
    wheel in use (benches' fault_wheel) at an onset drawn from the seed in ONSETS."""
    base = replace(load_scenario(fault_free_path), manoeuvres=MANOEUVRES)
    return [base.with_seed(s).with_faults([drawn_fault(kind, value, s, base.wheel_set(), ONSETS)]) for s in seeds]


def check_observers(fault_free_path, wheel_params, models: dict, curves: dict, seeds, out_dir) -> dict:
    """case -> observer -> {right, runs, ci95, worst miss, why} for the faults of :func:`fault_cases` on the runs
    of ``seeds``, judged by ``models`` and ``curves`` (observer -> ThresholdCurves); figures of the misses
    under ``out_dir``.

    Parameters
    ----------
    fault_free_path : path
        The vehicle's fault-free scenario (vehicle_defaults.vehicle_scenarios).
    wheel_params : WheelParams
        The vehicle's wheel type (the +30 C is of its nominal temperature).
    models : dict
        The FDI's networks (offline.load_models).
    curves : dict
        observer -> ThresholdCurves: the datasheet bands just fitted.
    seeds : sequence of int
        One run per seed and case.
    out_dir : path
        Where the figures of misses go (``observer_misses/``).

    Returns
    -------
    dict
        case -> observer -> figures; ``why`` only where an observer missed.
    """
    out = {}
    level = observable_level(curves, wheel_params)   # the benches' criterion of a fault the physics hides
    for case, kind, value in fault_cases(wheel_params):
        scenarios = fault_scenarios(fault_free_path, kind, value, seeds)
        runs = [judge_run(sc, samples, peak, models, curves) for sc, samples, peak in simulated_runs(scenarios)]
        seen = [observable(r, level) for r in runs]   # the rest: no observer's miss (metrics.observable)
        visible = [r for r, ok in zip(runs, seen) if ok]
        hidden = [r for r, ok in zip(runs, seen) if not ok]
        invisible = {"runs": len(hidden), "of": len(runs), "why": invisible_why(hidden, level)}
        out[case] = {}
        for obs in curves:
            right = [bool(judge_verdict(r, obs)["correct"]) for r in visible]
            entry = {"right": sum(right), "runs": len(visible), "ci95": list(wilson(sum(right), len(visible))),
                     "invisible": invisible}
            missed = [r for r, ok in zip(visible, right) if not ok]
            if missed:
                peak, worst = min(((_signal_to_band(r, obs), r) for r in missed), key=lambda x: x[0])
                entry["worst_miss"] = {"seed": worst.seed, "wheel": worst.faulty_wheels[0], "peak_over_band": peak,
                                       "model_peak_over_band": _signal_to_band(worst, "model")
                                       if "model" in worst.series and obs != "model" else None,
                                       "figure": str(plot_miss(worst, obs, Path(out_dir) / "observer_misses",
                                                               case))}
                entry["why"] = why_missed(obs, entry["worst_miss"])
            out[case][obs] = entry
    return out


def invisible_why(hidden, level: dict) -> str | None:
    """Why the ``hidden`` runs (not observable) cannot be judged: their largest fault torque against the
    fault-free level it had to rise above (metrics.observable_level: the band and the tachometer's noise
    floor); None without such runs."""
    if not hidden:
        return None
    peak = max(float(r.fault_effect_peak[r.wheels.index(a)]) for r in hidden for a in r.faulty_wheels)
    floor = min(max(level[k] for k in fitted_for(a, level)) for r in hidden for a in r.faulty_wheels)
    return (f"the fault changes its wheel's torque by at most {peak * 1e3:.3g} mN m, under the "
            f"{floor * 1e3:.3g} mN m a fault-free residual already reaches (the band and the tachometer's noise "
            "over the window): physically invisible here, no observer's miss")


def _signal_to_band(run, obs: str) -> float:
    """The largest |r| / threshold of the faulty wheel after the onset: below 1, the observer cannot see it."""
    s, i = run.series[obs], run.wheels.index(run.faulty_wheels[0])
    after = s.time >= run.onset
    return float(np.max(s.residual[after, i] / np.maximum(s.threshold[after, i], 1e-30))) if after.any() else 0.0


def why_missed(obs: str, worst: dict) -> str:
    """The cause of an observer's misses among runs whose fault is observable, measured (its worst miss's peak
    residual over its band, the model observer's on the same run), and for the Luenberger observer its closed
    form."""
    said = (f"its residual peaked at {worst['peak_over_band']:.2f} of its band on its worst miss (seed "
            f"{worst['seed']}, wheel {worst['wheel']})")
    if worst.get("model_peak_over_band") is not None:
        said += f", where the model observer's reached {worst['model_peak_over_band']:.1f}"
    if obs == "linear":
        observer = LinearObserver(wheel=linearised_wheel())
        gain = steady_fault_gain(observer.model)
        said += (f": the Luenberger observer's output injection (its pole at {1 / gain:.3g}x the wheel's) settles "
                 f"onto the faulty torque and leaves A / (A - L C) = {gain:.2f} of a steady error in its residual, "
                 "under a band that carries the linearisation's error in slews (kappa x demand; "
                 "core/fdi/linear_observer.steady_fault_gain)")
    return said


def plot_miss(run, obs: str, folder: Path, case: str) -> Path:
    """|residual| against threshold of the faulty wheel, ``obs`` beside the model observer, onset marked."""
    from matplotlib.figure import Figure
    folder.mkdir(parents=True, exist_ok=True)
    a = run.faulty_wheels[0]
    i = run.wheels.index(a)
    shown = [o for o in (obs, "model") if o in run.series][:2 if obs != "model" else 1]
    fig = Figure(figsize=(9, 2.8 * len(shown)))
    for row, o in enumerate(shown):
        ax = fig.add_subplot(len(shown), 1, row + 1)
        s = run.series[o]
        ax.semilogy(s.time, np.maximum(s.residual[:, i], 1e-9) * 1e3, lw=1, label="|residual|")
        ax.semilogy(s.time, s.threshold[:, i] * 1e3, "--", color="tab:red", lw=1, label="threshold")
        ax.axvline(run.onset, color="k", lw=0.8)
        ax.set_title(f"{o} observer, wheel {a}: {case} at {run.onset:g} s (seed {run.seed})", fontsize=9)
        ax.set_ylabel("10⁻³ N m")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    ax.set_xlabel("time [s]")
    fig.tight_layout()
    path = folder / f"{obs}_{case.split()[0]}_{run.seed}.png"
    fig.savefig(path, dpi=90)
    return path
