"""`rw-fdi bench detection`: detection figures on large held-out samples, with 95 % intervals.

Runs nobody tuned for: seeds from 10,000,000 on (training and fitting use
1000-1099, the defaults' held-out runs 5000-5019, the thesis study < 500,000),
faults on every wheel (wheel = seed mod 3) with onsets drawn uniformly in
[60, 300] s from the seed, 400 s runs of the Table 2.3 envelope. Each cell is
simulated once by the core loop (screen) and judged by both FDI methods with
the node code and the shared verdict (tools.metrics.judge).

Targets (issue 10): false alarms <= 0.5 % on fault-free and ripple runs;
correctness >= 99 % at the thesis sizes over observable runs; detection >= 95 %
for a 10 % current loss and +30 C with median delay <= 10 s; alarm held to the
end in >= 99 % of detections.
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...core.scenario import Fault, Scenario
from ..metrics import alarm_before_onset, judge, observable, observable_level
from ..evaluation.screen import load_fdi, screen_sets

SEED_BASE = 10_000_000
ONSET_RANGE = (60.0, 300.0)


@dataclass(frozen=True)
class Cell:
    name: str
    kind: str | None          # None: fault-free
    value: float = 0.0
    ramp: float = 0.0
    disturbance: bool = False  # a change that must not alarm (ripple)
    thesis_size: bool = False  # one of the thesis' headline sizes (Table 4.2)
    target_detection: bool = False  # the small sizes with a detection target


CELLS = (
    Cell("fault_free", None),
    Cell("ripple +40 %", "ripple_gain", 1.4, disturbance=True),
    Cell("ripple +60 %", "ripple_gain", 1.6, disturbance=True),
    Cell("current loss 10 %", "current_limiter", 0.9, target_detection=True),
    Cell("temperature +30 C", "temperature", 53.0, target_detection=True),
    Cell("current loss 40 %", "current_limiter", 0.6, thesis_size=True),
    Cell("temperature +150 C", "temperature", 173.0, thesis_size=True),
    Cell("bus 5.5 V (2.5 V off)", "bus_voltage", 5.5, thesis_size=True),
    Cell("current loss 35 % ramped over 60 s", "current_limiter", 0.65, ramp=60.0),
)


def cell_scenarios(cell: Cell, runs: int, index: int, seed_base: int = SEED_BASE, onset_range=ONSET_RANGE,
                   wheels: dict | None = None) -> list:
    """``runs`` scenarios of one cell: seeds seed_base + 100,000 index + n, fault on wheel seed mod 3
    with an onset drawn from the seed in ``onset_range``; ``wheels``: the scenario's unit variation."""
    out = []
    for n in range(runs):
        seed = seed_base + 100_000 * index + n
        faults = ()
        if cell.kind is not None:
            onset = float(np.round(np.random.default_rng(seed).uniform(*onset_range), 1))
            faults = (Fault(cell.kind, seed % 3, onset, cell.value, cell.ramp),)
        out.append(Scenario(cell.name, duration=400.0, seed=seed, faults=faults, wheels=dict(wheels or {})))
    return out


def screen_cells(sizes, chunk_job, desc: str, jobs: int = 2, chunk: int = 50) -> dict:
    """cell index -> results of ``chunk_job(cell_index, range)`` merged over chunks of ``chunk`` runs,
    ``jobs`` processes (CPU-bound numpy and Python: one per core). chunk_job returns name -> [RunEval]."""
    from tqdm import tqdm
    from ..campaigns.campaign import LocalExecutor, apply
    bar = tqdm(total=sum(sizes), desc=desc, unit="run", file=sys.stderr, mininterval=2.0)
    judged = {i: {} for i in range(len(sizes))}
    calls = [(_cell_chunk, chunk_job, i, range(start, min(start + chunk, n)))
             for i, n in enumerate(sizes) for start in range(0, n, chunk)]
    # the campaigns' executor: SIGTERM or Ctrl-C drops the queued chunks and ends the workers at once
    for i, seeds, out in LocalExecutor(jobs).map_unordered(apply, calls, processes=True):
        for name, runs in out.items():
            judged[i].setdefault(name, []).extend(runs)
        bar.update(len(seeds))
    bar.close()
    return {i: {name: sorted(runs, key=lambda r: r.seed) for name, runs in by_name.items()}
            for i, by_name in judged.items()}


def _cell_chunk(chunk_job, i: int, seeds) -> tuple:
    return i, seeds, chunk_job(i, seeds)


class SpeedAwareChunk:
    """A picklable chunk job for :func:`screen_cells`: the runs ``seeds`` of cell ``cell_index`` as
    ``scenarios(cell_index, seeds, seed_base)`` (a module-level function) makes them, judged by the shipped
    speed-aware FDI; with ``on_run`` (a picklable callable returning objects with a ``seed``) also what
    it says of each run's trajectory, under the name "runs"."""

    def __init__(self, scenarios, seed_base: int, on_run=None):
        self.scenarios, self.seed_base, self.on_run = scenarios, seed_base, on_run

    def __call__(self, cell_index: int, seeds):
        seen = []
        hook = None if self.on_run is None else (lambda sc, traj, b: seen.append(self.on_run(sc, traj, b)))
        out = screen_sets(self.scenarios(cell_index, seeds, self.seed_base),
                          {"speed_aware": load_fdi(method="speed_aware")}, on_run=hook)
        return {**out, "runs": seen} if self.on_run is not None else out


def wilson(k: int, n: int, z: float = 1.96):
    """95 % Wilson score interval of k successes in n trials."""
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def rate(flags) -> dict:
    flags = [bool(f) for f in flags]
    k, n = sum(flags), len(flags)
    lo, hi = wilson(k, n)
    return {"k": k, "n": n, "rate": k / n if n else None, "ci95": [lo, hi]}


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


