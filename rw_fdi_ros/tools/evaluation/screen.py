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

from ...core.calibration import calibration_samples
from ...core.closed_loop import simulate
from ...core.isolation import in_envelope, speed_envelope
from ...graph.topics import DIAGNOSTICS
from ...scoring.metrics import VERDICT, RunEval, decision_slot, judge, observers_of_runs
from ..design.offline import fdi_series, identification_series, observe, verdict_series
from ..design.samples import samples_from_series

BATCH = 50   # runs simulated at once: (4001, 50, 3) arrays, far below memory limits


def load_fdi(models=None, thresholds=None, method: str = "speed_aware", unit_calibration: float = 0.0):
    """(Elman weights, {observer: ThresholdCurves}) of an FDI given by its parts (None: the shipped set of
    ``method`` and ``unit_calibration``): FdiConfig's load, for scripts that call the screen directly."""
    from ...fdi_config import FdiConfig
    return FdiConfig(method, models, thresholds, unit_calibration=unit_calibration).load()


def screen_runs(scenarios, weights, curves, persistence: int | None = None, progress=None,
                identification: bool = False, calibration_samples: int = 0, decision=None) -> list:
    """RunEval of every scenario (one seed each; equal durations within a batch); ``decision``: what makes
    the verdict (core/isolation.DecisionRule; None: the method's decision observer)."""
    return screen_sets(scenarios, {"fdi": (weights, curves)}, persistence, progress, identification,
                       calibration_samples, decision=decision)["fdi"]


def simulated_runs(scenarios, identification: bool = False, check=None, progress=None, on_run=None):
    """(scenario, FdiSamples, fault effect peak per wheel) of every scenario, by the core closed loop in
    batches of BATCH (equal durations and plant choices within a batch): the FDI samples the plant
    node would report. ``check(plant_choices)`` runs before each batch is simulated; ``on_run(scenario,
    trajectory, index)`` sees each run's whole trajectory (what else a bench counts of it)."""
    for start in range(0, len(scenarios), BATCH):
        batch = scenarios[start:start + BATCH]
        choices = batch[0].plant_choices()
        if check:
            check(choices)
        traj = simulate(batch, wheel=batch[0].datasheet(choices), control_period=choices.control_period,
                        wheel_momentum_coupling=choices.wheel_momentum_coupling)
        stamps = np.round(traj.time * 1e9).astype(np.int64)
        for b, scenario in enumerate(batch):
            if on_run is not None:
                on_run(scenario, traj, b)
            samples = samples_from_series(stamps, traj.tcv[:, b], traj.reaction_torque[:, b], traj.wheel_speed[:, b],
                                          seed=scenario.seed, identification=identification, wheels=traj.wheel_names,
                                          wheel_params=scenario.spacecraft.wheel)
            onset = min((f.onset for f in scenario.faults), default=None)
            after = traj.time >= onset if onset is not None else np.zeros(len(traj.time), bool)
            yield scenario, samples, (np.abs(traj.fault_effect[after, b]).max(axis=0) if after.any()
                                      else np.zeros(len(traj.wheel_names)))
        if progress:
            progress(len(batch))


def simulated_samples(scenarios) -> dict:
    """seed -> the FdiSamples of each scenario's run by the core loop (:func:`simulated_runs`): an executor's
    unit of work."""
    return {scenario.seed: samples for scenario, samples, _ in simulated_runs(scenarios)}


