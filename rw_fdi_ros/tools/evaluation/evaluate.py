"""`rw-fdi evaluate`: replay bags through the observer and isolation nodes and report every figure.

Bags are replayed (player + the method's observers + isolation + recorder
of the FDI outputs) into ``<report>/replays/<bag>``, many bags through one
graph (tools/campaigns/replay.py): one graph per worker and per ``REPLAY_CHUNK`` bags.
A bag already replayed is not replayed again, so an interrupted evaluation
resumes. A bad bag
(truncated, no ground truth, recorded under other plant choices than the
curves) is reported with its reason and skipped; the rest goes on.
"""
from __future__ import annotations

import json
import time
from contextlib import closing
from dataclasses import replace
from pathlib import Path

import numpy as np

from ...fdi_config import FdiConfig
from ...core.fdi.threshold_file import ThresholdError
from ...core.fdi.elman import ModelError
from ...graph import topics as T
from ...storage.bag import BagError, bag_is_complete, read_bag, read_series
from ..campaigns.campaign import LocalExecutor, _progress
from ...runner.scenario_run import short_step_topics
from ...paths import shown_path
from ...scoring.metrics import RunEval, aggregate, observable_level, health_rows, identification_figures
from ...scoring.bag_series import (fdi_output_topics, health_from_bag, identification_from_bag, scenario_of,
                                   series_from_bag)
from ...core.mission.plant_choices import PlantChoices
from ..design.offline import model_card
from ..campaigns.replay import replay_bags, replay_finished


def find_bags(root) -> list:
    """Every bag directory below ``root`` (a directory with a .mcap file or a rosbag2 metadata.yaml),
    replays excluded: a bag whose data file is gone is answered (skipped, saying so), not passed over."""
    root = Path(root)
    if not root.is_dir():
        raise BagError(f"{root}: no such directory")
    found = [p.parent for pattern in ("*.mcap", "metadata.yaml") for p in root.rglob(pattern)]
    return sorted({b for b in found if "replays" not in b.relative_to(root).parts})


def _check_bag(bag: Path, curves: dict):
    """(scenario, peak |fault effect| per wheel after the first onset) of a bag whose plant choices
    the curves were fitted under, or a one-line reason to skip it."""
    if not list(bag.glob("*.mcap")):
        raise BagError(f"{bag.name}: no .mcap data file (only {', '.join(sorted(p.name for p in bag.iterdir()))})")
    if not bag_is_complete(bag):
        data = read_bag(bag, topics=["/scenario"])
        raise BagError(f"{bag.name}: incomplete bag ({data.note or 'no metadata.yaml'})")
    data = read_series(bag, topics=["/scenario", T.FAULT_EFFECT, T.ATTITUDE, T.PLANT_DONE], intact=True)
    scenario = scenario_of(data)
    if data.last(T.PLANT_DONE) is None:   # read from the file: no replay (and no timeout) spent on it
        end = data.info.span.get(T.ATTITUDE, [0, 0])[1] * 1e-9
        raise BagError(f"{bag.name}: short: the run stopped at {end:g} s of {scenario.duration:g} s "
                       "(no /plant/done: interrupted); evaluation judges whole runs")
    short = short_step_topics(bag)   # after the reasons above: a bag without ground truth says that first
    if short:
        raise BagError(f"{bag.name}: {', '.join(short)} short of the run's end (its recorder lost messages and "
                       "said so): record the run again")
    plant = PlantChoices.of_recording(scenario.plant)
    for c in curves.values():
        c.check_compatible(plant, origin=f"{bag.name}: curves")
        c.check_horizon(scenario.duration, origin=f"{bag.name}: thresholds_{c.observer}.json")
    t, effect = data.wheel_values(T.FAULT_EFFECT)
    onset = min((f.onset for f in scenario.faults), default=None)
    wheels = scenario.wheel_set(recorded=True).count
    peak = np.abs(effect[t >= onset]).max(axis=0) if onset is not None and np.any(t >= onset) else np.zeros(wheels)
    return scenario, peak


# bags per replay graph: start-up is paid once per chunk; a chunk is also the unit of progress
REPLAY_CHUNK = 25


