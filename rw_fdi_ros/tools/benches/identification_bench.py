"""`rw-fdi bench identification`: how often the fault's kind is right and how close its size is.

Runs nobody tuned for: seeds from 30,000,000 on (detection bench 10,000,000,
screen-vs-graph test 20,000,000, training and fitting 1000-1139), faults on
every wheel (wheel = seed mod 3) with onsets uniform in [60, 300] s, 400 s
runs. Each run is simulated by the core loop and goes through the node code:
observers, isolation (ObserverChannel) and the isolation node's
FaultIdentifier, started by the decision observer's alarm. The last
identification of the run is judged (scoring.metrics.judge_identification).

Observable: the fault's effect on the reaction torque exceeds the nominal
model observer's band (what the wheel physically shows; a bus drop on a slow
wheel shows nothing). Targets: kind right in >= 95 % of observable
runs at the thesis sizes; size within 10 % (temperature 10 C) in >= 90 %.

``--units``: units, not the datasheet. Wheels drawn at the
default spreads, the FDI calibrated over the first 150 s (config/fdi/
unit_calibrated), faults after it (onsets uniform in 160-300 s) with sizes
drawn from the seed over a range (off every grid), seeds from 31,000,000.
Targets: kind right >= 95 %, size within 10 % (10 C, 0.1 V: the bus' 10 % is
0.4-0.55 V, so 0.1 V is the stricter) in >= 90 %, the 95 % interval covering
the true size in >= 90 % of runs.
"""
from __future__ import annotations

import json
import time
from functools import partial
from pathlib import Path

import numpy as np

from ...fdi_config import FdiConfig
from ...core.fdi.calibration import calibration_samples
from ...core.fdi.identification import KINDS, NONE, SPOKEN, UNKNOWN, Identification, kind_name
from ...core.fdi.verdict import decision_observer
from ...core.mission.plant_choices import FDI_PERIOD
from ...core.mission.scenario import Fault
from ...core.mission.vehicle import DEFAULT_VEHICLE
from ...core.physics.wheel_set import fitted_for
from ...scoring.metrics import rate
from .journal import finish
from .kit import (DETECTION_FIELDS, bench_scenario, bench_wheels, fault_wheel, workers, Cell, cell_on_bus,
                  cell_scenarios, on_bus,
                  format_rate, screen_cells, write_cells_table, shipped_vehicles, vehicle_words)
from ...scoring.metrics import judge_identification
from ..evaluation.screen import screen_sets

SEED_BASE = 30_000_000
KIND_ORDER = (*KINDS, UNKNOWN, NONE)

CELLS = (
    Cell("current loss 40 %", "current_limiter", 0.6, thesis_size=True),
    Cell("temperature +150 C", "temperature", 173.0, thesis_size=True),
    Cell("bus 5.5 V (2.5 V off)", "bus_voltage", 5.5, thesis_size=True),
    Cell("current loss 10 %", "current_limiter", 0.9),
    Cell("current loss 20 %", "current_limiter", 0.8),
    Cell("current loss 30 %", "current_limiter", 0.7),
    Cell("current loss 50 %", "current_limiter", 0.5),
    Cell("temperature +30 C", "temperature", 53.0),
    Cell("temperature +60 C", "temperature", 83.0),
    Cell("temperature +100 C", "temperature", 123.0),
    Cell("bus 7.2 V (10 % off)", "bus_voltage", 7.2),
    Cell("bus 6.4 V (20 % off)", "bus_voltage", 6.4),
    Cell("bus 4.8 V (40 % off)", "bus_voltage", 4.8),
    Cell("bus 4.0 V", "bus_voltage", 4.0),
)


UNITS_SEED_BASE = 31_000_000
UNITS_CALIBRATION = 150.0                 # [s] the shipped config/fdi/unit_calibrated bands
UNITS_ONSETS = (160.0, 300.0)             # after the calibration window
# (name, kind, size range): sizes drawn uniformly from the seed, so never on an identification grid
UNITS_CELLS = (("current loss 8-45 %", "current_limiter", (0.55, 0.92)),
               ("temperature +25 to +150 C", "temperature", (48.0, 173.0)),
               ("bus 4.0-5.5 V", "bus_voltage", (4.0, 5.5)))