def screen_sets(scenarios, fdi_sets: dict, persistence: int | None = None, progress=None,
                identification: bool = False, calibration_samples: int = 0, on_run=None, decision=None,
                other_decisions=()) -> dict:
    """name -> [RunEval] for several FDI sets {name: (weights, curves[, calibration samples])} judged on the
    same simulated runs (a set's own calibration samples, else ``calibration_samples``).

    Besides each observer's series, ``verdict``: what /diagnostics says (the decision observer's alarm,
    latched: offline.verdict_series). ``identification``: also identify the faults of the wheels the
    verdict names (the isolation node's FaultIdentifier), into RunEval.identification. ``on_run``: as in
    :func:`simulated_runs`; ``decision``, ``other_decisions``: as in :func:`judge_run`."""
    out = {name: [] for name in fdi_sets}

    def check(choices):
        for entry in fdi_sets.values():
            for c in entry[1].values():
                c.check_compatible(choices, origin=f"thresholds_{c.observer}.json")
                c.check_horizon(max(s.duration for s in scenarios), origin=f"thresholds_{c.observer}.json")
    for scenario, samples, peak in simulated_runs(scenarios, identification, check, progress, on_run):
        for name, (weights, curves, *own) in fdi_sets.items():
            out[name].append(judge_run(scenario, samples, peak, weights, curves, persistence, identification,
                                       own[0] if own else calibration_samples, decision=decision,
                                       other_decisions=other_decisions))
    return out


def judge_run(scenario, samples, peak, weights, curves, persistence: int | None = None,
              identification: bool = False, calibration_samples: int = 0, bag: str | None = None,
              decision=None, other_decisions=()) -> RunEval:
    """The RunEval of one run from its FDI samples, by the observer and isolation nodes' code: each
    observer's series, ``verdict`` (what /diagnostics says: the ``decision``'s alarm, latched, None: the
    method's decision observer; offline.verdict_series) and with ``identification`` the faults of the wheels
    the verdict names (the isolation node's FaultIdentifier; the samples must carry the bus grid). ``peak``:
    |fault effect| per wheel after the first onset. ``other_decisions`` (core/isolation.DecisionRule): the verdict
    each would give, beside (metrics.decision_slot)."""
    series = fdi_series(observe(samples, weights, calibration_samples=calibration_samples), curves, persistence)
    method = next(iter(curves.values())).method
    envelope = speed_envelope(samples.wheel_params)
    series[VERDICT] = verdict_series(series, method, samples.wheel_speed, wheels=samples.wheels, decision=decision,
                                     envelope=envelope)
    for other in (d for d in other_decisions if set(d.observers) <= set(series)):   # those of this method
        series[decision_slot(other.label)] = verdict_series(series, method, samples.wheel_speed,
                                                            wheels=samples.wheels, decision=other, envelope=envelope)
    found = {}
    if identification and len(samples.time):
        last = identification_series(samples, series[VERDICT].alarm, calibration_samples, last_only=True)[-1]
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


def summarize(runs) -> dict:
    """observer -> counts of the shared verdict (metrics.judge) over ``runs``."""
    out = {}
    for obs in observers_of_runs(runs):
        o = {"runs": len(runs), "any_alarm": 0, "false_alarm": 0, "correct": 0, "wrong_axis": 0, "held": 0,
             "lost": 0, "delays": []}
        for r in runs:
            v = judge(r, obs)
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
    order) under ``fdi`` (FdiConfig; None: the shipped FDI), in batches of BATCH runs on ``executor`` (local
    processes by default, or a Dask cluster: the same runs whatever the executor, each a function of its seed);
    ``progress(n)`` is told each batch of runs done."""
    from ...fdi_config import FdiConfig
    from ..campaigns.campaign import LocalExecutor
    fdi = FdiConfig.of(fdi)
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
    weights, curves = fdi.load()
    return screen_runs([scenario.with_seed(s) for s in seeds], weights, curves, fdi.persistence,
                       identification=True, calibration_samples=calibration_samples(fdi.unit_calibration),
                       decision=fdi.decision_rule)


def format_screen(name, out) -> str:
    lines = []
    for obs, o in out.items():
        d = np.asarray(o["delays"])
        delay = f"delay median {np.median(d):.0f} s [{d.min():.0f}, {d.max():.0f}]" if d.size else "no detection"
        lines.append(f"{name:20s} {obs:7s} runs {o['runs']:3d}  any alarm {o['any_alarm']:3d}  "
                     f"false alarm {o['false_alarm']:3d}  correct {o['correct']:3d}"
                     f"  wrong axis {o['wrong_axis']:3d}  held {o['held']:3d}  lost {o['lost']:3d}  {delay}")
    return "\n".join(lines)

