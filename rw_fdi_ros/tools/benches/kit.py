"""What every bench shares: cells of runs and their scenarios, the pool that screens them (stoppable), rates
with their 95 % Wilson intervals, and the report files (JSON, Markdown, one CSV row a run)."""
from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path

import numpy as np

from ...fdi_config import FdiConfig
from ...core.physics.environment import OrbitEnvironment
from ...core.mission.scenario import Manoeuvres, Scenario, vehicle_scenario as core_vehicle_scenario
from ...core.mission.vehicle import DEFAULT_VEHICLE, load_vehicle, shipped_vehicles
from ...core.physics.wheel import NOMINAL
from ...core.physics.faults import drawn_fault
from ...core.physics.wheel_set import DEFAULT_WHEEL_SET, WHEEL_SETS, WheelSet, fault_wheel  # noqa: F401 (the benches')
from ...scoring.metrics import alarm_before_onset, judge, observable, rate
from ..evaluation.screen import screen_sets
from .journal import finish

SEED_BASE = 10_000_000         # the detection bench's; every bench passes its own
ONSET_RANGE = (60.0, 300.0)


@dataclass(frozen=True)
class Cell:
    """One row of a bench: the runs of one fault (or none) under one set of conditions.

    Every bench builds its cells from this one type, varies the fields it names and leaves the others at
    their defaults; its report holds only its own fields (:meth:`as_dict`). ``None``: the bench's own."""
    name: str
    kind: str | None = None         # None: fault-free
    value: float = 0.0
    ramp: float = 0.0               # [s] over which the fault grows to its value
    disturbance: bool = False       # a change that must not alarm (ripple)
    thesis_size: bool = False       # one of the thesis' headline sizes (Table 4.2)
    target_detection: bool = False  # the small sizes with a detection target
    onset_range: tuple | None = None   # (earliest, latest) fault onset [s]
    duration: float | None = None      # [s]
    wheel_speed: float | None = None   # every wheel's initial speed [rad/s]; None: Table 2.3's 20-30
    speeds: tuple = (20.0, 30.0)       # initial wheel speeds, uniform per wheel [rad/s]
    second: tuple | None = None        # (kind, value) of a later fault on the standby wheel, 100 s after
    manoeuvres: Manoeuvres | None = None
    tumbles: bool = False              # a bus drop that can leave its axis without control
    environment: OrbitEnvironment = field(default_factory=OrbitEnvironment)

    def as_dict(self, names) -> dict:
        """The fields ``names``, in that order: what a bench's report says of its cell.

        Parameters
        ----------
        names : sequence of str
            Field names.

        Returns
        -------
        dict
            Name to value.
        """
        return {name: getattr(self, name) for name in names}


# what the detection and identification benches vary and report of a cell
DETECTION_FIELDS = ("name", "kind", "value", "ramp", "disturbance", "thesis_size", "target_detection")


# the votes of the three speed-aware observers the benches judge beside /diagnostics' decision (an observer
# alone is its own column; docs/fdi.md "The decision")
VOTES = ("2of3", "3of3")


@lru_cache(maxsize=None)
def vehicle_scenario(vehicle: str) -> Scenario:
    """A 400-s run of ``vehicle`` (a shipped name or a vehicle's FDI directory) through the scenario file's own
    checks (its wheel set, plant choices and dispersions): what a bench's cells fly on another vehicle than the
    thesis'."""
    return core_vehicle_scenario(vehicle)


def vehicle_words(vehicle: str) -> str:
    """How a report names the vehicle its runs flew: a shipped one's name, or a user's name with its FDI
    directory."""
    return vehicle if vehicle in shipped_vehicles() else f"{load_vehicle(vehicle).name} (its FDI in `{vehicle}`)"


def bench_scenario(vehicle: str, name: str, **fields) -> Scenario:
    """A bench run of ``vehicle`` (a shipped name): the thesis' as Scenario(name, 400 s, **fields) makes it,
    another's from :func:`vehicle_scenario` with ``fields`` replaced (its source text cleared: a bag of it
    records what the run is, not the template's)."""
    if vehicle == DEFAULT_VEHICLE:
        return Scenario(name, **{"duration": 400.0, **fields})
    return replace(vehicle_scenario(vehicle), name=name, source_text="", **fields)


