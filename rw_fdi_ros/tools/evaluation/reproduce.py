"""`rw-fdi reproduce`: the whole thesis study from nothing, resumable.

fault-free fitting and held-out runs -> Table 4.2 runs (100 per kind at
thesis scale) -> Table 5.1/5.2 grid of fault sizes -> ripple +40 % runs ->
multiple-fault runs -> train -> fit thresholds -> evaluate -> report.
Faults rotate over the x, y and z wheels by seed, so isolation is tested in
every direction. Every stage skips what is already complete.

The runs are recorded and judged by ``engine``: ``core`` (default: the node
code on the core loop, tools/campaigns/engine.py) or ``graph`` (the ROS graph
records, the FDI graph replays). With the core engine the graph stays the
reference: ``graph_sample`` runs of every group are recorded through the graph
too and compared message by message with the core engine's bags, and replayed
through the FDI graph and judged against the core engine's evaluation; the
report says whether they agree.
"""
from __future__ import annotations

import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from ...core.physics.wheel_set import AXIS_WHEELS
from ..campaigns.campaign import CampaignResult, pending, record_campaigns, run_campaign
from ..design.train import EPOCHS


@dataclass(frozen=True)
class Scale:
    duration: float
    onset: float
    fit_runs: int
    heldout_runs: int
    table42_runs: int     # per fault kind
    grid_runs: int        # per fault size
    ripple_runs: int
    multiple_runs: int
    train_runs: int
    epochs: int


SCALES = {
    # CI-sized: every stage and every figure of the report, a few runs each, 120 s runs
    # fit_runs: the fault-free runs of the "fit" group; the first train_runs train, the rest fit thresholds
    "small": Scale(duration=120.0, onset=60.0, fit_runs=12, heldout_runs=2, table42_runs=1, grid_runs=1,
                   ripple_runs=1, multiple_runs=1, train_runs=2, epochs=40),
    "thesis": Scale(duration=400.0, onset=200.0, fit_runs=140, heldout_runs=20, table42_runs=100, grid_runs=10,
                    ripple_runs=20, multiple_runs=20, train_runs=40, epochs=EPOCHS),
}

GROUPS = ("fit", "heldout", "table42", "grid", "ripple", "multiple")   # the study's campaign groups, in order
# (kind, value, label) of thesis Table 4.2 and the Tables 5.1/5.2 grid
TABLE42 = [("bus_voltage", 5.5, "bus_5v5"), ("current_limiter", 0.6, "current_0p6"), ("temperature", 173.0, "temp_150")]
GRID = ([("bus_voltage", 8.0 * (1 - p / 100), f"bus_{p}pct") for p in (10, 20, 30, 40)]
        + [("current_limiter", 1 - p / 100, f"current_{p}pct") for p in (20, 30, 40, 50)]
        + [("temperature", 23.0 + d, f"temp_{d}") for d in (60, 90, 120, 150)])
SMALL_GRID = [GRID[1], GRID[7], GRID[9]]


def _scenario(path: Path, name: str, scale: Scale, faults=()):
    path.write_text(yaml.safe_dump({"name": name, "duration": scale.duration, "seed": 0,
                                    "faults": [dict(f) for f in faults]}, sort_keys=False))
    return str(path)


def plan(out: Path, scale_name: str):
    """[(group, scenario file, runs, seed_start)] of the whole study."""
    s = SCALES[scale_name]
    scen = out / "scenarios"
    scen.mkdir(parents=True, exist_ok=True)
    jobs = [("fit", _scenario(scen / "fault_free.yaml", "fault_free", s), s.fit_runs, 1000),
            ("heldout", _scenario(scen / "fault_free.yaml", "fault_free", s), s.heldout_runs, 5000)]

    def per_axis(group, kind, value, label, runs, seed0, first_axis=0):
        for i, axis in enumerate(AXIS_WHEELS):   # runs spread over the three wheels
            n = runs // 3 + (1 if (i - first_axis) % 3 < runs % 3 else 0)
            if n:
                f = {"kind": kind, "wheel": axis, "onset": s.onset, "value": value}
                jobs.append((group, _scenario(scen / f"{label}_{axis}.yaml", f"{label}_{axis}", s, [f]), n,
                             seed0 + 1000 * i))

    for k, (kind, value, label) in enumerate(TABLE42):
        per_axis("table42", kind, value, label, s.table42_runs, 10000 + 100000 * k, first_axis=k)
    for k, (kind, value, label) in enumerate(GRID if scale_name == "thesis" else SMALL_GRID):
        per_axis("grid", kind, value, label, s.grid_runs, 20000 + 100000 * k, first_axis=k)
    per_axis("ripple", "ripple_gain", 1.4, "ripple_40", s.ripple_runs, 30000, first_axis=1)
    for i, axis in enumerate(AXIS_WHEELS):
        other = AXIS_WHEELS[(i + 2) % 3]
        n = s.multiple_runs // 3 + (1 if i < s.multiple_runs % 3 else 0)
        if n:
            faults = [{"kind": "bus_voltage", "wheel": axis, "onset": s.onset, "value": 5.5},
                      {"kind": "current_limiter", "wheel": other, "onset": s.onset + s.duration / 8, "value": 0.6}]
            jobs.append(("multiple", _scenario(scen / f"multiple_{axis}{other}.yaml", f"multiple_{axis}{other}", s,
                                               faults), n, 40000 + 1000 * i))
    return jobs


