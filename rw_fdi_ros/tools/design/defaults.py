"""Regenerate the shipped Elman models and thresholds from nothing (`rw-fdi defaults`).

1. record fault-free campaigns: training runs (seeds 1000-1039), fitting runs (1040-1139) and
   held-out runs (5000..): training, fitting and checking never share a run;
2. the thesis set (config/fdi/thesis): train the thesis baseline (teacher forcing on one run)
   and recall mode on many runs, ship the one with the lower nominal residual on the held-out
   runs, fit mean + 3 sigma curves on the fitting runs, held-out false alarms against P;
3. our set (config/fdi): train the speed-aware network (recall mode, 3 inputs), fit both
   observers' bands on the fitting runs for the designed per-run false-alarm rate;
4. write both and a report of all of it (config/fdi/defaults_report.md). The figures of
   record on >= 1000 held-out runs are `rw-fdi bench detection`'s.
"""
from __future__ import annotations

import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from ...core.fdi.detection import FALSE_ALARM_RATE, PERSISTENCE, PERSISTENCE_SPEED_AWARE, observers_of
from ...core.physics.wheel_set import AXIS_WHEELS
from ..campaigns.campaign import run_campaign
from .offline import (alarmed_runs, fdi_method_of, fit_thresholds, load_models, observe, plant_conditions,
                      threshold_set)
from .samples import load_samples
from .train import EPOCHS, THESIS_EPOCHS, train_models

FIT_SEED, HELDOUT_SEED = 1000, 5000
PERSISTENCES = (1, 2, 3, 5, 8)


def _log(msg):
    print(msg, file=sys.stderr, flush=True)


def nominal_residuals(samples, models, settle: float = 60.0, observer: str = "elman") -> dict:
    """|residual| statistics after the manoeuvre on fault-free runs [N m]."""
    values = np.concatenate([np.abs(observe(s, models).residual[observer][s.time >= settle]) for s in samples])
    return {"mean": float(values.mean()), "p99": float(np.percentile(values, 99)), "max": float(values.max())}


def false_alarm_rates(samples, models, thresholds_dir, persistences=PERSISTENCES) -> dict:
    """P -> observer -> share of runs with any alarm."""
    curves = threshold_set(thresholds_dir, fdi_method_of(models))
    runs = [observe(s, models) for s in samples]
    return {p: {obs: k / len(runs) for obs, k in alarmed_runs(runs, curves, p).items()} for p in persistences}


def regenerate_defaults(work="bags/defaults", out="config/fdi", fit_runs=100, heldout_runs=20, train_runs=40,
                        epochs=EPOCHS, thesis_epochs=THESIS_EPOCHS, executor=None,
                        false_alarm_rate: float = FALSE_ALARM_RATE) -> dict:
    work, out = Path(work), Path(out)
    thesis_out = out / "thesis"
    t0 = time.monotonic()
    stages = {}

    _record_campaigns(work, train_runs, fit_runs, heldout_runs, executor)
    stages["campaigns_s"] = time.monotonic() - t0

    skipped = []
    recorded = load_samples(work / "fit", on_skip=skipped.append, fault_free=True)
    recorded.sort(key=lambda s: s.seed)
    train, fit = recorded[:train_runs], recorded[train_runs:train_runs + fit_runs]
    heldout = load_samples(work / "heldout", on_skip=skipped.append)[:heldout_runs]
    if skipped:
        raise RuntimeError(f"unusable bags: {skipped[0]}")
    plant = plant_conditions(train + fit)

    _log("[2/4] thesis set: teacher forcing on 1 run and recall mode on many, mean + 3 sigma curves")
    t = time.monotonic()
    thesis = _thesis_set(train, fit, heldout, thesis_out, thesis_epochs, plant, train_runs)
    stages["thesis_set_s"] = time.monotonic() - t

    _log(f"[3/4] speed-aware set: recall mode on {train_runs} runs with the wheel speed, bands for a "
         f"per-run false-alarm rate of {false_alarm_rate:g}")
    t = time.monotonic()
    ours_card = train_models(train, out, mode="recall", epochs=epochs, plant=plant, speed_aware=True,
                             calibration=train + fit, false_alarm_rate=false_alarm_rate)
    bands = fit_thresholds(fit, load_models(out), out, model_ref="model_set.json", false_alarm_rate=false_alarm_rate,
                           persistence=PERSISTENCE_SPEED_AWARE)
    ours_nominal = {obs: nominal_residuals(heldout, load_models(out), observer=obs)
                    for obs in observers_of("speed_aware")}
    ours_far = false_alarm_rates(heldout, load_models(out), out, persistences=(PERSISTENCE_SPEED_AWARE,))
    stages["speed_aware_set_s"] = time.monotonic() - t
    stages["total_s"] = time.monotonic() - t0

    report = {"command": "rw-fdi defaults", "plant": plant, "train_seeds": [s.seed for s in train],
              "fit_seeds": [s.seed for s in fit], "heldout_seeds": [s.seed for s in heldout],
              "thesis": thesis,
              "speed_aware": {"bands": bands, "false_alarm_rate_design": false_alarm_rate,
                              "persistence": PERSISTENCE_SPEED_AWARE, "nominal_residual": ours_nominal,
                              "false_alarm_rate_heldout": ours_far[PERSISTENCE_SPEED_AWARE],
                              "train_card": _card(ours_card)},
              "stages": stages}
    (out / "defaults.json").write_text(json.dumps(report, indent=2))
    (out / "defaults_report.md").write_text(format_report(report))
    _log(f"[4/4] wrote {out} and {thesis_out}")
    return report


