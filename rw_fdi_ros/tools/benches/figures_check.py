"""`rw-fdi bench figures`: every figure of the README's table re-measured at small n, beside the README's.

A figure of record holds only while nothing it depends on has changed. This command runs each bench behind the
README's table at a small sample (SMALL: about 8 minutes on 2 cores in all at the record's machine speed,
docs/benchmarks.md), on the benches' own seeds of record, and prints every figure beside the README's row and
the report of record it quotes (``reports/``). A rate is flagged when its small-n 95 % interval and the
record's do not meet: the two samples disagree beyond chance, so something the figure depends on changed. A
value (a wheel speed, a time of loss) is flagged outside its stated tolerance of the record. Small n cannot
confirm a record (0 of 40 says little); it catches a figure that has moved.
"""
from __future__ import annotations

import importlib
import json
from contextlib import contextmanager
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ...paths import config_dir
from ...scoring.metrics import rate
from .kit import format_rate

# the small samples: (bench, its keyword arguments); the whole check about 8 minutes on 2 cores (the graph
# running at its record's ~115x real time)
SMALL = {
    "detection": {"fault_free_runs": 60, "runs_per_cell": 20},
    "operations": {"fault_free_runs": 40, "runs_per_cell": 12, "hours_runs": 2},
    "identification_units": {"runs_per_cell": 12, "units": True, "thesis_runs": 12, "bus_thesis_runs": 20},
    "recovery": {"runs_per_cell": 6, "fault_free_runs": 40},
    "service": {"runs": 24, "fault_free_runs": 40, "max_hours": 0.5, "given_up_runs": 16},
    # every observer beside the decision, the Elman network trained for service among them (docs/fdi.md)
    "service_observers": {"runs": 30, "fault_free_runs": 30, "max_hours": 0.25, "given_up_runs": 1,
                          "watch": "service"},
    # 16 h of the day in orbit hold both dumps and the rods-off loss (13.7 h); one 6-h run per orbit cell
    "dumping": {"hours": 16.0, "operations_runs": 1, "runs_per_cell": 8},
    "reproduce": {"scale_name": "small"},
    "graph": {},
    "study": {"runs": 2},
    # the shipped microsatellite's row, with its own FDI (docs/vehicles.md)
    "vehicle_detection": {"fault_free_runs": 60, "runs_per_cell": 20, "vehicle": "microsat_pyramid"},
    "vehicle_recovery": {"runs_per_cell": 6, "fault_free_runs": 40, "vehicle": "microsat_pyramid"},
    "vehicle_service": {"runs": 24, "fault_free_runs": 40, "max_hours": 0.5, "given_up_runs": 16,
                        "vehicle": "microsat_pyramid"},
    # the shipped CubeSat's row: a wheel type of its own (docs/vehicles.md)
    "cubesat_detection": {"fault_free_runs": 60, "runs_per_cell": 20, "vehicle": "cubesat_6u"},
    "cubesat_recovery": {"runs_per_cell": 6, "fault_free_runs": 40, "vehicle": "cubesat_6u"},
    "cubesat_service": {"runs": 24, "fault_free_runs": 40, "max_hours": 0.5, "given_up_runs": 16,
                        "vehicle": "cubesat_6u"},
    # each observer on its own: the thesis' spacecraft with its FDI made the vehicle way (docs/fdi.md)
    "maksat_operations": {"fault_free_runs": 40, "runs_per_cell": 12, "hours_runs": 2,
                          "vehicle": str(config_dir() / "fdi" / "vehicles" / "maksat")},
}
RECORDS = {"detection": "reports/detection/detection.json", "operations": "reports/operations/operations.json",
           "identification_units": "reports/identification_units/identification.json",
           "recovery": "reports/recovery/recovery.json", "service": "reports/service/service.json",
           "service_observers": "reports/service_observers/service_trained/service.json",
           "dumping": "reports/dumping/dumping.json",
           "vehicle_detection": "reports/vehicles/microsat_pyramid/detection/detection.json",
           "vehicle_recovery": "reports/vehicles/microsat_pyramid/recovery/recovery.json",
           "vehicle_service": "reports/vehicles/microsat_pyramid/service/service.json",
           "cubesat_detection": "reports/vehicles/cubesat_6u/detection/detection.json",
           "cubesat_recovery": "reports/vehicles/cubesat_6u/recovery/recovery.json",
           "cubesat_service": "reports/vehicles/cubesat_6u/service/service.json",
           "maksat_operations": "reports/vehicles/maksat/operations/operations.json"}


