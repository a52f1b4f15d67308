"""`rw-fdi bench units`: the FDI on wheels that are not the datasheet, with and without unit calibration.

Every cell of `rw-fdi bench detection` (fault-free, ripple, the target and
thesis fault sizes, a ramp) on two wheel populations: units drawn around
Table 2.2 at the default spreads (scenario ``wheels: {variation: true}``,
core/physics/wheel.DEFAULT_UNIT_SPREAD) and the datasheet wheel itself. Each
simulated run is judged by the speed-aware FDI twice: as shipped (the
observers' model is the datasheet wheel) and calibrated (each observer
learns its wheel's unit over the first 150 s, core/fdi/calibration.py; bands
`config/fdi/unit_calibrated`, fitted on seeds 60,000,000-60,000,299).
Seeds from 40,000,000 (varied) and 41,000,000 (datasheet), disjoint from
every fit and tuning; faults on wheel seed mod 3 with onsets uniform in
160-300 s: after the window calibration assumes healthy.

Targets: calibrated, false alarms <= 0.5 % and detection >= 95 %
at 10 % current loss and +30 C on varied wheels; on the datasheet wheel the
best method at least matches the model-based baseline.
"""
from __future__ import annotations

import time
from functools import partial
from pathlib import Path

from ...fdi_config import FdiConfig
from ...core.fdi.calibration import calibration_samples
from ...core.mission.plant_choices import FDI_PERIOD
from ...core.mission.vehicle import DEFAULT_VEHICLE, load_vehicle
from .detection_bench import cell_results, cell_sizes, cells_of, observable_levels
from .kit import (cell_scenarios, configured, fdi_phrase, format_rate, own_fdi, screen_cells, workers,
                  write_cells_table, write_report, vehicle_words)
from ..evaluation.screen import screen_sets

CALIBRATION_TIME = 150.0   # [s]: the shipped config/fdi/unit_calibrated bands
ONSET_RANGE = (160.0, 300.0)
POPULATIONS = {"varied": (40_000_000, {"variation": True}), "datasheet": (41_000_000, {})}
SETS = {"datasheet model": 0.0, "calibrated": CALIBRATION_TIME}


def _fdi_sets(vehicle: str = DEFAULT_VEHICLE, fdi: FdiConfig | None = None) -> dict:
    """The datasheet and the calibrated sets of the shipped FDI of ``vehicle`` (or of ``fdi``: a user's observers
    beside, their bands in its thresholds directory and its unit_calibrated/)."""
    from dataclasses import replace
    fdi = fdi or FdiConfig()
    return {name: (*replace(fdi, unit_calibration=t).for_vehicle(vehicle).load(), calibration_samples(t, FDI_PERIOD))
            for name, t in SETS.items()}


def _judge_chunk(population: str, cell_index: int, seeds_range, vehicle: str = DEFAULT_VEHICLE,
                 fdi: FdiConfig | None = None):
    seed_base, wheels = POPULATIONS[population]
    scenarios = cell_scenarios(cells_of(vehicle)[cell_index], seeds_range.stop, cell_index, seed_base, ONSET_RANGE,
                               wheels, vehicle=vehicle)[seeds_range.start:]
    return screen_sets(scenarios, _fdi_sets(vehicle, fdi))


