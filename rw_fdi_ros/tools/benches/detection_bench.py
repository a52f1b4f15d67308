"""`rw-fdi bench detection`: detection figures on large held-out samples, with 95 % intervals.

Runs nobody tuned for: seeds from 10,000,000 on (training and fitting use
1000-1099, the defaults' held-out runs 5000-5019, the thesis study < 500,000),
faults on every wheel (wheel = seed mod 3) with onsets drawn uniformly in
[60, 300] s from the seed, 400 s runs of the Table 2.3 envelope. Each cell is
simulated once by the core loop (screen) and judged by both FDI methods with
the node code and the shared verdict (scoring.metrics.judge).

Targets: false alarms <= 0.5 % on fault-free and ripple runs;
correctness >= 99 % at the thesis sizes over observable runs; detection >= 95 %
for a 10 % current loss and +30 C with median delay <= 10 s; alarm held to the
end in >= 99 % of detections.
"""
from __future__ import annotations

import time
from functools import partial
from pathlib import Path


from ...fdi_config import FdiConfig
from ...core.mission.vehicle import DEFAULT_VEHICLE, load_vehicle
from ...core.fdi.verdict import decision_of
from ...scoring.metrics import observable_level, observers_of_runs
from ..evaluation.screen import screen_sets
from .kit import (DETECTION_FIELDS, VOTES, ONSET_RANGE, SEED_BASE, Cell, cell_figures, cell_on_bus, cell_scenarios,
                  configured,
                  fdi_phrase, format_rate, screen_cells, workers, write_cells_table, write_report, shipped_vehicles,
                  vehicle_words)


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


def cells_of(vehicle: str = DEFAULT_VEHICLE) -> tuple:
    """CELLS as ``vehicle`` flies them: its bus drops at the same share of its bus (kit.cell_on_bus)."""
    return tuple(cell_on_bus(c, vehicle) for c in CELLS)




def _fdi_sets(vehicle: str = DEFAULT_VEHICLE, fdi: FdiConfig | None = None):
    """Both methods' shipped FDI for the thesis' vehicle; ours (the vehicle's shipped FDI) for another.
    ``fdi``: ours as configured (a user's observers beside: FdiConfig.plugins) instead of the shipped one."""
    ours = {"speed_aware": (fdi or FdiConfig()).for_vehicle(vehicle).load()}
    if vehicle != DEFAULT_VEHICLE:   # the thesis' method is MakSat's own (its networks, its x, y, z curves)
        return ours
    return {**ours, "thesis": FdiConfig("thesis").load()}


def _judge_chunk(cell_index: int, seeds_range, vehicle: str = DEFAULT_VEHICLE, fdi: FdiConfig | None = None):
    """One worker's share of a cell: figures need the runs, so the runs come back (small: series only)."""
    cell = cells_of(vehicle)[cell_index]
    scenarios = [s for s in cell_scenarios(cell, seeds_range.stop, cell_index, vehicle=vehicle)][seeds_range.start:]
    return screen_sets(scenarios, _fdi_sets(vehicle, fdi),
                       other_decisions=tuple(decision_of(d, "speed_aware") for d in VOTES))


def observable_levels(sets: dict, wheel=None) -> dict:
    """set -> observer -> axis -> the fault-free residual level a fault effect must rise above to count as
    observable: the set's metrics.observable_level (of the ``wheel`` type's tachometer), the same for each
    of its observers."""
    return {name: {obs: observable_level(entry[1], wheel) for obs in entry[1]} for name, entry in sets.items()}


def cell_sizes(fault_free_runs: int, runs_per_cell: int) -> list:
    """Runs per cell of CELLS: the fault-free cell's, every other cell's."""
    return [fault_free_runs if c.kind is None else runs_per_cell for c in CELLS]


def cell_results(judged: list, sizes: list, seed_base: int, levels: dict, key: str, cells: tuple = CELLS) -> dict:
    """cell name -> the cell, its seeds (cell i from seed_base + 100,000 i) and under ``key`` per FDI set
    and observer its :func:`cell_figures`; ``judged[i]``: set name -> the judged runs of cell i of ``cells``."""
    # every slot the runs were judged by: the observers, the verdict and the other decisions' verdicts, each
    # against the set's one observable level
    return {cell.name: {"cell": cell.as_dict(DETECTION_FIELDS),
                        "seeds": [seed_base + 100_000 * i, seed_base + 100_000 * i + sizes[i] - 1],
                        key: {name: {obs: cell_figures(runs, obs, next(iter(levels[name].values())))
                                     for obs in observers_of_runs(runs)}
                              for name, runs in judged[i].items()}}
            for i, cell in enumerate(cells)}


def bench_detection(fault_free_runs: int = 1000, runs_per_cell: int = 200, out: str | Path = "reports/detection",
                    executor=None, vehicle: str = DEFAULT_VEHICLE, fdi: FdiConfig | None = None) -> dict:
    sets = _fdi_sets(vehicle, fdi)
    levels = observable_levels(sets, load_vehicle(vehicle).wheel)
    t0 = time.monotonic()
    sizes = cell_sizes(fault_free_runs, runs_per_cell)
    judged = screen_cells(sizes, partial(_judge_chunk, vehicle=vehicle, fdi=fdi),
                          "detection bench (core loop + node code)", executor, out=out, name="detection")
    results = cell_results(judged, sizes, SEED_BASE, levels, "methods", cells_of(vehicle))
    write_cells_table(judged, [c.name for c in cells_of(vehicle)], out, "detection")
    report = {"schema": "rw_fdi_ros/detection_bench/1", "seconds": time.monotonic() - t0, "jobs": workers(executor),
              "date": time.strftime("%Y-%m-%d"), "vehicle": vehicle, "configured": configured(fdi),
              "fault_free_runs": fault_free_runs, "runs_per_cell": runs_per_cell, "seed_base": SEED_BASE,
              "onset_range_s": ONSET_RANGE,
              "design": {name: {obs: {"method": c.method, "persistence": c.persistence,
                                      "false_alarm_rate": c.false_alarm_rate} for obs, c in curves.items()}
                         for name, (_, curves) in sets.items()},
              "cells": results}
    return write_report(report, out, "detection", format_detection)


def _method_label(method: str) -> str:
    return "ours" if method == "speed_aware" else "thesis"


def _columns(report: dict) -> list:
    """(method, observer) of every column the report's cells hold, in the order they were judged."""
    first = next(iter(report["cells"].values()))["methods"]
    return [(method, obs) for method, figures in first.items() for obs in figures]


def format_detection(report: dict) -> str:
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    shipped = ("the shipped `config/fdi` (speed-aware) and `config/fdi/thesis`" if vehicle == DEFAULT_VEHICLE
               else f"vehicle {vehicle} with its shipped `config/fdi/vehicles/{vehicle}` (speed-aware)"
               if vehicle in shipped_vehicles() else f"vehicle {vehicle_words(vehicle)} (speed-aware)")
    lines = ["# Detection on held-out runs (`rw-fdi bench detection`)", "",
             f"Measured {report.get('date', '?')} on {fdi_phrase(report, shipped)} with the command's defaults.", "",
             f"Seeds from {report['seed_base']:,} (disjoint from training, fitting and the thesis study); faults "
             f"on a wheel in use drawn from the seed (seed mod the wheels in use) with onsets uniform in "
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
    for method in dict(_columns(report)):
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