@dataclass(frozen=True)
class Figure:
    """One figure of a README row: ``extract(report)`` gives a rate {k, n} or a value, alike from the small
    run's report and the record's; a value may differ by ``tolerance`` (absolute, in its unit)."""

    row: str          # the start of the README row's first column
    label: str
    bench: str
    extract: object
    tolerance: float | None = None
    unit: str = ""


def _cell(name, observer, figure, key="observers"):
    return lambda r: r["cells"][name][key][observer][figure]


def _summed(chosen, figure):
    """The rate ``figure`` over the recovery report's cells ``chosen(cell)`` picks."""
    def extract(r):
        cells = [c["figures"][figure] for c in r["cells"].values() if chosen(c["cell"])]
        return rate(x for c in cells for x in [True] * c["k"] + [False] * (c["n"] - c["k"]))
    return extract


def single_fault(cell: dict) -> bool:
    """The recovery bench's single-fault cells (a fault, no second one), at whatever wheel speeds."""
    return cell.get("kind") is not None and cell.get("second") is None
def _vehicle_figures(row: str, short: str, bench: str) -> list:
    """A shipped vehicle's row: detection, recovery and in-service figures from benches ``<bench>_detection``,
    ``_recovery`` and ``_service``."""
    verdict = lambda r, cell, key: r["cells"][cell]["methods"]["speed_aware"]["verdict"][key]   # noqa: E731
    return [
        Figure(row, f"{short}: false alarms", f"{bench}_detection", lambda r: verdict(r, "fault_free", "false_alarm")),
        Figure(row, f"{short}: current loss 10 % right, observable", f"{bench}_detection",
               lambda r: verdict(r, "current loss 10 %", "correct_observable")),
        Figure(row, f"{short}: single faults recovered", f"{bench}_recovery", _summed(single_fault, "recovered")),
        *[Figure(row, f"{short} in service: {label}", f"{bench}_service", lambda r, key=key: r["figures"][key])
          for label, key in (("the faulty wheel and no other acted on", "acted_right"),
                             ("pointing kept", "pointing_kept"),
                             ("reconfigurations without a fault", "reconfigured_fault_free_600s"))],
    ]


