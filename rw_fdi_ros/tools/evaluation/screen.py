"""`rw-fdi screen`: FDI verdicts for many seeds without ROS, by the node code on the core loop.

The core closed loop (the plant and PID code the nodes run) simulates a
batch of runs; TelemetrySampler, the observers and ObserverChannel (the code
the observer and isolation nodes run) make the series the isolation node
would publish, and scoring.metrics.judge (the verdict `rw-fdi evaluate` uses)
judges them. The graph gives the same verdicts (test_screen_matches_graph.py);
use it for large samples, `rw-fdi evaluate` on recorded bags for replays.
"""
from __future__ import annotations

import numpy as np

from ...core.flight import Fdir
from ...scoring.metrics import judge as judge_verdict, observers_of_runs
from ..design.offline import judge_run
from ..design.samples import BATCH, simulated_runs


def load_fdi(models=None, thresholds=None, method: str = "speed_aware", unit_calibration: float = 0.0):
    """(Elman weights, {observer: ThresholdCurves}) of an FDI given by its parts (None: the shipped set of
    ``method`` and ``unit_calibration``): FdiConfig's load, for scripts that call the screen directly."""
    from ...fdi_config import FdiConfig
    return FdiConfig(method, models, thresholds, unit_calibration=unit_calibration).load()


def screen_runs(scenarios, weights, curves, persistence: int | None = None, progress=None,
                identification: bool = False, calibration_samples: int = 0, decision=None, fdir=None) -> list:
    """RunEval of every scenario (one seed each; equal durations within a batch); ``decision``: what makes
    the verdict (core/fdi/verdict.DecisionRule; None: the method's decision observer); ``fdir``
    (flight.Fdir): the core loop reconfigures on its FDI's verdict, as the graph's allocation does."""
    return screen_sets(scenarios, {"fdi": (weights, curves)}, persistence, progress, identification,
                       calibration_samples, decision=decision, fdir=fdir)["fdi"]


def screen_sets(scenarios, fdi_sets: dict, persistence: int | None = None, progress=None,
                identification: bool = False, calibration_samples: int = 0, on_run=None, decision=None,
                other_decisions=(), fdir=None) -> dict:
    """name -> [RunEval] for several FDI sets {name: (weights, curves[, calibration samples])} judged on the
    same simulated runs (a set's own calibration samples, else ``calibration_samples``).

    Besides each observer's series, ``verdict``: what /diagnostics says (the decision observer's alarm,
    latched: offline.judge). ``identification``: also identify the faults of the wheels the
    verdict names (the isolation node's FaultIdentifier), into RunEval.identification. ``on_run``: as in
    :func:`simulated_runs`; ``decision``, ``other_decisions``: as in :func:`judge_run`; ``fdir``: FDIR in the
    loop (flight.Fdir), its acts into RunEval.reconfiguration."""
    out = {name: [] for name in fdi_sets}
    acts = {}

    def seen(scenario, traj, b):
        acts["run"] = [(d.time, d.wheel, d.action, d.reason) for d in traj.decisions[b]] if traj.decisions else []
        if on_run is not None:
            on_run(scenario, traj, b)

    def check(choices):
        for entry in fdi_sets.values():
            for c in entry[1].values():
                c.check_compatible(choices, origin=f"thresholds_{c.observer}.json")
                c.check_horizon(max(s.duration for s in scenarios), origin=f"thresholds_{c.observer}.json")
    for scenario, samples, peak in simulated_runs(scenarios, identification, check, progress, seen, fdir):
        for name, (weights, curves, *own) in fdi_sets.items():
            run = judge_run(scenario, samples, peak, weights, curves, persistence, identification,
                            own[0] if own else calibration_samples, decision=decision, other_decisions=other_decisions)
            run.reconfiguration = acts["run"]
            out[name].append(run)
    return out


def summarize(runs) -> dict:
    """observer -> counts of the shared verdict (metrics.judge) over ``runs``."""
    out = {}
    for obs in observers_of_runs(runs):
        o = {"runs": len(runs), "any_alarm": 0, "false_alarm": 0, "correct": 0, "wrong_axis": 0, "held": 0,
             "lost": 0, "delays": []}
        for r in runs:
            v = judge_verdict(r, obs)
            o["any_alarm"] += bool(v["alarmed_wheels"])
            o["false_alarm"] += v["false_alarm"]
            if "axes" in v:
                o["correct"] += v["correct"]
                o["wrong_axis"] += bool(v["wrong_axes"])
                for f in v["axes"].values():
                    if f["detected"]:
                        o["delays"].append(f["delay"])
                        o["held" if f["held_to_end"] else "lost"] += 1
        out[obs] = o
    return out


def screen(scenario, seeds, fdi=None, progress=None, executor=None) -> tuple:
    """(counts per observer over ``seeds`` of one scenario (see :func:`summarize`), the runs (RunEval) in seed
    order) under ``fdi`` (FdiConfig; None: the shipped FDI, detection alone; its ``fdir``: FDIR reconfigures
    in the loop as in the graph, the runs' acts in RunEval.reconfiguration), in batches of BATCH runs on
    ``executor`` (local processes by default, or a Dask cluster: the same runs whatever the executor, each a
    function of its seed);
    ``progress(n)`` is told each batch of runs done."""
    from ...fdi_config import FdiConfig
    from ..campaigns.campaign import LocalExecutor
    fdi = FdiConfig(fdir=False) if fdi is None else FdiConfig.of(fdi)
    if fdi.fdir and fdi.method != "speed_aware":
        raise ValueError("FDIR in the core loop (screen --fdir) runs the speed_aware FDI; the thesis method's "
                         "reconfiguration runs in the graph (rw-fdi run --fdi-method thesis)")
    seeds = list(seeds)
    executor = executor or LocalExecutor()
    size = min(BATCH, max(1, -(-len(seeds) // getattr(executor, "jobs", 8))))   # every worker busy on a few seeds
    batches = [(scenario, seeds[i:i + size], fdi) for i in range(0, len(seeds), size)]
    runs = []
    for out in executor.map_unordered(_screen_batch, batches, processes=True):
        runs += out
        if progress:
            progress(len(out))
    order = {seed: i for i, seed in enumerate(seeds)}
    runs.sort(key=lambda r: order[r.seed])   # seed order, whatever order the batches came back in
    return summarize(runs), runs


def _screen_batch(work) -> list:
    """The RunEval of one batch (scenario, seeds, FdiConfig): what a worker computes."""
    scenario, seeds, fdi = work
    loaded = fdi.loaded(scenario.plant_choices().fdi_period)
    fdir = Fdir(loaded, scenario.plant_choices().fdi_period, identification=True) if fdi.fdir else None
    return screen_runs([scenario.with_seed(s) for s in seeds], loaded.models, loaded.curves, fdi.persistence,
                       identification=True, calibration_samples=loaded.calibration_samples,
                       decision=fdi.decision_rule, fdir=fdir)


def format_screen(name, out) -> str:
    lines = []
    for obs, o in out.items():
        d = np.asarray(o["delays"])
        delay = f"delay median {np.median(d):.0f} s [{d.min():.0f}, {d.max():.0f}]" if d.size else "no detection"
        lines.append(f"{name:20s} {obs:7s} runs {o['runs']:3d}  any alarm {o['any_alarm']:3d}  "
                     f"false alarm {o['false_alarm']:3d}  correct {o['correct']:3d}"
                     f"  wrong axis {o['wrong_axis']:3d}  held {o['held']:3d}  lost {o['lost']:3d}  {delay}")
    return "\n".join(lines)