def cells_of(vehicle: str = DEFAULT_VEHICLE, units: bool = False) -> tuple:
    """CELLS (``units``: UNITS_CELLS) as ``vehicle`` flies them: its bus drops at the same share of its bus."""
    if units:
        return tuple((named, kind, sized) for name, kind, span in UNITS_CELLS
                     for named, sized in [on_bus(name, kind, span, vehicle)])
    return tuple(cell_on_bus(c, vehicle) for c in CELLS)


def units_scenarios(cell_index: int, runs: int, vehicle: str = DEFAULT_VEHICLE) -> list:
    """``runs`` varied-wheel scenarios of a units cell: seed 31,000,000 + 100,000 index + n, the fault on a
    wheel in use drawn from the seed (seed mod 3 on the thesis' set), its onset and size drawn from the seed;
    ``vehicle``: the shipped vehicle they fly."""
    name, kind, (low, high) = cells_of(vehicle, units=True)[cell_index]
    wheels = bench_wheels(vehicle)
    out = []
    for n in range(runs):
        seed = UNITS_SEED_BASE + 100_000 * cell_index + n
        rng = np.random.default_rng(seed)
        onset, size = float(np.round(rng.uniform(*UNITS_ONSETS), 1)), float(np.round(rng.uniform(low, high), 4))
        fault = Fault(kind, fault_wheel(seed, wheels), onset, size)
        out.append(bench_scenario(vehicle, name, seed=seed, faults=(fault,), wheels={"variation": True}))
    return out


def _units_chunk(cell_index: int, seeds_range, vehicle: str = DEFAULT_VEHICLE):
    scenarios = units_scenarios(cell_index, seeds_range.stop, vehicle)[seeds_range.start:]
    fdi = (*FdiConfig(unit_calibration=UNITS_CALIBRATION).for_vehicle(vehicle).load(),
           calibration_samples(UNITS_CALIBRATION, FDI_PERIOD))
    return screen_sets(scenarios, {"speed_aware": fdi}, identification=True)


def _chunk(cell_index: int, seeds_range, vehicle: str = DEFAULT_VEHICLE):
    cell = cells_of(vehicle)[cell_index]
    scenarios = cell_scenarios(cell, seeds_range.stop, cell_index, SEED_BASE, vehicle=vehicle)[seeds_range.start:]
    return screen_sets(scenarios, {"speed_aware": FdiConfig().for_vehicle(vehicle).load()}, identification=True)


def cell_identification(runs, observable_level: dict, strict_bus: bool = False) -> dict:
    """Figures of one cell: kind right (observable runs), confusion counts, size errors, interval
    coverage, and the share of intervals the unit widened (``strict_bus``: bus within 0.1 V)."""
    rows, observable = [], []
    for r in runs:
        for a, v in judge_identification(r, strict_bus).items():
            found = Identification.from_values(r.identification.get(a) or {})
            v["unit_limited"] = found is not None and found.unit_limited
            seen = bool(r.fault_effect_peak[r.wheels.index(a)] > max(observable_level[k]
                                                                     for k in fitted_for(a, observable_level)))
            rows.append(v)
            observable.append(seen)
    seen_rows = [v for v, o in zip(rows, observable) if o]
    confusion = {k: sum(v["kind"] == k for v in seen_rows) for k in KIND_ORDER}
    right = [v for v in seen_rows if v["kind_right"]]
    errors = np.abs([v["size_error"] for v in right]) if right else np.zeros(0)
    return {"runs": len(rows), "observable": rate(observable), "kind_right_observable": rate(v["kind_right"]
                                                                                              for v in seen_rows),
            "confusion_observable": confusion,
            "size_right": rate(v["size_right"] for v in right), "covered": rate(v["covered"] for v in right),
            "unit_limited": rate(v["unit_limited"] for v in right),
            "abs_size_error": {"median": float(np.median(errors)) if errors.size else None,
                               "p90": float(np.percentile(errors, 90)) if errors.size else None}}


