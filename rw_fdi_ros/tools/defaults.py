"""Regenerate the shipped Elman models and threshold curves from nothing (`rw-fdi defaults`).

1. record fault-free campaigns: fitting runs (seeds 1000..) and held-out runs (seeds 5000..);
2. train the thesis baseline (teacher forcing on one run) and ours (recall mode on many runs);
3. compare their nominal residuals on the held-out runs, keep both, ship the lower;
4. fit both observers' threshold curves on the fitting runs with the shipped model;
5. measure the held-out false-alarm rate for several persistence values P;
6. write config/fdi/ and a report of all of it (config/fdi/defaults_report.md).
"""
from __future__ import annotations

import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from ..core.detection import PERSISTENCE, ThresholdCurves
from ..core.scenario import AXES
from .campaign import run_campaign
from .offline import decisions, fit_thresholds, load_models, observe, plant_conditions
from .samples import load_samples
from .train import train_models

FIT_SEED, HELDOUT_SEED = 1000, 5000
PERSISTENCES = (1, 2, 3, 5, 8)


def _log(msg):
    print(msg, file=sys.stderr, flush=True)


def nominal_residuals(samples, models, settle: float = 60.0) -> dict:
    """Elman residual statistics after the manoeuvre on fault-free runs [N m]."""
    values = np.concatenate([observe(s, models).residual["elman"][s.time >= settle] for s in samples])
    return {"mean": float(values.mean()), "p99": float(np.percentile(values, 99)), "max": float(values.max())}


def false_alarm_rates(samples, models, thresholds_dir, persistences=PERSISTENCES) -> dict:
    curves = {obs: ThresholdCurves.load(Path(thresholds_dir) / f"thresholds_{obs}.json") for obs in ("elman", "linear")}
    runs = [observe(s, models) for s in samples]
    out = {}
    for p in persistences:
        out[p] = {}
        for obs in curves:
            alarmed = [any(d[obs][a][1] is not None for a in AXES) for d in (decisions(r, {obs: curves[obs]}, p)
                                                                              for r in runs)]
            out[p][obs] = float(np.mean(alarmed))
    return out


def regenerate_defaults(work="bags/defaults", out="config/fdi", fit_runs=100, heldout_runs=20, train_runs=40,
                        epochs=300, persistence=PERSISTENCE, executor=None) -> dict:
    work, out = Path(work), Path(out)
    t0 = time.monotonic()
    stages = {}

    _log(f"[1/5] fault-free campaigns: {fit_runs} fitting runs, {heldout_runs} held-out runs -> {work}")
    for name, seed, n in (("fit", FIT_SEED, fit_runs), ("heldout", HELDOUT_SEED, heldout_runs)):
        res = run_campaign("fault_free", n, seed, work / name, executor=executor, desc=f"fault_free {name}")
        if res.failed:
            raise RuntimeError(f"{len(res.failed)} {name} runs failed, e.g. seed {res.failed[0][0]}: {res.failed[0][1]}")
    stages["campaigns_s"] = time.monotonic() - t0

    skipped = []
    fit = load_samples(work / "fit", on_skip=skipped.append)
    heldout = load_samples(work / "heldout", on_skip=skipped.append)
    if skipped:
        raise RuntimeError(f"unusable bags: {skipped[0]}")

    _log("[2/5] training the thesis baseline (teacher forcing, 1 run) and recall mode on many runs")
    t = time.monotonic()
    variants = {"teacher_1run": ("teacher", fit[:1]), f"recall_{train_runs}runs": ("recall", fit[:train_runs])}
    cards = {}
    plant = plant_conditions(fit)
    for name, (mode, data) in variants.items():
        cards[name] = train_models(data, out / "variants" / name, mode=mode, epochs=epochs, plant=plant)
    stages["training_s"] = time.monotonic() - t

    _log("[3/5] nominal residuals of each variant on held-out fault-free runs")
    comparison = {name: nominal_residuals(heldout, load_models(out / "variants" / name)) for name in variants}
    chosen = min(comparison, key=lambda n: comparison[n]["mean"])
    for f in (out / "variants" / chosen).iterdir():
        shutil.copy(f, out / f.name)

    _log(f"[4/5] threshold curves from {len(fit)} fitting runs with the '{chosen}' model")
    t = time.monotonic()
    reliability = fit_thresholds(fit, load_models(out), out, model_ref=f"variants/{chosen}")
    stages["fitting_s"] = time.monotonic() - t

    _log("[5/5] held-out false-alarm rate against persistence P")
    far = false_alarm_rates(heldout, load_models(out), out)
    stages["total_s"] = time.monotonic() - t0
    report = {"chosen_model": chosen, "comparison": comparison, "reliability": reliability,
              "false_alarm_rate_heldout": far, "persistence": persistence,
              "fit_seeds": [s.seed for s in fit], "heldout_seeds": [s.seed for s in heldout],
              "train_cards": {k: {kk: vv for kk, vv in v.items() if kk != "bags"} for k, v in cards.items()},
              "stages": stages, "command": "rw-fdi defaults"}
    (out / "defaults.json").write_text(json.dumps(report, indent=2))
    (out / "defaults_report.md").write_text(format_report(report))
    return report


def format_report(r: dict) -> str:
    lines = ["# Shipped FDI defaults", "", f"Regenerate with `{r['command']}` (from nothing: campaigns, training, "
             "fitting). Plant choices: see the `plant` field of `thresholds_*.json`.", "",
             "## Elman training variants, nominal residual on held-out fault-free runs (after 60 s)", "",
             "| variant | mean [1e-3 N m] | p99 [1e-3 N m] | max [1e-3 N m] | final training MSE x/y/z |",
             "|---|---|---|---|---|"]
    for name, c in r["comparison"].items():
        losses = "/".join(f"{r['train_cards'][name]['axes'][a]['final_loss']:.1e}" for a in AXES)
        mark = " (shipped)" if name == r["chosen_model"] else ""
        lines.append(f"| {name}{mark} | {c['mean'] * 1e3:.3f} | {c['p99'] * 1e3:.3f} | {c['max'] * 1e3:.3f} | {losses} |")
    lines += ["", f"## Threshold reliability on the {len(r['fit_seeds'])} fitting runs (share under the curve everywhere)",
              "", "| observer | x | y | z |", "|---|---|---|---|"]
    for obs, rel in r["reliability"].items():
        lines.append(f"| {obs} | " + " | ".join(f"{rel[a] * 100:.0f} %" for a in AXES) + " |")
    lines += ["", f"## False-alarm rate on {len(r['heldout_seeds'])} held-out fault-free runs against persistence P",
              "", "| P | elman | linear |", "|---|---|---|"]
    for p, row in r["false_alarm_rate_heldout"].items():
        lines.append(f"| {p} | {row['elman'] * 100:.0f} % | {row['linear'] * 100:.0f} % |")
    lines += ["", f"Shipped persistence P = {r['persistence']}.", "",
              "Stage times [s]: " + ", ".join(f"{k} {v:.0f}" for k, v in r["stages"].items())]
    return "\n".join(lines) + "\n"