def bench_units(fault_free_runs: int = 1000, runs_per_cell: int = 200, out: str | Path = "reports/units",
                executor=None, vehicle: str = DEFAULT_VEHICLE, fdi: FdiConfig | None = None) -> dict:
    t0 = time.monotonic()   # loading both calibrations' bands included
    sets = _fdi_sets(vehicle, fdi)
    levels, sizes = observable_levels(sets, load_vehicle(vehicle).wheel), cell_sizes(fault_free_runs, runs_per_cell)
    populations = {}
    for population, (seed_base, wheels) in POPULATIONS.items():
        judged = screen_cells(sizes, partial(_judge_chunk, population, vehicle=vehicle, fdi=fdi),
                              f"units bench, {population} wheels", executor, out=out,
                              name=f"units_{population}")
        write_cells_table(judged, [c.name for c in cells_of(vehicle)], out, f"units_{population}")
        populations[population] = {"seed_base": seed_base, "wheels": wheels,
                                   "cells": cell_results(judged, sizes, seed_base, levels, "sets", cells_of(vehicle))}
    report = {"schema": "rw_fdi_ros/units_bench/1", "seconds": time.monotonic() - t0, "jobs": workers(executor),
              "date": time.strftime("%Y-%m-%d"), "vehicle": vehicle, "configured": configured(fdi),
              "fault_free_runs": fault_free_runs,
              "runs_per_cell": runs_per_cell,
              "onset_range_s": ONSET_RANGE, "unit_calibration_time_s": CALIBRATION_TIME,
              "bands": {name: {obs: {"seeds": [min(c.seeds), max(c.seeds)] if c.seeds else None,
                                     "unit_calibration_time": c.unit_calibration_time}
                               for obs, c in entry[1].items()} for name, entry in sets.items()},
              "populations": populations}
    return write_report(report, out, "units", format_units)


def format_units(report: dict) -> str:
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    lines = ["# The FDI on wheels that are not the datasheet (`rw-fdi bench units`)"
             + ("" if vehicle == DEFAULT_VEHICLE else f", vehicle {vehicle_words(vehicle)}"), "",
             f"Measured {report['date']} on {fdi_phrase(report, own_fdi(report))}; `datasheet model`: "
             f"the datasheet bands, observers modelling Table 2.2's wheel; `calibrated`: each observer learns its "
             f"wheel over the first {report['unit_calibration_time_s']:g} s of the run (`--unit-calibration "
             f"{report['unit_calibration_time_s']:g}`, bands `unit_calibrated`). Faults on a wheel in use drawn "
             f"from the seed, onsets uniform in {report['onset_range_s'][0]:g}-{report['onset_range_s'][1]:g} s; "
             f"{report['fault_free_runs']} fault-free runs and {report['runs_per_cell']} per other cell, per "
             f"population; rates with 95 % Wilson intervals; {report['seconds'] / 60:.0f} min on this machine.", ""]
    sets = list(SETS)
    for population, p in report["populations"].items():
        first = next(iter(p["cells"].values()))["sets"]
        columns = [(s, o) for s in sets for o in first[s]]
        lines += [f"## {population} wheels (seeds from {p['seed_base']:,}; wheels: {p['wheels'] or 'Table 2.2'})", "",
                  "False alarms (any alarm in a run that must not alarm):", "",
                  "| case | " + " | ".join(f"{s}: {o}" for s, o in columns) + " |",
                  "|---|" + "---|" * len(columns)]
        for name, c in p["cells"].items():
            if c["cell"]["kind"] is None or c["cell"]["disturbance"]:
                lines.append(f"| {name} | " + " | ".join(format_rate(c["sets"][s][o]["false_alarm"])
                                                         for s, o in columns) + " |")
        lines += ["", "Faults (detected: the faulty wheel alarmed; correct: alarmed wheels = faulty wheels; "
                  "observable: runs whose fault effect rose above the fault-free residual level, physics.md; delay "
                  "median / p90 in s):", "",
                  "| case | set | observer | correct | correct, observable | detected | delay | held to end |",
                  "|---|---|---|---|---|---|---|---|"]
        for name, c in p["cells"].items():
            if c["cell"]["kind"] is None or c["cell"]["disturbance"]:
                continue
            for s, o in columns:
                f = c["sets"][s][o]
                d = f["delay_s"]
                delay = f"{d['median']:.0f} / {d['p90']:.0f}" if d["median"] is not None else "-"
                lines.append(f"| {name} | {s} | {o} | {format_rate(f['correct'])} | "
                             f"{format_rate(f['correct_observable'])} | "
                             f"{format_rate(f['detected'])} | {delay} | {format_rate(f['held_to_end'])} |")
        lines.append("")
    return "\n".join(lines)