def bench_identification(runs_per_cell: int = 100, thesis_runs: int = 200, bus_thesis_runs: int = 340,
                         out: str | Path = "reports/identification", executor=None, units: bool = False,
                         vehicle: str = DEFAULT_VEHICLE) -> dict:
    """Identification figures per cell; the thesis sizes get ``thesis_runs`` (the bus ``bus_thesis_runs``:
    about 6 in 10 bus drops of 2.5 V are physically visible). ``units``: the varied-wheel cells instead
    (``runs_per_cell`` each, the bus 1.7 times as many)."""
    _, curves = FdiConfig(unit_calibration=UNITS_CALIBRATION if units else 0.0).for_vehicle(vehicle).load()
    level = {a: float(c[-1]) for a, c in curves["model"].curves.items()}   # the model observer's band
    t0 = time.monotonic()
    cells = {}
    if units:
        sizes = [runs_per_cell * 17 // 10 if kind == "bus_voltage" else runs_per_cell for _, kind, _ in UNITS_CELLS]
        units_cells = cells_of(vehicle, units=True)
        judged = screen_cells(sizes, partial(_units_chunk, vehicle=vehicle),
                              "identification bench, varied units (core loop + node code)", executor, out=out,
                              name="identification_units")
        write_cells_table(judged, [name for name, _, _ in units_cells], out, "identification")
        for i, (name, kind, span) in enumerate(units_cells):
            first = UNITS_SEED_BASE + 100_000 * i
            cells[name] = {"cell": {"name": name, "kind": kind, "range": list(span), "thesis_size": False},
                           "seeds": [first, first + sizes[i] - 1],
                           **cell_identification(judged[i]["speed_aware"], level, strict_bus=True)}
    else:
        sizes = [(bus_thesis_runs if c.kind == "bus_voltage" else thesis_runs) if c.thesis_size else runs_per_cell
                 for c in CELLS]
        judged = screen_cells(sizes, partial(_chunk, vehicle=vehicle), "identification bench (core loop + node code)",
                              executor, out=out, name="identification")
        write_cells_table(judged, [c.name for c in cells_of(vehicle)], out, "identification")
        for i, cell in enumerate(cells_of(vehicle)):
            first = SEED_BASE + 100_000 * i
            cells[cell.name] = {"cell": cell.as_dict(DETECTION_FIELDS), "seeds": [first, first + sizes[i] - 1],
                                **cell_identification(judged[i]["speed_aware"], level)}
    report = {"schema": "rw_fdi_ros/identification_bench/1", "seconds": time.monotonic() - t0,
              "jobs": workers(executor),
              "date": time.strftime("%Y-%m-%d"), "vehicle": vehicle,
              "seed_base": UNITS_SEED_BASE if units else SEED_BASE,
              "decision_observer": decision_observer("speed_aware"),
              "observable_level_Nm": level, "units": units,
              "unit_calibration_time_s": UNITS_CALIBRATION if units else 0.0,
              "cells": cells}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "identification.json").write_text(json.dumps(report, indent=1))
    plot_confusion(report, out / "confusion.png")
    text = format_identification(report)
    (out / "identification.md").write_text(text)
    finish(out, "identification")
    report["text"] = text
    report["ok"] = True
    return report


def confusion_matrix(report: dict, thesis_only: bool = True):
    """(true kinds, identified kinds, counts (true, identified)) summed over the cells."""
    true_kinds = KIND_ORDER[:3]
    counts = np.zeros((3, len(KIND_ORDER)), int)
    for c in report["cells"].values():
        if thesis_only and not c["cell"]["thesis_size"]:
            continue
        row = true_kinds.index(c["cell"]["kind"])
        seen = {kind_name(k): n for k, n in c["confusion_observable"].items()}   # a report of former names too
        for j, k in enumerate(KIND_ORDER):
            counts[row, j] += seen[k]
    return true_kinds, KIND_ORDER, counts


def _spoken(kind: str) -> str:
    """A kind as a table's or a figure's label says it ('current loss' for current_limiter)."""
    return SPOKEN.get(kind, kind.replace("_", " "))