def _fdi_sets():
    return {"speed_aware": load_fdi(method="speed_aware"), "thesis": load_fdi(method="thesis")}


def _judge_chunk(cell_index: int, seeds_range):
    """One worker's share of a cell: figures need the runs, so the runs come back (small: series only)."""
    cell = CELLS[cell_index]
    scenarios = [s for s in cell_scenarios(cell, seeds_range.stop, cell_index)][seeds_range.start:]
    return screen_sets(scenarios, _fdi_sets())


def observable_levels(sets: dict) -> dict:
    """set -> observer -> axis -> the fault-free residual level a fault effect must rise above to count as
    observable: the set's metrics.observable_level, the same for each of its observers."""
    return {name: {obs: observable_level(entry[1]) for obs in entry[1]} for name, entry in sets.items()}


def cell_sizes(fault_free_runs: int, runs_per_cell: int) -> list:
    """Runs per cell of CELLS: the fault-free cell's, every other cell's."""
    return [fault_free_runs if c.kind is None else runs_per_cell for c in CELLS]


def cell_results(judged: list, sizes: list, seed_base: int, levels: dict, key: str) -> dict:
    """cell name -> the cell, its seeds (cell i from seed_base + 100,000 i) and under ``key`` per FDI set
    and observer its :func:`cell_figures`; ``judged[i]``: set name -> the judged runs of cell i."""
    return {cell.name: {"cell": cell.__dict__,
                        "seeds": [seed_base + 100_000 * i, seed_base + 100_000 * i + sizes[i] - 1],
                        key: {name: {obs: cell_figures(runs, obs, levels[name][obs]) for obs in levels[name]}
                              for name, runs in judged[i].items()}}
            for i, cell in enumerate(CELLS)}


def bench_detection(fault_free_runs: int = 1000, runs_per_cell: int = 200, out: str | Path = "reports/detection",
                    jobs: int = 2) -> dict:
    sets = _fdi_sets()
    levels = observable_levels(sets)
    t0 = time.monotonic()
    sizes = cell_sizes(fault_free_runs, runs_per_cell)
    judged = screen_cells(sizes, _judge_chunk, "detection bench (core loop + node code)", jobs)
    results = cell_results(judged, sizes, SEED_BASE, levels, "methods")
    report = {"schema": "rw_fdi_ros/detection_bench/1", "seconds": time.monotonic() - t0, "jobs": jobs,
              "date": time.strftime("%Y-%m-%d"),
              "fault_free_runs": fault_free_runs, "runs_per_cell": runs_per_cell, "seed_base": SEED_BASE,
              "onset_range_s": ONSET_RANGE,
              "design": {name: {obs: {"method": c.method, "persistence": c.persistence,
                                      "false_alarm_rate": c.false_alarm_rate} for obs, c in curves.items()}
                         for name, (_, curves) in sets.items()},
              "cells": results}
    return write_report(report, out, "detection", format_detection)


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


def _method_label(method: str) -> str:
    return "ours" if method == "speed_aware" else "thesis"


def _columns(report: dict) -> list:
    """(method, observer) of every column the report's cells hold, in the order they were judged."""
    first = next(iter(report["cells"].values()))["methods"]
    return [(method, obs) for method, figures in first.items() for obs in figures]


def format_detection(report: dict) -> str:
    lines = ["# Detection on held-out runs (`rw-fdi bench detection`)", "",
             f"Measured {report.get('date', '?')} on the shipped `config/fdi` (speed-aware) and `config/fdi/thesis` "
             "with the command's defaults.", "",
             f"Seeds from {report['seed_base']:,} (disjoint from training, fitting and the thesis study); faults "
             f"on wheel seed mod 3 with onsets uniform in "
             f"{report['onset_range_s'][0]:g}-{report['onset_range_s'][1]:g} s; "
             f"{report['fault_free_runs']} fault-free runs, {report['runs_per_cell']} per cell. Rates with 95 % Wilson "
             f"intervals. {report['seconds'] / 60:.0f} min on this machine.", "",
             "## False alarms (any alarm in a run that must not alarm)", "",
             "| case | " + " | ".join(f"{_method_label(m)}: {o}" for m, o in _columns(report)) + " |",
             "|---|" + "---|" * len(_columns(report))]
    for name, c in report["cells"].items():
        if c["cell"]["kind"] is None or c["cell"]["disturbance"]:
            m = c["methods"]
            lines.append(f"| {name} | " + " | ".join(format_rate(m[method][o]["false_alarm"])
                                                     for method, o in _columns(report)) + " |")
    for method in ("speed_aware", "thesis"):
        lines += ["", f"## Faults, {'ours (speed-aware)' if method == 'speed_aware' else 'the thesis method'}", "",
                  "| case | observer | correct | correct, observable | detected | delay median / p90 [s] | "
                  "held to end | alarm before onset |", "|---|---|---|---|---|---|---|---|"]
        for name, c in report["cells"].items():
            if c["cell"]["kind"] is None or c["cell"]["disturbance"]:
                continue
            for obs in c["methods"][method]:
                f = c["methods"][method][obs]
                d = f["delay_s"]
                delay = f"{d['median']:.0f} / {d['p90']:.0f}" if d["median"] is not None else "-"
                lines.append(f"| {name} | {obs} | {format_rate(f['correct'])} | "
                             f"{format_rate(f['correct_observable'])} | "
                             f"{format_rate(f['detected'])} | {delay} | {format_rate(f['held_to_end'])} | "
                             f"{format_rate(f['alarm_before_onset'])} |")
    return "\n".join(lines) + "\n"
