"""Elman networks trained for service: on what a spacecraft in service shows its wheels.

The shipped networks learnt one slew at t = 0 on three datasheet wheels; in service the wheels see
manoeuvres at any time, reconfigurations (the standby wheel brought in, the others taking a lost wheel's
share), momentum dumps that take them through zero, and units that are not the datasheet. Here the
training runs are draws of the in-service family itself (tools/campaigns/service_family.draw: its own seeds,
flown with the onboard FDIR on the core loop, so the reconfigurations happen as in service), and the
network learns every healthy running stretch of every wheel: the samples of a faulty wheel from its first
onset on and of a wheel at rest and unpowered (standby) are left out, the rest cut into windows of WINDOW
samples. As all the wheels of a set are of one type, one network is trained on every wheel's windows
pooled (a type network) and each wheel of the set runs it, its kappa measured on its own windows.

Design choices (compared on the family's tuning seeds, docs/fdi.md "Learned observers in service"):
what it learns (r, or the nominal model's error), the training runs' wheels (``units``: datasheet only, or
the family's mix of units and datasheet), the hidden units, the window and the loss.
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...core.fdi.elman import HIDDEN, ElmanWeights, speed_coverage, standby
from ...core.mission.vehicle import DEFAULT_VEHICLE
from ..campaigns import service_family as family

WINDOW = 300            # [FDI samples] a training window: two of each 600-s run
TRAIN_MAX_S = 1800.0    # [s] the longest training run (the family's 2-h and 6-h draws shortened)
SEEDS = {"train": 93_000_000, "fit": 93_500_000}   # disjoint from every bench's (service: 90-92 M)


def _run_batch(draws, act: bool = True) -> list:
    """(draw, FdiSamples) of one batch of draws flown on the core loop, every sample: with the family's FDIR
    (the vehicle's shipped FDI), or, ``act`` False, with no FDIR (what a vehicle's FDI is first fitted on)."""
    from ...core.closed_loop import simulate
    from .samples import samples_from_series
    scenarios = [family.scenario(d) for d in draws]
    traj = simulate(scenarios, fdir=family.fdir_for(draws[0].units, vehicle=draws[0].vehicle) if act else None)
    stamps = np.round(traj.time * 1e9).astype(np.int64)
    return [(d, samples_from_series(stamps, traj.wheel_command[:, b], traj.reaction_torque[:, b],
                                    traj.wheel_speed[:, b], seed=d.seed, wheels=traj.wheel_names,
                                    wheel_params=scenarios[0].spacecraft.wheel))
            for b, d in enumerate(draws)]


def family_runs(seeds, units: str = "mixed", fault_free: bool = False, executor=None, desc: str = "runs",
                vehicle: str = DEFAULT_VEHICLE, act: bool = True) -> list:
    """(draw, FdiSamples) of the in-service family's draws of ``seeds`` (at most TRAIN_MAX_S long; ``units``
    'mixed' as drawn, 'datasheet' or 'units' for all; ``fault_free``: its fault-free 600-s runs) flying
    ``vehicle`` (a shipped name or a vehicle file's absolute path); ``act`` False: flown without FDIR."""
    from functools import partial
    from tqdm import tqdm
    from ..campaigns.campaign import LocalExecutor
    draws = [family.draw(s, TRAIN_MAX_S, fault_free=fault_free, vehicle=str(vehicle)) for s in seeds]
    if units != "mixed":
        draws = [replace(d, units=units == "units") for d in draws]
    out = []
    with tqdm(total=len(draws), desc=desc, unit="run", file=sys.stderr) as bar:
        for done in (executor or LocalExecutor()).map_unordered(partial(_run_batch, act=act), family.batches(draws),
                                                                  processes=True):
            out += done
            bar.update(len(done))
    return sorted(out, key=lambda x: x[0].seed)


def healthy_windows(draw, samples, length: int = WINDOW) -> dict:
    """wheel -> [(tcv, reaction torque, wheel speed, ripple phasor, model torque) (length,) arrays]: the run's
    healthy running
    stretches of each wheel (not its fault's from the onset on, not at rest and unpowered), cut into windows."""
    onset = {}
    for f in draw.faults:
        onset[f["wheel"]] = min(onset.get(f["wheel"], np.inf), f["onset"])
    out = {}
    for i, wheel in enumerate(samples.wheels):
        u, r, w, p, m = (samples.tcv[:, i], samples.reaction_torque[:, i], samples.wheel_speed[:, i],
                         samples.ripple_phasor[:, i], samples.model_torque[:, i])
        ok = samples.time < onset.get(wheel, np.inf)
        ok &= ~np.array([standby(a, b) for a, b in zip(u, r)])
        edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
        for start, stop in zip(edges[::2], edges[1::2]):
            for k in range(start, stop - length + 1, length):
                out.setdefault(wheel, []).append(tuple(x[k:k + length] for x in (u, r, w, p, m)))
    return out


def _pooled(runs, window: int = WINDOW) -> tuple:
    """(windows by wheel, pooled arrays (windows, window) of tcv, torque, speed) of ``runs``."""
    by_wheel = {}
    for d, s in runs:
        for wheel, windows in healthy_windows(d, s, window).items():
            by_wheel.setdefault(wheel, []).extend(windows)
    pooled = [w for windows in by_wheel.values() for w in windows]
    return by_wheel, tuple(np.stack([w[j] for w in pooled]) for j in (0, 1, 2, 4))   # tcv, torque, speed, model


class _Window:
    """A window as the kappa measurement reads a run (train.uncertainty_gain): one wheel's column, of the
    wheel type ``wheel_params`` (its ripple and torque scale; None: the thesis' type)."""

    def __init__(self, u, r, w, p, m, wheel_params=None):
        self.tcv, self.reaction_torque, self.wheel_speed, self.ripple_phasor, self.model_torque = (
            x[:, None] for x in (u, r, w, p, m))
        self.wheel_params = wheel_params


def train_type_network(train_runs, out_dir, names, epochs: int, seed: int = 0, units: str = "mixed",
                       model_error: bool = True, hidden: int = HIDDEN, window: int = WINDOW,
                       loss: str = "mse", false_alarm_rate: float | None = None) -> dict:
    """One network for the wheel type on every wheel's healthy windows of ``train_runs`` pooled, saved as each
    wheel of ``names``' (its kappa from its own windows, or the largest where it has none); the card.
    ``model_error``: it learns the nominal model's error r - r_model (a grey box: its estimate r_model plus its
    output), else r itself; ``hidden``, ``window`` and ``loss`` as train.train_axis and healthy_windows;
    ``false_alarm_rate``: the designed per-run rate kappa takes half of (default train's)."""
    from tqdm import tqdm
    from .train import train_axis, uncertainty_gain
    from ...core.fdi.detection import FALSE_ALARM_RATE
    rate = FALSE_ALARM_RATE if false_alarm_rate is None else false_alarm_rate
    wheel_params = getattr(train_runs[0][1], "wheel_params", None)
    t0 = time.monotonic()
    by_wheel, (u, r, w, m) = _pooled(train_runs, window)
    if model_error and not np.any(r - m):
        # the nominal model is the telemetry to the bit (a simulator without noise): nothing to learn, and a
        # target scale of 0 would make the network non-finite; its correction is 0, the grey box the model
        print("the nominal model gives every training sample exactly: the grey box learns nothing, its "
              "correction is 0", file=sys.stderr, flush=True)
        zero = ElmanWeights.random(np.random.default_rng(seed), hidden, tcv_scale=5.0,
                                   torque_scale=float(np.abs(r).max() * 1.1) or 1.0,
                                   speed_scale=float(np.abs(w).max() * 1.1) or 1.0)
        weights, losses = replace(zero, w_ho=np.zeros_like(zero.w_ho), b_o=np.zeros_like(zero.b_o)), [0.0]
    else:
        with tqdm(total=epochs, desc=f"train the type network ({len(u)} windows of {window} samples)",
                  unit="epoch", file=sys.stderr, mininterval=1.0) as bar:
            def tick(k, loss_now):
                bar.update(k)
                bar.set_postfix(mse=f"{loss_now:.2e}", refresh=False)
            weights, losses = train_axis(u, r - m if model_error else r, "recall", epochs, seed=seed,
                                         wheel_speed=w, hidden=hidden, loss=loss, progress=tick)
    weights.model_error = model_error
    if model_error:   # beyond the speeds it learnt, the grey box is the nominal model (elman.speed_coverage)
        weights.speed_coverage = speed_coverage(w, weights.speed_scale)
    kappas = {}
    for wheel in names:
        windows = by_wheel.get(wheel, [])
        kappas[wheel] = (uncertainty_gain(weights, [_Window(*x, wheel_params) for x in windows], 0, rate, wheel=wheel)
                         if windows else None)
    widest = max(k for k in kappas.values() if k is not None)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    card = {"mode": "recall", "speed_aware": True, "epochs": epochs, "training": "service",
            "learns": "the nominal model's error r - r_model" if model_error else "r",
            "units": units, "window": window, "hidden": hidden, "loss": loss,
            "seeds": sorted({d.seed for d, _ in train_runs}),
            "windows": {a: len(v) for a, v in by_wheel.items()}, "wheels": list(names),
            "type_network": "one network trained on every wheel's healthy windows pooled", "axes": {},
            "final_loss": losses[-1], "speeds_learnt": _intervals(weights)}
    for wheel in names:
        weights.uncertainty_gain = kappas[wheel] if kappas[wheel] is not None else widest
        weights.save(out_dir / f"elman_{wheel}.npz", {**{k: v for k, v in card.items() if k != "axes"},
                                                      "axis": wheel, "uncertainty_gain": weights.uncertainty_gain})
        card["axes"][wheel] = {"uncertainty_gain": weights.uncertainty_gain, "windows": len(by_wheel.get(wheel, []))}
    card["train_seconds"] = time.monotonic() - t0
    (out_dir / "model_set.json").write_text(json.dumps(card, indent=2))
    return card


def _intervals(weights) -> list | None:
    """[low, high] wheel speeds [rad/s] of each run of learnt bins of a grey box (None: it is used at every speed)."""
    from ...core.fdi.elman import COVERAGE_BINS
    if weights.speed_coverage is None:
        return None
    edges = np.linspace(-weights.speed_scale, weights.speed_scale, COVERAGE_BINS + 1)
    flips = np.flatnonzero(np.diff(np.concatenate([[0], weights.speed_coverage.astype(int), [0]])))
    return [[round(float(edges[a]), 1), round(float(edges[b]), 1)] for a, b in zip(flips[::2], flips[1::2])]


def family_plant(draw) -> dict:
    """The plant choices a family draw is flown under, as a bag of it records them (what bands are fitted for)."""
    from ...core.mission.plant_choices import PlantChoices
    return PlantChoices.of_recording(family.scenario(draw).plant_choices().scenario_dict()).as_dict()


def fit_service_bands(fit_runs, fit_unit_runs, out_dir) -> dict:
    """The bands of every observer of the set in ``out_dir`` fitted on the family's fault-free 600-s runs:
    datasheet ones there, calibrated ones (150 s, on unit runs) in its unit_calibrated/ (config/fdi's layout)."""
    from .offline import fit_thresholds, load_models
    out_dir = Path(out_dir)
    models = load_models(out_dir)
    plant = family_plant(fit_runs[0][0])
    bands = {"datasheet": fit_thresholds([s for _, s in fit_runs], models, out_dir, model_ref="model_set.json",
                                         plant=plant)}
    if fit_unit_runs:
        bands["unit_calibrated"] = fit_thresholds([s for _, s in fit_unit_runs], models, out_dir / "unit_calibrated",
                                                  model_ref="../model_set.json", plant=plant,
                                                  unit_calibration=family.CALIBRATION_S)
    return bands


def service_defaults(out, train_runs: int = 60, fit_runs: int = 100, units: str = "mixed", epochs: int = 1000,
                     executor=None, fit=None, model_error: bool = True, hidden: int = HIDDEN,
                     window: int = WINDOW, loss: str = "mse") -> dict:
    """A speed-aware FDI directory trained and fitted for service from nothing (`rw-fdi defaults --service`):
    the type network on ``train_runs`` family draws (seeds from SEEDS['train'], wheels as ``units`` says), every
    observer's bands on ``fit_runs`` fault-free 600-s family runs of datasheet wheels and as many of units
    calibrated 150 s (seeds from SEEDS['fit'] and +10,000); ``fit``: those fitting runs, already flown;
    ``hidden``, ``window``, ``loss``: the network's design (train_type_network). The report (seeds, windows,
    kappa, bands) -> out/service_report.json."""
    t0 = time.monotonic()
    base = SEEDS["fit"]
    fit = fit or (family_runs(range(base, base + fit_runs), "datasheet", True, executor, "fitting runs, datasheet"),
                  family_runs(range(base + 10_000, base + 10_000 + fit_runs), "units", True, executor,
                              "fitting runs, units"))
    train = family_runs(range(SEEDS["train"], SEEDS["train"] + train_runs), units, False, executor, "training runs")
    card = train_type_network(train, out, tuple(fit[0][0][1].wheels), epochs, units=units, model_error=model_error,
                              hidden=hidden, window=window, loss=loss)
    bands = fit_service_bands(*fit, out)
    report = {"command": "rw-fdi defaults --service", "units": units, "epochs": epochs, "model_error": model_error,
              "hidden": hidden, "window": window, "loss": loss,
              "train_seeds": [SEEDS["train"], SEEDS["train"] + train_runs - 1],
              "fit_seeds": {"datasheet": [base, base + fit_runs - 1],
                            "units": [base + 10_000, base + 10_000 + fit_runs - 1]},
              "windows": card["windows"],
              "uncertainty_gain": {a: c["uncertainty_gain"] for a, c in card["axes"].items()},
              "final_loss": card["final_loss"], "bands": bands, "seconds": time.monotonic() - t0}
    (Path(out) / "service_report.json").write_text(json.dumps(report, indent=1, default=float))
    return report