def plot_confusion(report: dict, path: Path) -> Path:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    panels = _panels(report)
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 3.8), squeeze=False)
    for ax, (thesis_only, title) in zip(axes[0], panels):
        rows, cols, counts = confusion_matrix(report, thesis_only)
        share = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
        ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
        for i in range(len(rows)):
            for j in range(len(cols)):
                ax.text(j, i, f"{counts[i, j]}", ha="center", va="center",
                        color="white" if share[i, j] > 0.5 else "black")
        ax.set_xticks(range(len(cols)), [_spoken(c) for c in cols], rotation=20)
        ax.set_yticks(range(len(rows)), [_spoken(r) for r in rows])
        ax.set_xlabel("identified (none: never alarmed)")
        ax.set_ylabel("true kind")
        ax.set_title(f"observable runs, {title}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _panels(report: dict) -> tuple:
    """(thesis sizes only, title) of each confusion panel: the varied-unit cells have no thesis sizes."""
    return ((False, "all sizes"),) if report.get("units") else ((True, "thesis sizes"), (False, "all sizes"))


def format_identification(report: dict) -> str:
    units = {"current_limiter": "", "temperature": " C", "bus_voltage": " V"}
    if report.get("units"):
        head = ["# Fault identification on units, not the datasheet (`rw-fdi bench identification --units`)", "",
                f"Measured {report.get('date', '?')} on the shipped `config/fdi/unit_calibrated` with the "
                "command's defaults.", "",
                f"Seeds from {report['seed_base']:,}; wheels drawn at the default unit spreads, every observer and "
                f"the identifier calibrated over the first {report['unit_calibration_time_s']:g} s; faults on a wheel "
                "in use drawn from the seed, onsets uniform in 160-300 s, sizes drawn uniformly over the case's "
                "range (off every grid), 400 s runs; identification starts at the "
                f"{report['decision_observer']} observer's alarm. Size within 10 % (10 C; the bus within 0.1 V). "
                "'Widened by the unit': the share of intervals at least twice as wide as they would be were the "
                f"unit known exactly. Rates with 95 % Wilson intervals. {report['seconds'] / 60:.0f} min on this "
                "machine."]
    else:
        head = ["# Fault identification on held-out runs (`rw-fdi bench identification`)", "",
                f"Measured {report.get('date', '?')} on the shipped `config/fdi` with the command's defaults.", "",
                f"Seeds from {report['seed_base']:,}; faults on a wheel in use drawn from the seed, onsets uniform in "
                f"60-300 s, 400 s "
                f"runs; identification starts at the {report['decision_observer']} observer's alarm. Observable: the "
                "fault's effect on the reaction torque exceeds the nominal-model observer's band. Rates with 95 % "
                f"Wilson intervals. {report['seconds'] / 60:.0f} min on this machine."]
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    if vehicle != DEFAULT_VEHICLE:
        head[0] += f", vehicle {vehicle_words(vehicle)}"
        if vehicle in shipped_vehicles():
            head[2] = head[2].replace("the shipped `config/fdi", f"the shipped `config/fdi/vehicles/{vehicle}")
    lines = head + ["", "| case | observable | kind right (observable) | size within tolerance | "
                        "|error| median / p90 | interval covers truth | widened by the unit |",
                    "|---|---|---|---|---|---|---|"]
    for name, c in report["cells"].items():
        e = c["abs_size_error"]
        unit = units[c["cell"]["kind"]]
        err = f"{e['median']:.3g} / {e['p90']:.3g}{unit}" if e["median"] is not None else "-"
        mark = " (thesis size)" if c["cell"]["thesis_size"] else ""
        widened = format_rate(c["unit_limited"]) if "unit_limited" in c else "-"
        lines.append(f"| {name}{mark} | {format_rate(c['observable'])} | {format_rate(c['kind_right_observable'])} | "
                     f"{format_rate(c['size_right'])} | {err} | {format_rate(c['covered'])} | {widened} |")
    for thesis_only, title in _panels(report):
        rows, cols, counts = confusion_matrix(report, thesis_only)
        lines += ["", f"## Confusion, observable runs, {title} (rows: truth)", "",
                  "| true \\ identified | " + " | ".join(_spoken(c) for c in cols) + " |",
                  "|---" * (len(cols) + 1) + "|"]
        for i, r in enumerate(rows):
            lines.append(f"| {_spoken(r)} | " + " | ".join(str(v) for v in counts[i]) + " |")
    lines += ["", "![confusion](confusion.png)"]
    return "\n".join(lines) + "\n"