def _commit():
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).resolve().parents[2]).stdout.strip()
    except OSError:
        return ""


class StageClock:
    """Stage times of a study over all its sessions (a resumed study adds to what it already spent).

    Kept in ``<out>/stages.json``: per stage the seconds and runs done, summed over sessions for
    stages that resume (recording, evaluation) and replaced for stages that are redone whole
    (threshold fitting); a stage that found nothing to do keeps its earlier figures.
    """

    def __init__(self, out: Path, command: str):
        self.path = out / "stages.json"
        self.data = {"stages": {}, "sessions": []}
        if self.path.exists():
            self.data = json.loads(self.path.read_text())
        else:   # a study begun before stages.json existed: its report holds the first session
            old = out / "report" / "report.json"
            if old.exists():
                prev = json.loads(old.read_text())
                self.data["stages"] = {k: v for k, v in prev.get("stages", {}).items() if k != "total"}
                if "total" in prev.get("stages", {}):
                    self.data["sessions"].append({**prev.get("provenance", {}),
                                                  "seconds": prev["stages"]["total"]["seconds"]})
        self.session = {"command": command, "commit": _commit(), "seconds": 0.0}
        self.data["sessions"].append(self.session)
        self.t0 = time.monotonic()

    def add(self, name: str, seconds: float, runs: int, redo: bool = False):
        old = self.data["stages"].get(name)
        if old is None or redo:
            self.data["stages"][name] = {"seconds": seconds, "runs": runs}
        elif runs:
            self.data["stages"][name] = {"seconds": old["seconds"] + seconds, "runs": old["runs"] + runs}
        self.save()

    def save(self):
        self.session["seconds"] = time.monotonic() - self.t0
        self.path.write_text(json.dumps(self.data, indent=1))

    def stages(self) -> dict:
        total = sum(s["seconds"] for s in self.data["sessions"])
        return {**self.data["stages"], "total": {"seconds": total, "runs": None}}


def graph_check(out: Path, jobs, sample: int, executor, models: Path, persistence) -> dict:
    """The graph as reference for a core-engine study: the first ``sample`` seeds of each group's first
    campaign recorded again through the graph (``out/graph_sample``), compared with the core engine's bags
    message by message, and evaluated by both engines (replay through the FDI graph, and the core
    engine's node code): what agreed."""
    from ...storage.compare import bag_differences
    from .evaluate import evaluate
    from concurrent.futures import ThreadPoolExecutor
    from ..campaigns.campaign import LocalExecutor
    root = out / "graph_sample"
    compared, differing = 0, []
    firsts = [next(j for j in jobs if j[0] == g) for g in GROUPS if any(j[0] == g for j in jobs)]
    local = executor is None or isinstance(executor, LocalExecutor)
    jobs_at_once = getattr(executor, "jobs", None) or LocalExecutor().jobs

    def record(job):   # the groups' samples side by side: one graph each, ``jobs`` at once
        group, scenario, runs, seed = job
        return group, run_campaign(scenario, min(sample, runs), seed, root / "bags" / group,
                                   executor=LocalExecutor(1) if local else executor, desc=f"graph sample {group}",
                                   engine="graph")
    with ThreadPoolExecutor(jobs_at_once) as pool:
        recorded = list(pool.map(record, firsts))
    for group, res in recorded:
        for bag in sorted(res.done + res.skipped):
            compared += 1
            diff = bag_differences(bag, out / "bags" / group / bag.name, limit=3)
            if diff:
                differing.append({"bag": f"{group}/{bag.name}", "differences": diff})
        differing += [{"bag": f"{group}/seed {s}", "differences": [f"graph run failed: {r}"]} for s, r in res.failed]
    reports = {engine: evaluate(root / "bags", root / f"report_{engine}",
                                {"models": models, "persistence": persistence}, executor=executor, plots=False,
                                engine=engine)
               for engine in ("graph", "core")}
    keys = ("observers", "identification", "health")
    return {"runs": compared, "identical_bags": compared - len(differing), "differing": differing,
            "evaluated": reports["graph"]["runs"],
            "evaluation_agrees": all(reports["graph"][k] == reports["core"][k] for k in keys),
            "disagreeing": [k for k in keys if reports["graph"][k] != reports["core"][k]]}


