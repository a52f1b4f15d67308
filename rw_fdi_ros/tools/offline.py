"""The observers run offline on recorded FDI samples, with the very code the nodes run.

ElmanObserver.update, LinearObserver.update, ResidualFilter.update and
AlarmRule.update are stepped sample by sample here exactly as in the
elman_observer, linear_observer and isolation nodes.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.detection import WINDOW, ThresholdCurves, ThresholdError, alarm_series, residual_series
from ..core.elman import ElmanWeights, ModelError, recall_series
from ..core.linear_observer import estimate_series
from ..core.scenario import AXES
from ..launch.graph import CONTROL_PERIOD, FDI_PERIOD, FDI_SAMPLING

DEFAULT_PLANT = {"emf_limit": "kf_scaled", "control_period": CONTROL_PERIOD}


def load_models(models_dir) -> dict:
    """axis -> ElmanWeights from ``models_dir/elman_<axis>.npz`` (ModelError names the file)."""
    models_dir = Path(models_dir)
    return {a: ElmanWeights.load(models_dir / f"elman_{a}.npz") for a in AXES}


def model_card(models_dir) -> dict:
    path = Path(models_dir) / "model_set.json"
    if not path.is_file():
        raise ModelError(f"{path}: missing model card")
    return json.loads(path.read_text())


@dataclass
class ObserverRun:
    """Estimates and residuals (n, 3) of both observers on one run's FDI samples."""

    time: np.ndarray
    reaction_torque: np.ndarray
    estimate: dict      # observer -> (n, 3)
    residual: dict      # observer -> (n, 3)


def observe(samples, models: dict, window: int = WINDOW, period: float = FDI_PERIOD) -> ObserverRun:
    r = samples.reaction_torque
    elman = np.stack([recall_series(models[a], samples.tcv[:, i], r[0, i]) for i, a in enumerate(AXES)], axis=1)
    linear = estimate_series(samples.tcv, r, period)
    est = {"elman": elman, "linear": linear}
    return ObserverRun(samples.time, r, est, {k: residual_series(r, v, window) for k, v in est.items()})


def plant_conditions(samples_list, sampling: str = FDI_SAMPLING) -> dict:
    """The plant choices the bags were recorded under (FdiSamples or bag paths); they must all agree."""
    import yaml
    from ..storage.bag import read_bag
    seen = set()
    for s in samples_list:
        text = read_bag(getattr(s, "bag", s), topics=["/scenario"]).scenario_text or ""
        plant = {**DEFAULT_PLANT, **((yaml.safe_load(text) or {}).get("plant") or {})}
        seen.add(tuple(sorted(plant.items())))
    if len(seen) != 1:
        raise ThresholdError(f"bags recorded under different plant choices: {sorted(seen)}")
    return {**dict(seen.pop()), "fdi_period": FDI_PERIOD, "fdi_sampling": sampling}


def fit_thresholds(samples_list, models: dict, out_dir, model_ref: str = "", window: int = WINDOW) -> dict:
    """Fit mean + 3 sigma curves for both observers from fault-free runs; returns reliability per axis."""
    from ..core.detection import fit_threshold_curve
    n = min(len(s.time) for s in samples_list)
    runs = [observe(s, models, window) for s in samples_list]
    plant = plant_conditions(samples_list)
    seeds = [s.seed for s in samples_list]
    out_dir = Path(out_dir)
    report = {}
    for obs in ("elman", "linear"):
        stack = np.stack([run.residual[obs][:n] for run in runs])          # (runs, n, 3)
        curves = {a: fit_threshold_curve(stack[:, :, i]) for i, a in enumerate(AXES)}
        ThresholdCurves(observer=obs, curves=curves, sample_period=FDI_PERIOD, window=window, seeds=seeds,
                        plant=plant, model=model_ref if obs == "elman" else "linearised wheel, poles 4x").save(
            out_dir / f"thresholds_{obs}.json")
        report[obs] = {a: float(np.mean(np.all(stack[:, :, i] <= curves[a], axis=1))) for i, a in enumerate(AXES)}
    return report


def decisions(run: ObserverRun, curves: dict, persistence: int) -> dict:
    """observer -> axis -> (alarm flags, first alarm time) with the isolation node's rule."""
    out = {}
    for obs, c in curves.items():
        out[obs] = {}
        for i, a in enumerate(AXES):
            k = np.round(run.time / c.sample_period).astype(int)
            threshold = np.array([c.at(a, j) for j in k])
            out[obs][a] = alarm_series(run.residual[obs][:, i], threshold, run.time, persistence)
    return out