FIGURES = [
    Figure("false alarms, fault-free, datasheet", "false alarms, the decision observer", "detection",
           lambda r: r["cells"]["fault_free"]["methods"]["speed_aware"]["model"]["false_alarm"]),
    Figure("false alarms in operations", "400-s runs alarmed (/diagnostics)", "operations",
           _cell("fault-free operations", "verdict", "false_alarm")),
    Figure("false alarms in operations", "2-h runs alarmed", "operations",
           _cell("continuous operations, 2 h runs", "verdict", "false_alarm")),
    Figure("detected, 10 % current loss", "current loss 10 % detected", "operations",
           _cell("current loss 10 %", "verdict", "detected")),
    Figure("detected, 10 % current loss", "temperature +30 C detected", "operations",
           _cell("temperature +30 C", "verdict", "detected")),
    Figure("bus drops that tumble", "bus 4.6 V: right wheel", "operations", _cell("bus 4.6 V", "verdict", "correct")),
    Figure("bus drops that tumble", "bus 5.0 V: right wheel", "operations", _cell("bus 5.0 V", "verdict", "correct")),
    *[Figure("fault kind right, varied wheel units", f"kind right: {cell}", "identification_units",
             lambda r, c=cell: r["cells"][c]["kind_right_observable"])
      for cell in ("current loss 8-45 %", "temperature +25 to +150 C", "bus 4.0-5.5 V")],
    Figure("single faults on an active wheel recovered", "recovered, 12 single-fault cells", "recovery",
           _summed(single_fault, "recovered")),
    Figure("single faults on an active wheel recovered", "a healthy wheel acted on", "recovery",
           _summed(single_fault, "healthy_given_up")),
    Figure("**in service**", "pointing kept", "service", lambda r: r["figures"]["pointing_kept"]),
    Figure("**in service**", "the faulty wheel and no other acted on", "service",
           lambda r: r["figures"]["acted_right"]),
    Figure("**in service**", "kind identified", "service", lambda r: r["figures"]["kind_right"]),
    Figure("**in service**", "kind identified, wheel given up", "service",
           lambda r: r["figures"]["given_up"]["kind_right"]),
    Figure("**in service**", "kind or the drive named, wheel given up", "service",
           lambda r: r["figures"]["given_up"]["kind_narrowed"]),
    Figure("**in service**", "kind identified where the physics tells it, wheel given up", "service",
           lambda r: r["figures"]["given_up"]["kind_right_told_apart"]),
    Figure("**in service**", "reconfigurations without a fault, 600-s runs", "service",
           lambda r: r["figures"]["reconfigured_fault_free_600s"]),
    Figure("**every observer in service**", "Elman trained for service: the faulty wheel and no other alarmed",
           "service_observers", lambda r: r["figures"]["observers"]["elman"]["right"]),
    Figure("**every observer in service**", "Elman trained for service: false alarms, 600-s runs",
           "service_observers", lambda r: r["figures"]["observers"]["elman"]["false_alarm_600s"]),
    Figure("reconfigurations in fault-free operations", "reconfigured", "recovery",
           lambda r: r["cells"]["fault-free operations"]["figures"]["reconfigured"]),
    Figure("a day in orbit", "with dumping: largest pointing error", "dumping",
           lambda r: r["day"]["with_dumping"]["max_pointing_error_deg"], 0.02, "deg"),
    Figure("a day in orbit", "with dumping: largest wheel speed", "dumping",
           lambda r: r["day"]["with_dumping"]["max_abs_wheel_speed"], 3.0, "rad/s"),
    Figure("a day in orbit", "rods off: pointing lost after", "dumping",
           lambda r: r["day"]["rods_off"]["first_pointing_loss_s"] / 3600.0, 1.0, "h"),
    Figure("false alarms through momentum dumping", "6-h runs in orbit alarmed", "dumping",
           _cell("operations in orbit with dumping, 6-h runs", "verdict", "false_alarm")),
    Figure("detected, 10 % current loss and +30 C with the onset inside a dump", "current loss 10 % in a dump",
           "dumping", _cell("current loss 10 % during a dump", "verdict", "detected")),
    Figure("detected, 10 % current loss and +30 C with the onset inside a dump", "temperature +30 C in a dump",
           "dumping", _cell("temperature +30 C during a dump", "verdict", "detected")),
    Figure("the thesis-scale study", "graph sample: bags identical to the core engine's (small scale)",
           "reproduce", lambda r: r["engines"]["graph_sample"]),
    Figure("the recorded graph", "real time, composed", "graph",
           lambda r: r["groupings"][next(iter(r["groupings"]))]["real_time_factor"], None, "x"),
    Figure("the recorded graph", "real time, one node per process", "graph",
           lambda r: r["groupings"]["none"]["real_time_factor"], None, "x"),
    *_vehicle_figures("**another vehicle**", "microsat", "vehicle"),
    *_vehicle_figures("**a wheel type of its own**", "cubesat", "cubesat"),
    *[Figure("**each observer on its own**", f"{label} alone: {what}", "maksat_operations", _cell(cell, obs, key))
      for obs, label in (("elman", "Elman"), ("linear", "Luenberger"))
      for what, cell, key in (("false alarms in operations", "fault-free operations", "false_alarm"),
                              ("current loss 10 % right", "current loss 10 %", "correct"),
                              ("temperature +30 C right", "temperature +30 C", "correct"))],
    *[Figure("judging a recorded bag", f"judging a bag: {how}", "study",
             lambda r, how=how: next(v for k, v in r["judge_s_per_bag"].items() if k.startswith(how)), None, "s")
      for how in ("core engine", "replay through the FDI graph")],
]