@lru_cache(maxsize=None)
def bus_scale(vehicle: str) -> float:
    """V_bus / 8 V of ``vehicle``'s wheel: the factor a bench's bus cells, written for the Type A's 8-V bus
    (thesis Table 2.3), fly at on the vehicle's."""
    return 1.0 if vehicle == DEFAULT_VEHICLE else load_vehicle(vehicle).wheel.bus_voltage / NOMINAL.bus_voltage


def on_bus(name: str, kind: str | None, value, vehicle: str) -> tuple:
    """(name, value) of a bench's fault on ``vehicle``'s bus: a bus drop keeps its share of the bus (5.5 V of
    8 V flies at 8.25 V of 12 V), and its name says the vehicle's volts; any other fault as it is. ``value``:
    a size or a (low, high) range."""
    scale = bus_scale(vehicle)
    if kind != "bus_voltage" or scale == 1.0:
        return name, value
    scaled = tuple(v * scale for v in value) if isinstance(value, tuple) else value * scale
    return re.sub(r"\d+(?:\.\d+)?(?=(?:-\d+(?:\.\d+)?)? V\b)", lambda m: f"{float(m[0]) * scale:.3g}", name), scaled


def cell_on_bus(cell: Cell, vehicle: str) -> Cell:
    """``cell`` on ``vehicle``'s bus (:func:`on_bus`), its later fault too."""
    name, value = on_bus(cell.name, cell.kind, cell.value, vehicle)
    second = cell.second and (cell.second[0], on_bus("", *cell.second, vehicle)[1])
    return replace(cell, name=name, value=value, second=second)


def bench_wheels(vehicle: str) -> WheelSet:
    """The wheel set the bench runs of ``vehicle`` fly."""
    return WHEEL_SETS[DEFAULT_WHEEL_SET] if vehicle == DEFAULT_VEHICLE else vehicle_scenario(vehicle).wheel_set()


def cell_scenarios(cell: Cell, runs: int, index: int, seed_base: int = SEED_BASE, onset_range=ONSET_RANGE,
                   wheels: dict | None = None, vehicle: str = DEFAULT_VEHICLE) -> list:
    """``runs`` scenarios of one cell: seeds seed_base + 100,000 index + n, fault on a wheel in use
    (:func:`fault_wheel`) with an onset drawn from the seed in ``onset_range``; ``wheels``: the scenario's unit
    variation; ``vehicle``: the shipped vehicle they fly (default: the thesis')."""
    wheel_set = bench_wheels(vehicle)
    out = []
    for n in range(runs):
        seed = seed_base + 100_000 * index + n
        faults = ()
        if cell.kind is not None:
            faults = (drawn_fault(cell.kind, cell.value, seed, wheel_set, onset_range, cell.ramp),)
        out.append(bench_scenario(vehicle, cell.name, seed=seed, faults=faults, wheels=dict(wheels or {})))
    return out


def workers(executor) -> int | str:
    """What a report says ran it: the local processes' count, or the Dask scheduler's address."""
    return getattr(executor, "jobs", None) or getattr(executor, "address", "dask")


