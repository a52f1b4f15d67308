"""The observers run offline on recorded FDI samples, with the very code the nodes run.

ElmanObserver.update, LinearObserver.update, ResidualFilter.update,
SignedResidual.update and AlarmRule.update are stepped sample by sample here
exactly as in the elman_observer, linear_observer, model_observer and
isolation nodes.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core.fdi.detection import FALSE_ALARM_RATE, PERSISTENCE, PERSISTENCE_SPEED_AWARE, WINDOW, observers_of
from ...core.fdi.threshold_file import ThresholdCurves, ThresholdError
from ...core.fdi.threshold_fit import fit_band, run_statistic
from ...core.fdi.residuals import residual_series, signed_residual_series
from ...core.fdi.calibration import calibration_samples, regressors
from ...core.fdi.elman import ElmanWeights, ModelError, network_wheel, network_wheels, recall_series
from ...core.fdi.linear_observer import estimate_series, uncertainty_gain
from ...core.fdi.observer_plugin import PluginRun
from ...core.mission.plant_choices import FDI_PERIOD, FDI_SAMPLING, PlantChoices
from ...core.physics.wheel import WheelParams, bearing_noise_mean, linearised_wheel
from ...core.physics.wheel_set import AXIS_WHEELS, wheel_set
from ...core.mission.yaml_text import read_yaml
from ...core.fdi.verdict import in_envelope, speed_envelope
from ...graph.topics import DIAGNOSTICS
from ...scoring.metrics import RunEval



def load_models(models_dir) -> dict:
    """wheel -> ElmanWeights from ``models_dir/elman_<wheel>.npz``, a network per wheel the set was trained
    for (core/fdi/elman.network_wheels; ModelError names the file)."""
    models_dir = Path(models_dir)
    return {a: ElmanWeights.load(models_dir / f"elman_{a}.npz") for a in network_wheels(models_dir)}


def model_card(models_dir) -> dict:
    path = Path(models_dir) / "model_set.json"
    if not path.is_file():
        raise ModelError(f"{path}: missing model card")
    return json.loads(path.read_text())


@dataclass
class ObserverRun:
    """Estimates, residuals and ripple bounds (n, 3) of the method's observers on one run's FDI samples."""

    time: np.ndarray
    reaction_torque: np.ndarray
    estimate: dict      # observer -> (n, 3)
    residual: dict      # observer -> (n, 3); signed (speed_aware) or >= 0 (thesis)
    bound: dict         # observer -> (n, 3); 0 for the thesis method
    method: str = "thesis"
    wheels: tuple = AXIS_WHEELS   # the columns' wheel names


def fdi_method_of(models: dict) -> str:
    """'speed_aware' for networks with the wheel-speed input, else 'thesis'."""
    return "speed_aware" if all(w.speed_aware for w in models.values()) else "thesis"


def observe(samples, models: dict, window: int = WINDOW, period: float = FDI_PERIOD,
            calibration_samples: int = 0) -> ObserverRun:
    """The method's observers (core/fdi/detection.observers_of) over one run, and the plug-ins of ``models``
    (core/fdi/observer_plugin.ObserverModels) beside them; the method follows the Elman models (thesis: 2 inputs).
    ``calibration_samples`` > 0: each speed-aware observer learns each wheel's unit from that many
    first samples (core/fdi/calibration.py)."""
    r = samples.reaction_torque
    method = fdi_method_of(models)
    wheels = getattr(samples, "wheels", AXIS_WHEELS)
    nets = [models[network_wheel(a, models)] for a in wheels]   # a redundant wheel runs its type's network
    if method == "thesis":
        elman = np.stack([recall_series(m, samples.tcv[:, i], reaction_torque=r[:, i])
                          for i, m in enumerate(nets)], axis=1)
        est = {"elman": elman, "linear": estimate_series(samples.tcv, r, period)}
        zero = np.zeros_like(r)
        return ObserverRun(samples.time, r, est, {k: residual_series(r, v, window) for k, v in est.items()},
                           {k: zero for k in est}, wheels=wheels)
    if samples.wheel_speed is None:
        raise ValueError("speed-aware observers need FDI samples with wheel speed (fdi_sampling 'mean')")
    speed, model = samples.wheel_speed, samples.model_torque
    elman = np.stack([recall_series(m, samples.tcv[:, i], wheel_speed=speed[:, i], reaction_torque=r[:, i],
                                    model_torque=None if model is None else model[:, i])
                      for i, m in enumerate(nets)], axis=1)
    params = getattr(samples, "wheel_params", WheelParams())   # the wheel type the plant modelled
    linear = estimate_series(samples.tcv, r, period, linearised_wheel(params=params))
    est = {"elman": elman, "linear": linear, "model": samples.model_torque}
    gains = {"elman": [m.uncertainty_gain for m in nets], "linear": [uncertainty_gain(a) for a in wheels],
             "model": [0.0] * len(wheels)}
    for cls, state in getattr(models, "plugins", ()):   # a user's observers (core/fdi/observer_plugin.py)
        run = PluginRun(cls, wheels, period, state, calibration_samples)
        gains[cls.slot] = run.uncertainty_gains()
        est[cls.slot] = run.series(samples)
    residual, bound = {}, {}
    x = None
    if calibration_samples:
        if samples.motor_torque is None:
            raise ValueError("calibration needs FDI samples with the nominal motor and friction torque")
        x = regressors(samples.motor_torque, samples.friction_torque, samples.wheel_speed, samples.ripple_phasor,
                       samples.free_motor_torque, params=params)
    for k, v in est.items():
        residual[k], bound[k] = signed_residual_series(r, v, samples.ripple_phasor, window, gains[k], x,
                                                       calibration_samples, params, period)
    return ObserverRun(samples.time, r, est, residual, bound, method, wheels)


def recorded_plant(sample, sampling: str = FDI_SAMPLING):
    """The PlantChoices a bag (or FdiSamples read from one) was recorded under."""
    from ...storage.bag import read_bag
    text = read_bag(getattr(sample, "bag", sample), topics=["/scenario"]).scenario_text or ""
    return PlantChoices.of_recording((read_yaml(text, "the recorded /scenario") or {}).get("plant"), sampling)


def plant_conditions(samples_list, sampling: str = FDI_SAMPLING) -> dict:
    """The plant choices the bags were recorded under (FdiSamples or bag paths), as a mapping;
    they must all agree."""
    seen = {recorded_plant(s, sampling) for s in samples_list}
    if len(seen) != 1:
        raise ThresholdError(f"bags recorded under different plant choices: {sorted(map(str, seen))}")
    return seen.pop().as_dict()


def under_one_plant(samples_list, on_skip, sampling: str = FDI_SAMPLING) -> list:
    """The samples recorded under the plant choices most of them share; each other one is passed to
    ``on_skip`` with its reason (a model or band learnt from a mix would fit no plant)."""
    plants = [recorded_plant(s, sampling) for s in samples_list]
    if len(set(plants)) <= 1:
        return list(samples_list)
    kept = max(set(plants), key=lambda p: (plants.count(p), -plants.index(p)))
    for s, p in zip(samples_list, plants):
        if p != kept:
            on_skip(f"{getattr(s, 'bag', s)}: recorded under the plant choices {p}, the others under {kept}")
    return [s for s, p in zip(samples_list, plants) if p == kept]


def fit_thresholds(samples_list, models: dict, out_dir, model_ref: str = "", window: int = WINDOW,
                   false_alarm_rate: float = FALSE_ALARM_RATE, persistence: int | None = None,
                   unit_calibration: float = 0.0, plant: dict | None = None) -> dict:
    """Fit the method's observers' thresholds from fault-free runs (the method follows the models):
    thesis: mean + 3 sigma curves, returns reliability per axis; speed_aware: bands c for the
    designed per-run ``false_alarm_rate`` at persistence P, returns the bands.
    ``unit_calibration`` [s]: bands for observers that learn their wheel first; ``plant``: the plant
    choices of runs that are not bags (default: read from the bags)."""
    lengths = sorted({len(s.time) for s in samples_list})
    if len(lengths) > 1:   # the curves would end with the shortest run: a longer run could not be judged
        short = min(samples_list, key=lambda s: len(s.time))
        raise ThresholdError(f"fitting runs of different lengths ({lengths[0]} to {lengths[-1]} FDI samples; "
                             f"shortest: {getattr(short, 'bag', None) or short.seed}): fit on runs of one length")
    runs = [observe(s, models, window, calibration_samples=calibration_samples(unit_calibration, FDI_PERIOD))
            for s in samples_list]
    if unit_calibration and runs[0].method != "speed_aware":
        raise ThresholdError("--unit-calibration needs speed_aware models (the thesis' residual is unsigned)")
    # what every thresholds file says of its fitting runs
    fitting = dict(sample_period=FDI_PERIOD, window=window, seeds=[s.seed for s in samples_list],
                   plant=plant or plant_conditions(samples_list))
    describe = {"elman": model_ref, "linear": "linearised wheel, poles 4x",
                "model": "nominal wheel model at the measured speed",
                **{cls.slot: f"{cls.__module__}.{cls.__qualname__}: {cls.description}".rstrip(": ")
                   for cls, _ in getattr(models, "plugins", ())}}
    if runs and runs[0].method == "speed_aware":
        return _fit_bands(runs, samples_list, models, Path(out_dir), describe, fitting, false_alarm_rate,
                          persistence or PERSISTENCE_SPEED_AWARE, unit_calibration)
    return _fit_curves(runs, lengths[0], Path(out_dir), describe, fitting, persistence or PERSISTENCE)


def _fit_bands(runs, samples_list, models, out_dir: Path, describe: dict, fitting: dict, false_alarm_rate: float,
               p: int, unit_calibration: float) -> dict:
    """The speed-aware observers' (and plug-ins') bands c per wheel in use, saved; returns them."""
    window = fitting["window"]
    # a band per wheel in use in the fitting runs (x, y, z; a pyramid's four): counts are the set's
    fitted = wheel_set(PlantChoices.from_recorded(fitting["plant"]).wheel_set).active
    cols = [runs[0].wheels.index(a) for a in fitted]
    # the bearing noise (eq. 2.16) no observer models, over the residual's window: the smallest band of a
    # datasheet wheel (a calibrated one's bound carries the calibration's noise floor)
    noise_floor = (-np.inf if unit_calibration else
                   bearing_noise_mean(getattr(samples_list[0], "wheel_params", WheelParams()), window * FDI_PERIOD))
    kappa_of = {cls.slot: any(g > 0 for a, g in zip(runs[0].wheels, PluginRun(cls, runs[0].wheels, FDI_PERIOD,
                                                                               state).uncertainty_gains())
                              if a in fitted)
                for cls, state in getattr(models, "plugins", ())}
    report = {}
    for obs in observers_of("speed_aware") + tuple(cls.slot for cls, _ in getattr(models, "plugins", ())):
        blind = [i for i, run in enumerate(runs) if not np.all(np.isfinite(run.residual[obs][:, cols]))]
        if blind:   # a band fitted on what it could not see would be NaN, or too low
            raise ValueError(f"observer {obs}: non-finite estimates in {len(blind)} of {len(runs)} fitting runs "
                             f"(the first: run {blind[0] + 1}); its band cannot be fitted")
        stats = np.array([run_statistic(np.abs(run.residual[obs][:, cols]) - run.bound[obs][:, cols], p)
                          for run in runs])
        # the Elman and Luenberger bounds spent half of alpha on kappa (residuals.demand_gain), and so does a
        # plug-in with a kappa (the same rule); the model observer's band gets the whole
        share = 0.5 if obs in ("elman", "linear") or kappa_of.get(obs) else 1.0
        bands = fit_band(stats, false_alarm_rate, axes=fitted, share=share, floor=noise_floor)
        ThresholdCurves(observer=obs, curves={a: np.array([bands[a]["band"]]) for a in fitted}, **fitting,
                        sigmas=float("nan"), model=describe[obs], method="speed_aware", persistence=p,
                        false_alarm_rate=false_alarm_rate, unit_calibration_time=float(unit_calibration),
                        calibration={"law": "Gumbel fitted to the upper half of the run statistics "
                                            "(probability plot)",
                                     "alpha_per_axis": share * false_alarm_rate / len(fitted), "axes": bands,
                                     "run_statistic": "max over k of min(|residual| - bound) over P samples"}
                        ).save(out_dir / f"thresholds_{obs}.json")
        report[obs] = {a: bands[a]["band"] for a in fitted}
    return report


def _fit_curves(runs, n: int, out_dir: Path, describe: dict, fitting: dict, persistence: int) -> dict:
    """The thesis' observers' mean + 3 sigma curves on the axis wheels, saved; returns each axis' reliability
    (the share of fitting runs under its curve throughout)."""
    from ...core.fdi.threshold_fit import fit_threshold_curve
    # the axis wheels' columns: a standby wheel never used in a fitting run has no residual to fit, and gets
    # the widest band of its type (ThresholdCurves.at)
    axis_columns = [runs[0].wheels.index(a) for a in AXIS_WHEELS] if runs else []
    report = {}
    for obs in observers_of("thesis"):
        stack = np.stack([run.residual[obs][:n, axis_columns] for run in runs])          # (runs, n, 3)
        curves = {a: fit_threshold_curve(stack[:, :, i]) for i, a in enumerate(AXIS_WHEELS)}
        ThresholdCurves(observer=obs, curves=curves, **fitting, model=describe[obs],
                        persistence=persistence).save(out_dir / f"thresholds_{obs}.json")
        report[obs] = {a: float(np.mean(np.all(stack[:, :, i] <= curves[a], axis=1)))
                       for i, a in enumerate(AXIS_WHEELS)}
    return report


def judge(run: ObserverRun, curves: dict, samples=None, decision=None, persistence: int | None = None,
          calibration_samples: int = 0, identification: bool = False, other_decisions=()) -> tuple:
    """Stages 2-5 of the FDI pipeline (core/fdi/pipeline.Isolation, the isolation node's) stepped over one run's
    residuals: what the node would publish for this run.

    Parameters
    ----------
    run : ObserverRun
        The observers' residuals and bounds (:func:`observe`).
    curves : dict
        observer -> ThresholdCurves of the observers judged.
    samples : FdiSamples, optional
        The run's FDI samples: the wheel speeds (the operating envelope) and, with ``identification``, the terms
        the identification fits; None: every sample judged.
    decision : DecisionRule, optional
        Who decides /diagnostics; None: the method's decision observer.
    persistence : int, optional
        P; None: the curves' own.
    calibration_samples : int
        FDI samples the identification learns each wheel's unit from.
    identification : bool
        Identify the verdict's alarmed wheels (decided once, at the end).
    other_decisions : sequence of DecisionRule
        The verdicts these would give, beside (metrics.decision_slot); those of other observers are left out.

    Returns
    -------
    series : dict
        observer -> metrics.Series (|residual|, threshold + bound, alarm); ``verdict``: what /diagnostics says
        (the lead observer's residual and threshold, the latched alarm).
    identified : dict
        wheel -> the last Identification or None ({} without ``identification``).
    """
    from ...core.fdi.pipeline import Isolation, Verdict
    from ...scoring.metrics import VERDICT, decision_slot
    for obs, c in curves.items():
        c.check_method(run.method, origin=f"thresholds_{obs}")
    wheels, n = run.wheels, len(run.time)
    isolation = Isolation(wheels, curves, decision, persistence, wheel=getattr(samples, "wheel_params", None),
                          calibration_samples=calibration_samples, identification=identification, lazy=True)
    verdicts = {VERDICT: isolation.verdict,
                **{decision_slot(d.label): Verdict(wheels, d, True, isolation.verdict.envelope)
                   for d in other_decisions if set(d.observers) <= set(curves)}}
    speeds = None if samples is None else samples.wheel_speed
    rows = samples.rows() if identification else None
    stamps = np.round(run.time * 1e9).astype(np.int64)
    table = {obs: np.empty((n, len(wheels), 3)) for obs in curves}
    alarm = {slot: np.zeros((n, len(wheels)), bool) for slot in verdicts}
    for k, stamp in enumerate(stamps):
        rows_of = {obs: isolation.observe(obs, int(stamp), run.residual[obs][k], run.bound[obs][k]) for obs in curves}
        speed = None if speeds is None else speeds[k]
        for slot, verdict in verdicts.items():
            decided = verdict.decide(rows_of, speed)
            alarm[slot][k] = [decided[a][2] for a in wheels]
            if slot == VERDICT and rows is not None:
                isolation.identify(next(rows), decided)
        for obs, r in rows_of.items():
            table[obs][k] = [r[a][:3] for a in wheels]
    return _series_of(run.time, table, alarm, isolation.decision.lead), isolation.identified()


def _series_of(time, table: dict, alarm: dict, lead: str) -> dict:
    """observer -> Series of its (n, W, 3) rows (residual, threshold, alarm); each verdict slot's alarms beside
    the ``lead`` observer's residual and threshold."""
    from ...scoring.metrics import Series
    series = {obs: Series(time, np.abs(t[:, :, 0]), t[:, :, 1], t[:, :, 2].astype(bool)) for obs, t in table.items()}
    series.update({slot: Series(time, series[lead].residual, series[lead].threshold, a) for slot, a in alarm.items()})
    return series


def decisions(run: ObserverRun, curves: dict, persistence: int | None = None) -> dict:
    """observer -> axis -> (alarm flags, first alarm time) of the observers' series (:func:`judge`)."""
    from ...scoring.metrics import VERDICT
    out = {}
    series, _ = judge(run, curves, persistence=persistence)
    for obs, s in ((o, v) for o, v in series.items() if o != VERDICT):
        out[obs] = {}
        for i, a in enumerate(run.wheels):
            flags = s.alarm[:, i]
            up = np.nonzero(flags)[0]   # AlarmRule's first alarm: where the flag first goes up
            out[obs][a] = (flags, float(s.time[up[0]]) if up.size else None)
    return out


def threshold_set(thresholds_dir, method: str) -> dict:
    """observer -> ThresholdCurves of the ``method``'s observers in ``thresholds_dir`` (thresholds_<obs>.json)."""
    return {obs: ThresholdCurves.load(Path(thresholds_dir) / f"thresholds_{obs}.json", obs)
            for obs in observers_of(method)}


def alarmed_runs(runs, curves: dict, persistence: int | None = None) -> dict:
    """observer -> how many of ``runs`` (ObserverRun) it alarmed anywhere: on fault-free runs, its false alarms."""
    judged = [decisions(r, curves, persistence) for r in runs]
    return {obs: sum(any(first is not None for _, first in d[obs].values()) for d in judged) for obs in curves}


def judge_run(scenario, samples, peak, weights, curves, persistence: int | None = None,
              identification: bool = False, calibration_samples: int = 0, bag: str | None = None,
              decision=None, other_decisions=()) -> RunEval:
    """The RunEval of one run from its FDI samples, by the observer and isolation nodes' code: each
    observer's series, ``verdict`` (what /diagnostics says: the ``decision``'s alarm, latched, None: the
    method's decision observer; offline.judge) and with ``identification`` the faults of the wheels
    the verdict names (the isolation node's FaultIdentifier; the samples must carry the bus grid). ``peak``:
    |fault effect| per wheel after the first onset. ``other_decisions`` (core/fdi/verdict.DecisionRule): the verdict
    each would give, beside (metrics.decision_slot)."""
    series, last = judge(observe(samples, weights, calibration_samples=calibration_samples), curves, samples,
                         decision, persistence, calibration_samples, identification and len(samples.time) > 0,
                         other_decisions)
    found = {a: v.values() for a, v in last.items() if v is not None}
    return RunEval(bag=bag or f"screen:{scenario.name}:{scenario.seed}", scenario=scenario.name, seed=scenario.seed,
                   faults=list(scenario.faults), series=series, fault_effect_peak=peak, identification=found,
                   health=envelope_health(samples), wheels=samples.wheels)


def envelope_health(samples) -> dict:
    """What the isolation node's /diagnostics says of samples outside the operating envelope (STALE, not
    judged), in health_from_bag's form: {/diagnostics: {axis: {cannot_judge: samples, first_s, message}}}."""
    if samples.wheel_speed is None or not len(samples.time):
        return {}
    outside = ~in_envelope(samples.wheel_speed, speed_envelope(samples.wheel_params))
    return {DIAGNOSTICS: {a: {"cannot_judge": {"samples": int(outside[:, i].sum()),
                                               "first_s": float(samples.time[int(np.argmax(outside[:, i]))]),
                                               "message": "outside the operating envelope"}}
                          for i, a in enumerate(samples.wheels) if outside[:, i].any()}} if outside.any() else {}
