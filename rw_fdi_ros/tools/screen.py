"""`rw-fdi screen`: FDI figures for many seeds in seconds, without ROS.

The core closed loop (the plant and PID code the nodes run) simulates a
batch of seeds; FdiSampler, the observers and the alarm rule (the code the
observer and isolation nodes run) judge them. The graph gives the same
residuals to 1e-15 (test_fdi_graph.py); use it to screen, and `rw-fdi
evaluate` on recorded bags for the figures of record.
"""
from __future__ import annotations

import numpy as np

from ..core.closed_loop import simulate
from ..core.detection import PERSISTENCE, ThresholdCurves
from ..core.sampling import sample_series
from ..core.scenario import AXES
from ..paths import config_dir
from .offline import decisions, load_models, observe
from .samples import FdiSamples


def screen(scenario, seeds, models=None, thresholds=None, persistence: int = PERSISTENCE) -> dict:
    models_dir = models or config_dir() / "fdi"
    thresholds_dir = thresholds or config_dir() / "fdi"
    weights = load_models(models_dir)
    curves = {o: ThresholdCurves.load(f"{thresholds_dir}/thresholds_{o}.json") for o in ("elman", "linear")}
    runs = [scenario.with_seed(s) for s in seeds]
    traj = simulate(runs)
    stamps = np.round(traj.time * 1e9).astype(np.int64)
    faulty = {AXES[f.wheel] for f in scenario.faults if f.kind != "ripple_gain"}
    out = {o: {"runs": len(runs), "any_alarm": 0, "correct": 0, "wrong_axis": 0, "held": 0, "lost": 0,
               "delays": []} for o in curves}
    for b, seed in enumerate(seeds):
        st, u, r = sample_series(stamps, traj.tcv[:, b], traj.reaction_torque[:, b])
        verdict = decisions(observe(FdiSamples(None, seed, st * 1e-9, u, r), weights), curves, persistence)
        for obs, axes in verdict.items():
            alarmed = {a for a, (_, first) in axes.items() if first is not None}
            o = out[obs]
            o["any_alarm"] += bool(alarmed)
            o["wrong_axis"] += bool(alarmed - faulty)
            if faulty:
                o["correct"] += faulty <= alarmed and not alarmed - faulty
                for a in faulty:
                    flags, first = axes[a]
                    onset = min(f.onset for f in runs[b].faults if AXES[f.wheel] == a)
                    after = np.nonzero(flags & (st * 1e-9 >= onset))[0]
                    if after.size:
                        o["delays"].append(float(st[after[0]] * 1e-9 - onset))
                        o["held" if flags[-1] else "lost"] += 1
    return out


def format_screen(name, out) -> str:
    lines = []
    for obs, o in out.items():
        d = np.asarray(o["delays"])
        delay = f"delay median {np.median(d):.0f} s [{d.min():.0f}, {d.max():.0f}]" if d.size else "no detection"
        lines.append(f"{name:20s} {obs:7s} runs {o['runs']:3d}  any alarm {o['any_alarm']:3d}  correct {o['correct']:3d}"
                     f"  wrong axis {o['wrong_axis']:3d}  held {o['held']:3d}  lost {o['lost']:3d}  {delay}")
    return "\n".join(lines)