def _record_campaigns(work: Path, train_runs: int, fit_runs: int, heldout_runs: int, executor):
    """Stage 1: the fault-free campaigns, training and fitting runs in work/fit, held-out ones in work/heldout."""
    _log(f"[1/4] fault-free campaigns: {train_runs} training + {fit_runs} fitting runs, {heldout_runs} held-out "
         f"runs -> {work}")
    for name, seed, n in (("fit", FIT_SEED, train_runs + fit_runs), ("heldout", HELDOUT_SEED, heldout_runs)):
        res = run_campaign("fault_free", n, seed, work / name, executor=executor, desc=f"fault_free {name}")
        if res.failed:
            raise RuntimeError(f"{len(res.failed)} {name} runs failed, "
                               f"e.g. seed {res.failed[0][0]}: {res.failed[0][1]}")


def _thesis_set(train: list, fit: list, heldout: list, thesis_out: Path, epochs: int, plant: dict,
                train_runs: int) -> dict:
    """Stage 2: the thesis baseline (teacher forcing on one run) and recall mode on every training run, the one
    with the lower nominal residual on the held-out runs shipped in ``thesis_out`` with its mean + 3 sigma
    curves; returns the report's part on it."""
    variants = {"teacher_1run": ("teacher", train[:1]), f"recall_{train_runs}runs": ("recall", train)}
    cards = {}
    for name, (mode, data) in variants.items():
        cards[name] = train_models(data, thesis_out / "variants" / name, mode=mode, epochs=epochs, plant=plant,
                                   speed_aware=False)
    comparison = {name: nominal_residuals(heldout, load_models(thesis_out / "variants" / name)) for name in variants}
    chosen = min(comparison, key=lambda n: comparison[n]["mean"])
    for f in (thesis_out / "variants" / chosen).iterdir():
        shutil.copy(f, thesis_out / f.name)
    reliability = fit_thresholds(fit, load_models(thesis_out), thesis_out, model_ref=f"variants/{chosen}",
                                 persistence=PERSISTENCE)
    return {"chosen_model": chosen, "comparison": comparison, "reliability": reliability,
            "false_alarm_rate_heldout": false_alarm_rates(heldout, load_models(thesis_out), thesis_out),
            "persistence": PERSISTENCE, "train_cards": {k: _card(v) for k, v in cards.items()}}


def _card(card: dict) -> dict:
    return {k: v for k, v in card.items() if k != "bags"}