def _replayed(replays: Path) -> int:
    """The complete replays under ``replays``: a stalled one leaves an incomplete directory behind."""
    from ...storage.bag import bag_is_complete
    return sum(bag_is_complete(p) for p in replays.iterdir()) if replays.is_dir() else 0


def _record_group(out: Path, group: str, mine: list, executor, engine: str) -> int:
    """Record one group's campaigns ``mine`` ((scenario, runs, seed)) under out/bags/<group>; the runs done."""
    if engine == "core":   # the group's campaigns share batches: a grid of small ones costs one large one
        campaigns = []
        for scenario, runs, seed in mine:
            todo, skipped = pending(scenario, runs, seed, out / "bags" / group)
            campaigns.append((scenario, todo, out / "bags" / group, CampaignResult([], skipped, [])))
        results = record_campaigns(campaigns, executor, desc=f"{group} ({len(mine)} campaigns)")
    else:
        results = [run_campaign(scenario, runs, seed, out / "bags" / group, executor=executor,
                                desc=f"{group} {Path(scenario).stem}", engine=engine)
                   for scenario, runs, seed in mine]
    for (scenario, _, _), res in zip(mine, results):
        if res.failed:
            print(f"{len(res.failed)} runs failed in {Path(scenario).stem}: {res.failed[0][1]}", file=sys.stderr)
    return sum(len(res.done) for res in results)


def reproduce(out, scale_name: str = "small", executor=None, persistence: int | None = None, engine: str = "core",
              graph_sample: int = 1) -> dict:
    from .evaluate import evaluate
    from ...core.fdi.detection import FALSE_ALARM_RATE
    from ...core.fdi.threshold_fit import rate_carried
    from ..design.offline import fit_thresholds, load_models, plant_conditions
    from ..design.samples import load_samples
    from ..design.train import train_models
    out = Path(out)
    s = SCALES[scale_name]
    jobs = plan(out, scale_name)
    # the directory's name: no machine path
    command = f"rw-fdi reproduce --out {out.name} --scale {scale_name}" + (f" --engine {engine}" if engine != "core"
                                                                            else "")
    clock = StageClock(out, command)
    print(f"reproduce ({scale_name}): {sum(j[2] for j in jobs)} runs in {len(jobs)} campaigns -> {out}",
          file=sys.stderr, flush=True)
    for group in GROUPS:
        t = time.monotonic()
        n = _record_group(out, group, [(sc, runs, seed) for g, sc, runs, seed in jobs if g == group], executor, engine)
        clock.add(f"record {group}", time.monotonic() - t, n)

    models = out / "models"
    t = time.monotonic()
    recorded = sorted(load_samples(out / "bags" / "fit", on_skip=lambda m: print(f"skipped {m}", file=sys.stderr)),
                      key=lambda x: x.seed)
    train, fit = recorded[:s.train_runs], recorded[s.train_runs:]   # never the same run for both
    if not (models / "model_set.json").exists():
        train_models(train, models, mode="recall", epochs=s.epochs, plant=plant_conditions(recorded))
        clock.add("train", time.monotonic() - t, len(train), redo=True)
    t = time.monotonic()
    # the designed rate, or the smallest the fitting runs can carry (the small scale's 10: 0.006)
    fit_thresholds(fit, load_models(models), models, model_ref=str(models),
                   false_alarm_rate=max(FALSE_ALARM_RATE, rate_carried(len(fit))))
    clock.add("fit thresholds", time.monotonic() - t, len(fit), redo=True)
    t = time.monotonic()
    before = _replayed(out / "report" / "replays")
    report = evaluate(out / "bags", out / "report", {"models": models, "persistence": persistence},
                      executor=executor, engine=engine)
    if engine == "core":
        clock.add("evaluate (core)", time.monotonic() - t, report["runs"], redo=True)
    else:
        clock.add("evaluate (replay)", time.monotonic() - t, _replayed(out / "report" / "replays") - before)
    report["engines"] = {"recorded_and_judged_by": engine}
    if engine == "core" and graph_sample > 0:
        t = time.monotonic()
        check = graph_check(out, jobs, graph_sample, executor, models, persistence)
        clock.add("graph sample (record, replay, compare)", time.monotonic() - t, check["runs"], redo=True)
        report["engines"]["graph_sample"] = check
    clock.save()
    report["stages"] = clock.stages()
    report["stages"]["total"]["runs"] = sum(j[2] for j in jobs)
    report["provenance"] = {"command": command, "commit": clock.session["commit"], "scale": scale_name,
                            "sessions": clock.data["sessions"]}
    from .report import write_markdown
    write_markdown(report, out / "report" / "report.md")
    (out / "report" / "report.json").write_text(json.dumps(report, indent=1))
    return report