def replay_chunks(bags: list, jobs: int) -> list:
    """``bags`` dealt into chunks of at most REPLAY_CHUNK, at least one per job while there are bags."""
    n = max(min(len(bags), jobs), -(-len(bags) // REPLAY_CHUNK))
    return [bags[i::n] for i in range(n) if bags[i::n]]


def evaluate_replayed(bag: Path, out: Path, scenario, peak, observers=None) -> RunEval:
    """The figures of one bag from its replay ``out`` and its ground truth; ``observers``: those the
    replay must hold (a replay without one of them is refused, not judged by the others alone)."""
    plugins = [obs for obs in observers or () if obs not in T.OBSERVERS]   # a user's observers: their topics too
    replay = read_series(out, topics=fdi_output_topics(plugins))
    series = series_from_bag(replay)
    missing = [obs for obs in observers or () if obs not in series]
    if missing:
        raise ValueError(f"{out.name}: the replay holds no outputs of the {', '.join(missing)} observer")
    return RunEval(bag=str(bag), scenario=scenario.name, seed=scenario.seed, faults=list(scenario.faults),
                   series=series, fault_effect_peak=peak, identification=identification_from_bag(replay),
                   health=health_from_bag(out), wheels=scenario.wheel_set(recorded=True).names)


def judge_bags(chunk) -> list:
    """The core engine's evaluation of a chunk: ``chunk`` = (bags, FdiConfig); [(bag, RunEval or the one-line
    reason it is skipped)]. Each bag is checked as for a
    replay (_check_bag), then the observer and isolation nodes' code runs on its recorded FDI telemetry
    (offline.judge_run), no replay. Module level: process pools and Dask workers run it."""
    from ...core.fdi.calibration import calibration_samples
    from ..design.samples import fdi_samples
    from ..design.offline import judge_run
    bags, fdi = chunk
    weights, curves = fdi.load()
    out = []
    for bag in bags:
        try:
            scenario, peak = _check_bag(bag, curves)
            choices = PlantChoices.of_recording(scenario.plant)
            data = read_bag(bag, topics=[T.FDI_TELEMETRY, T.FDI_BUS_GRID, T.SCENARIO], intact=True)
            samples = fdi_samples(data, choices.fdi_period, choices.fdi_sampling, speed_aware=True,
                                  identification=True)
            out.append((bag, judge_run(scenario, samples, peak, weights, curves, fdi.persistence, identification=True,
                                       calibration_samples=calibration_samples(fdi.unit_calibration), bag=str(bag),
                                       decision=fdi.decision_rule)))
        except (BagError, ValueError, ThresholdError) as exc:
            out.append((bag, str(exc)))
    return out


def _recorded_wheel(bag):
    """The wheel type a bag's run flew (its /scenario), whose tachometer floors what counts as observable
    (metrics.observable_level); None where the bag does not say (said where the bag is checked)."""
    try:
        return scenario_of(read_series(bag, topics=["/scenario"])).spacecraft.wheel
    except (BagError, OSError, ValueError):
        return None


def _recorded_vehicle(bag) -> str:
    """The vehicle a bag's run flew (its /scenario's plant choices; the thesis' for a bag before vehicles): whose
    shipped FDI judges it where none is given (each bag is checked against the bands still, _check_bag)."""
    from ..design.offline import recorded_plant
    try:
        return recorded_plant(bag).vehicle
    except (BagError, OSError, ValueError):
        return PlantChoices().vehicle   # said where the bag is checked


def evaluate(bags_root, report_dir, fdi=None, executor=None, plots: bool = True, engine: str = "graph") -> dict:
    """Judge every bag under ``bags_root`` by the FDI nodes under ``fdi`` (FdiConfig or its mapping; None: the
    shipped FDI): ``engine`` 'graph' replays it through them (report/replays/), 'core' runs their code on its
    recorded telemetry (judge_bags: the same verdicts, test_engine.py). The method follows the models (the
    unit calibration: the observers learn each run's wheels first, core/fdi/calibration.py)."""
    from ..campaigns.engine import check_engine
    check_engine(engine)
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    bags = find_bags(bags_root)
    if not bags:
        raise BagError(f"{bags_root}: no bags to evaluate")
    fdi = FdiConfig.of(fdi)
    fdi = fdi.following_models() if fdi.models else fdi.for_vehicle(_recorded_vehicle(bags[0]))
    fdi.load_models()   # a missing or corrupt model stops here, before any replay
    curves = fdi.load_thresholds()
    fdi = replace(fdi, persistence=fdi.persistence or curves["elman"].persistence)
    models, thresholds, persistence, method = str(fdi.models_dir), str(fdi.thresholds_dir), fdi.persistence, fdi.method
    t0 = time.monotonic()
    runs, skipped = [], []
    executor = executor or LocalExecutor()

    replays = report_dir / "replays"
    bar = _progress(len(bags), "evaluate (replay)" if engine == "graph" else "evaluate (core)")

    def skip(bag, reason):
        skipped.append((str(bag), reason))
        bar.write(f"skipped {bag}: {reason}")
        bar.update(1)

    checked = {}
    if engine == "core":   # each bag checked where it is judged, in the worker processes
        todo, done = [], []
        chunks = [(chunk, fdi)
                  for chunk in replay_chunks(bags, getattr(executor, "jobs", 2))]
        with closing(executor.map_unordered(judge_bags, chunks, processes=True)) as judged:
            for pairs in judged:
                for bag, run in pairs:
                    if isinstance(run, str):
                        skip(bag, run)
                    else:
                        runs.append(run)
                        bar.update(1)
    else:   # interrupted replays are redone
        for bag in bags:
            try:
                checked[bag] = _check_bag(bag, curves)
            except (BagError, ValueError, ThresholdError) as exc:
                skip(bag, str(exc))
        todo = [b for b in checked if not replay_finished(replays / b.name)]
        done = [b for b in checked if b not in todo]

    def replay_chunk(chunk):
        outcomes = replay_bags(chunk, [replays / b.name for b in chunk], fdi)
        return list(zip(chunk, outcomes))

    def collect(bag):
        try:
            runs.append(evaluate_replayed(bag, replays / bag.name, *checked[bag], observers=list(curves)))
            bar.update(1)
        except (BagError, ValueError) as exc:
            skip(bag, str(exc))

    for bag in done:
        collect(bag)
    with closing(executor.map_unordered(replay_chunk, replay_chunks(todo, getattr(executor, "jobs", 2)))) as chunks:
        for pairs in chunks:   # closing: an interruption stops the executor at once
            for bag, outcome in pairs:
                if outcome.ok:
                    collect(bag)
                else:
                    skip(bag, f"{bag.name}: replay failed: {outcome.reason}")
    bar.close()
    runs.sort(key=lambda r: (r.scenario, r.seed))
    level = dict.fromkeys(curves, observable_level(curves, _recorded_wheel(bags[0])))   # one criterion for all
    try:
        training = model_card(models).get("seeds", [])
    except ModelError:   # a model set without its card: nothing known to exclude
        training = []
    figures = aggregate(runs, {obs: c.seeds for obs, c in curves.items()}, level, training, observers=list(curves))
    report = {"schema": "rw_fdi_ros/evaluation/1", "fdi_method": method, "persistence": persistence, "engine": engine,
              "unit_calibration_time": fdi.unit_calibration,
              "models": shown_path(models, report_dir.parent),
              "thresholds": shown_path(thresholds, report_dir.parent), "observable_level_Nm": level, "runs": len(runs),
              "skipped": [{"bag": shown_path(b, bags_root), "reason": r} for b, r in skipped],
              "observers": figures, "identification": identification_figures(runs), "health": health_rows(runs),
              "evaluate_seconds": time.monotonic() - t0}
    (report_dir / "report.json").write_text(json.dumps(report, indent=1))
    from .report import write_markdown, write_plots
    if plots and runs:   # nothing evaluated, nothing to draw (and no empty axes to warn about)
        report["plots"] = [shown_path(p, report_dir) for p in write_plots(runs, figures, report_dir)]
    write_markdown(report, report_dir / "report.md")
    (report_dir / "report.json").write_text(json.dumps(report, indent=1))
    return report


def main_summary(report: dict) -> str:
    lines = [f"evaluated {report['runs']} runs ({len(report['skipped'])} skipped) in "
             f"{report['evaluate_seconds']:.0f} s"]
    for s in report["skipped"]:
        lines.append(f"  skipped {s['bag']}: {s['reason']}")
    return "\n".join(lines)