def screen_cells(sizes, chunk_job, desc: str, executor=None, chunk: int = 50, out=None, name: str = "") -> dict:
    """cell index -> results of ``chunk_job(cell_index, range)`` merged over chunks of ``chunk`` runs, on
    ``executor`` (campaign.make_executor: local processes, one per core by default, or a Dask cluster; the
    work is CPU-bound numpy and Python). chunk_job returns name -> [RunEval]. With ``out``, the finished
    chunks are kept there as they come and an interrupted bench resumes (journal.resumable_map, ``name``)."""
    from tqdm import tqdm
    from ..campaigns.campaign import LocalExecutor, apply
    from .journal import resumable_map
    bar = tqdm(total=sum(sizes), desc=desc, unit="run", file=sys.stderr, mininterval=2.0)
    judged = {i: {} for i in range(len(sizes))}
    calls = [(_cell_chunk, chunk_job, i, range(start, min(start + chunk, n)))
             for i, n in enumerate(sizes) for start in range(0, n, chunk)]
    # the campaigns' executor: SIGTERM or Ctrl-C drops the queued chunks and ends the workers at once
    executor = executor or LocalExecutor()
    done = (resumable_map(executor, apply, calls, out, name) if out is not None
            else executor.map_unordered(apply, calls, processes=True))
    for i, seeds, result in done:
        bar.update(len(seeds))
        for observer, runs in result.items():
            judged[i].setdefault(observer, []).extend(runs)
    bar.close()
    return {i: {observer: sorted(runs, key=lambda r: r.seed) for observer, runs in by_name.items()}
            for i, by_name in judged.items()}


def _cell_chunk(chunk_job, i: int, seeds) -> tuple:
    return i, seeds, chunk_job(i, seeds)


class SpeedAwareChunk:
    """A picklable chunk job for :func:`screen_cells`: the runs ``seeds`` of cell ``cell_index`` as
    ``scenarios(cell_index, seeds, seed_base)`` (a module-level function) makes them, judged by the shipped
    speed-aware FDI; with ``on_run`` (a picklable callable returning objects with a ``seed``) also what
    it says of each run's trajectory, under the name "runs". ``decisions``: the labels of other decisions
    whose verdicts are judged beside /diagnostics' (core/fdi/verdict.decision_of, e.g. '2of3')."""

    def __init__(self, scenarios, seed_base: int, on_run=None, decisions=(), vehicle: str = DEFAULT_VEHICLE,
                 fdi: FdiConfig | None = None):
        self.scenarios, self.seed_base, self.on_run = scenarios, seed_base, on_run
        self.decisions, self.vehicle = tuple(decisions), vehicle   # the vehicle's shipped FDI judges
        self.fdi = fdi or FdiConfig()   # or ours as configured: a user's observers beside (FdiConfig.plugins)

    def __repr__(self):   # what a bench journal's signature reads (journal.work_signature)
        return (f"SpeedAwareChunk({self.scenarios!r}, {self.seed_base}, {self.on_run!r}, {self.decisions}, "
                f"{self.vehicle!r}, {self.fdi!r})")

    def __call__(self, cell_index: int, seeds):
        from ...core.fdi.verdict import decision_of
        seen = []
        hook = None if self.on_run is None else (lambda sc, traj, b: seen.append(self.on_run(sc, traj, b)))
        out = screen_sets(self.scenarios(cell_index, seeds, self.seed_base),
                          {"speed_aware": self.fdi.for_vehicle(self.vehicle).load()}, on_run=hook,
                          other_decisions=tuple(decision_of(d, "speed_aware") for d in self.decisions))
        return {**out, "runs": seen} if self.on_run is not None else out


def configured(fdi) -> dict | None:
    """What a bench's report says of an FDI given instead of the shipped one (FdiConfig; None: the shipped)."""
    if fdi is None:
        return None
    return {"thresholds": str(fdi.thresholds_dir), "plugins": list(fdi.plugins), "slots": list(fdi.plugin_slots)}


def own_fdi(report: dict) -> str:
    """How a report names the FDI it was measured on when none was given: the shipped one of its vehicle, or the
    one in the vehicle's directory (``rw-fdi defaults --vehicle FILE --out DIR``)."""
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    return "the shipped speed-aware FDI" if vehicle in shipped_vehicles() else f"the speed-aware FDI in `{vehicle}`"


def fdi_phrase(report: dict, shipped: str) -> str:
    """``shipped``, or the FDI the report was measured on where it was given (:func:`configured`)."""
    given = report.get("configured")
    if not given:
        return shipped
    return (f"the FDI in `{given['thresholds']}` (ours fitted there beside the user's observers "
            f"{', '.join(given['slots'])}: {', '.join(f'`{p}`' for p in given['plugins'])}; docs/observers.md)")