def readme_rows(readme: str | Path = "README.md") -> dict:
    """The README's figures table: first column -> figure column."""
    rows = {}
    for line in Path(readme).read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| ") and len(cells) >= 3 and not set(cells[0]) <= {"-"}:
            rows[cells[0]] = cells[1]
    return rows


# bench -> (its module, function, the report file it writes in ``out``: None for one that returns it only)
BENCH_FUNCTIONS = {
    "detection": (".detection_bench", "bench_detection", "detection.json"),
    "operations": (".operations_bench", "bench_operations", "operations.json"),
    "identification_units": (".identification_bench", "bench_identification", "identification.json"),
    "recovery": (".recovery_bench", "bench_recovery", "recovery.json"),
    "service": (".service_bench", "bench_service", "service.json"),
    "service_observers": (".service_bench", "bench_service", "service.json"),
    "dumping": (".dumping_bench", "bench_dumping", "dumping.json"),
    "reproduce": ("..evaluation.reproduce", "reproduce", None),
    "graph": (".speed_bench", "bench_graph", None),
    "study": (".speed_bench", "bench_study", None),
    "vehicle_detection": (".detection_bench", "bench_detection", "detection.json"),
    "vehicle_recovery": (".recovery_bench", "bench_recovery", "recovery.json"),
    "vehicle_service": (".service_bench", "bench_service", "service.json"),
    "cubesat_detection": (".detection_bench", "bench_detection", "detection.json"),
    "cubesat_recovery": (".recovery_bench", "bench_recovery", "recovery.json"),
    "cubesat_service": (".service_bench", "bench_service", "service.json"),
    "maksat_operations": (".operations_bench", "bench_operations", "operations.json"),
}


def _run_bench(name: str, out: Path, day=None) -> dict:
    """The small run of bench ``name``: its report as its JSON holds it (or as it returns it); ``day``: the future
    of the dumping bench's day in orbit, run beside the others."""
    module, function, report = BENCH_FUNCTIONS[name]
    bench = getattr(importlib.import_module(module, __package__), function)
    if name in ("graph", "study"):   # their figures are timings: no report directory
        return bench(**SMALL[name])
    extra = {"day": day.result()} if name == "dumping" and day is not None else {}
    kwargs = dict(SMALL[name])
    if kwargs.get("watch") == "service":   # the shipped set trained for service, judged beside the decision
        from ...fdi_config import FdiConfig
        from ...paths import config_dir
        kwargs["watch"] = FdiConfig(models=str(config_dir() / "fdi" / "service"))
    result = bench(out=out, **kwargs, **extra)
    return result if report is None else json.loads((out / report).read_text())


def _graph_sample(x) -> dict:
    return {"k": x["identical_bags"], "n": x["runs"]}


def _compare(figure: Figure, small, record) -> tuple:
    """(the small-n text, the record's text, flagged)."""
    if figure.bench == "reproduce":
        small = _graph_sample(small)
        return f"{small['k']} of {small['n']}", "", small["k"] != small["n"]
    if isinstance(small, dict):   # a rate
        small = small if "ci95" in small else rate([True] * small["k"] + [False] * (small["n"] - small["k"]))
        if record is None:
            return format_rate(small), "-", False
        lo, hi = small["ci95"]
        rlo, rhi = record["ci95"]
        return format_rate(small), format_rate(record), bool(hi < rlo - 1e-12 or lo > rhi + 1e-12)
    if record is None or figure.tolerance is None:
        return f"{small:.3g} {figure.unit}", "-" if record is None else f"{record:.3g} {figure.unit}", False
    return (f"{small:.3g} {figure.unit}", f"{record:.3g} {figure.unit} (+-{figure.tolerance:g})",
            abs(small - record) > figure.tolerance)