def format_report(r: dict) -> str:
    th, ours = r["thesis"], r["speed_aware"]
    wheels = list(next(iter(ours["bands"].values())))   # the wheels in use: a band each
    lines = ["# Shipped FDI defaults", "",
             f"Regenerate with `{r['command']}` (from nothing: campaigns, training, fitting). Plant choices: "
             + ", ".join(f"{k} {v}" for k, v in r["plant"].items()) + ".",
             f"Training runs: {len(r['train_seeds'])} fault-free, seeds {r['train_seeds'][0]}-{r['train_seeds'][-1]}; "
             f"fitting runs: {len(r['fit_seeds'])}, seeds {r['fit_seeds'][0]}-{r['fit_seeds'][-1]}; "
             f"held-out runs: {len(r['heldout_seeds'])}, seeds {r['heldout_seeds'][0]}-{r['heldout_seeds'][-1]}. "
             "The figures of record (>= 1000 held-out runs, faults on every wheel) are `rw-fdi bench detection`'s.",
             "", "## Ours: speed-aware (`config/fdi`)", "",
             f"Bands c for a designed per-run false-alarm rate of {ours['false_alarm_rate_design']:g} at "
             f"P = {ours['persistence']} (Gumbel fit of the upper half of the fitting runs' statistics; alpha/3 per "
             "axis for the model observer, alpha/6 for the Elman and Luenberger observers, whose kappa spends the "
             "other half):", "",
             f"| observer | {' | '.join(f'c {a}' for a in wheels)} [1e-3 N m] | held-out |residual| after 60 s: "
             "mean / p99 / max [1e-3 N m] |",
             "|---|" + "---|" * (len(wheels) + 1)]
    for obs, row in ours["bands"].items():
        n = ours["nominal_residual"][obs]
        lines.append(f"| {obs} | " + " | ".join(f"{row[a] * 1e3:.4f}" for a in wheels)
                     + f" | {n['mean'] * 1e3:.4f} / {n['p99'] * 1e3:.4f} / {n['max'] * 1e3:.4f} |")
    far = ours["false_alarm_rate_heldout"]
    kappa = ours["train_card"]["axes"]
    lines += ["", "Elman uncertainty gain kappa (bound grows by kappa x mean |r| in manoeuvres; the (1 - alpha/6) "
              "Gumbel quantile of the training and fitting runs' largest error per unit demand): "
              + ", ".join(f"{a} {kappa[a]['uncertainty_gain']:.3f}" for a in kappa) + ".",
              "", "Held-out runs with any alarm: " + ", ".join(f"{o} {v * 100:.0f} %" for o, v in far.items())
              + f" (n = {len(r['heldout_seeds'])}).", "", *([ours["note"], ""] if ours.get("note") else []),
              "## The thesis' method (`config/fdi/thesis`)", "",
              "### Elman training variants, nominal residual on held-out fault-free runs (after 60 s)", "",
              "| variant | mean [1e-3 N m] | p99 [1e-3 N m] | max [1e-3 N m] | final training MSE x/y/z |",
              "|---|---|---|---|---|"]
    for name, c in th["comparison"].items():
        losses = "/".join(f"{th['train_cards'][name]['axes'][a]['final_loss']:.1e}" for a in AXIS_WHEELS)
        mark = " (shipped)" if name == th["chosen_model"] else ""
        lines.append(f"| {name}{mark} | {c['mean'] * 1e3:.3f} | {c['p99'] * 1e3:.3f} | {c['max'] * 1e3:.3f} "
                     f"| {losses} |")
    lines += ["", f"### Threshold reliability on the {len(r['fit_seeds'])} fitting runs (share under the curve "
              "everywhere)", "", "| observer | x | y | z |", "|---|---|---|---|"]
    for obs, rel in th["reliability"].items():
        lines.append(f"| {obs} | " + " | ".join(f"{rel[a] * 100:.0f} %" for a in AXIS_WHEELS) + " |")
    lines += ["", f"### False-alarm rate on {len(r['heldout_seeds'])} held-out fault-free runs against persistence P",
              "", "| P | elman | linear |", "|---|---|---|"]
    for p, row in th["false_alarm_rate_heldout"].items():
        lines.append(f"| {p} | {row['elman'] * 100:.0f} % | {row['linear'] * 100:.0f} % |")
    lines += ["", f"Thesis persistence P = {th['persistence']}.", "",
              "Stage times [s]: " + ", ".join(f"{k} {v:.0f}" for k, v in r["stages"].items())]
    return "\n".join(lines) + "\n"