def cell_figures(runs, observer: str, observable_level: dict) -> dict:
    verdicts = [judge(r, observer) for r in runs]
    if runs and runs[0].category in ("fault_free", "disturbance"):
        return {"false_alarm": rate(v["false_alarm"] for v in verdicts)}
    figs = [f for v in verdicts for f in v["axes"].values()]
    det = [f for f in figs if f["detected"]]
    seen = [v["correct"] for r, v in zip(runs, verdicts) if observable(r, observable_level)]
    delays = np.array([f["delay"] for f in det]) if det else np.zeros(0)
    early = [alarm_before_onset(r, observer) for r in runs]
    return {"correct": rate(v["correct"] for v in verdicts), "correct_observable": rate(seen),
            "detected": rate(f["detected"] for f in figs), "held_to_end": rate(f["held_to_end"] for f in det),
            "alarm_before_onset": rate(early),
            "delay_s": {"median": float(np.median(delays)) if delays.size else None,
                        "p90": float(np.percentile(delays, 90)) if delays.size else None}}


def write_report(report: dict, out, name: str, formatter) -> dict:
    """``report`` as <out>/<name>.json and its text (``formatter``) as <out>/<name>.md, and where it keeps its
    runs (a list of dicts under "runs") a table of them, one row a run (<out>/<name>_runs.csv:
    :func:`write_runs_table`); the report with its text, ok, as the bench commands return it."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.json").write_text(json.dumps(report, indent=1))
    runs = report.get("runs")
    if isinstance(runs, list) and runs and all(isinstance(r, dict) for r in runs):
        write_runs_table(runs, out / f"{name}_runs.csv")
    report["text"] = formatter(report)
    (out / f"{name}.md").write_text(report["text"])
    finish(out, name)   # whole: its runs kept for a resume are no longer needed
    report["ok"] = True
    return report


def runs_table(runs: list) -> tuple:
    """(columns, rows) of per-run dicts as a flat table: nested dicts flattened with dots (identification.kind),
    lists as JSON text, every run's keys in the order they first come."""
    def flat(d, prefix=""):
        for k, v in d.items():
            if isinstance(v, dict):
                yield from flat(v, f"{prefix}{k}.")
            else:
                yield f"{prefix}{k}", json.dumps(v) if isinstance(v, (list, tuple)) else v
    rows = [dict(flat(r)) for r in runs]
    columns = list(dict.fromkeys(k for row in rows for k in row))
    return columns, [[row.get(c, "") for c in columns] for row in rows]


def write_cells_table(judged: dict, cell_names, out, name: str) -> Path:
    """The judged runs of :func:`screen_cells` as <out>/<name>_runs.csv: one row a run and FDI set, its cell and
    set named beside metrics.run_row's columns (seed, faults, each observer's verdict and delay, the
    identification)."""
    from ...scoring.metrics import RunEval, run_row
    rows = [{"cell": cell_names[i], "fdi": fdi, **run_row(r)} for i, by_fdi in sorted(judged.items())
            for fdi, runs in by_fdi.items() for r in runs if isinstance(r, RunEval)]
    Path(out).mkdir(parents=True, exist_ok=True)
    return write_runs_table(rows, Path(out) / f"{name}_runs.csv")


def write_runs_table(runs: list, path) -> Path:
    """The runs as CSV (pandas.read_csv, polars.read_csv): one row a run, :func:`runs_table`'s columns."""
    import csv
    columns, rows = runs_table(runs)
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(columns)
        writer.writerows(rows)
    return Path(path)


def format_rate(r: dict) -> str:
    """'12.5 % [8.6, 17.8] (n=200)': a rate with its 95 % interval and sample size."""
    if not r or r["n"] == 0:
        return "-"
    lo, hi = r["ci95"]
    return f"{r['rate'] * 100:.1f} % [{lo * 100:.1f}, {hi * 100:.1f}] (n={r['n']})"