def _recorded(figure: Figure, record: dict | None):
    """The figure in the report of record; None where the record predates the figure."""
    try:
        return None if record is None else figure.extract(record)
    except (KeyError, TypeError):
        return None


def figures_of(name: str, result: dict, rows: dict, record: dict | None) -> list:
    """The figures of bench ``name`` from its small run's ``result``, beside the README's ``rows`` and its
    ``record`` report."""
    lines = []
    for figure in (f for f in FIGURES if f.bench == name):
        row = next((text for key, text in rows.items() if key.startswith(figure.row)), None)
        small, recorded, flag = _compare(figure, figure.extract(result), _recorded(figure, record))
        lines.append({"row": figure.row, "figure": figure.label, "small": small, "record": recorded,
                      "readme": row or "(row not found)", "flagged": flag})
    return lines


def check_figures(readme: str | Path = "README.md", benches=None, progress=None, work: Path | None = None) -> dict:
    """Run the small benches (``benches``: a subset of SMALL's names) and compare every figure of FIGURES;
    ``progress(name, lines)`` before each bench (lines None) and after it (its figures)."""
    names = [b for b in SMALL if benches is None or b in benches]
    unknown = sorted(set(benches or ()) - set(SMALL))
    if unknown:
        raise ValueError(f"unknown bench(es) {', '.join(unknown)}; the table's: {', '.join(SMALL)}")
    rows = readme_rows(readme)
    work = Path(work or tempfile.mkdtemp(prefix="rw_fdi_figures_"))
    lines, seconds = [], {}
    with _day_beside("dumping" in names, work / "dumping") as day:
        for name in names:
            if progress:
                progress(name, None)
            t0 = time.monotonic()
            result = _run_bench(name, work / name, day)
            seconds[name] = time.monotonic() - t0
            path = Path(RECORDS[name]) if name in RECORDS else None
            record = json.loads(path.read_text()) if path is not None and path.is_file() else None
            lines += figures_of(name, result, rows, record)
            if progress:
                progress(name, [x for x in lines if any(f.bench == name and f.label == x["figure"] for f in FIGURES)])
    flagged = sum(x["flagged"] for x in lines)
    return {"work": str(work), "seconds": seconds, "figures": lines, "flagged": flagged,
            "ok": flagged == 0, "text": format_check(lines, seconds)}


@contextmanager
def _day_beside(wanted: bool, out: Path):
    """The day in orbit (one process, 16 simulated hours: the check's longest single piece of work) started at
    once in a process of its own, beside the other benches; yields its future (None when not ``wanted``)."""
    if not wanted:
        yield None
        return
    from concurrent.futures import ProcessPoolExecutor
    from .dumping_bench import bench_day
    pool = ProcessPoolExecutor(max_workers=1)
    try:
        yield pool.submit(bench_day, SMALL["dumping"]["hours"], 1, out)
    finally:
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:   # SIGTERM, Ctrl-C: no orphan left simulating
            process.kill()


def format_check(lines: list, seconds: dict) -> str:
    out = [f"Every figure of the README's table at small n ({sum(seconds.values()) / 60:.1f} min: "
           + ", ".join(f"{k} {v:.0f} s" for k, v in seconds.items()) + ")", ""]
    row = None
    for x in lines:
        if x["row"] != row:
            row = x["row"]
            out.append(f"{row.strip('*')}\n    README: {x['readme']}")
        mark = "  << OUTSIDE" if x["flagged"] else ""
        out.append(f"    {x['figure']:48s} {x['small']:34s} record {x['record']}{mark}")
    flagged = sum(x["flagged"] for x in lines)
    out += ["", f"{flagged} figure(s) outside the record's interval" if flagged else
            "every figure within its record's interval (the small and the record's 95 % intervals meet)"]
    return "\n".join(out) + "\n"

