"""`rw-fdi bench dumping`: momentum dumping by the magnetorquers, and the FDI through it.

Two parts, both by the node code on the core loop (the plant, controllers, allocation and the
momentum-dumping law the nodes run; the FDI by screen):

1. **A day in orbit** (scenario ``dumping_day``: the thesis' 700 km sun-synchronous orbit, IGRF, gravity
   gradient and the residual dipole, inertial hold): the same seed with dumping and with the rods off.
   Figures: the band the wheels in use stay in, the pointing error after the first slew settles, how
   many dumps and how long; without dumping, when a wheel first needs the whole 5 V command and when
   the pointing first leaves 0.2 deg. A plot (``day.png``).
2. **The FDI through dumping**: continuous operations in orbit (manoeuvres every 60-900 s, dumps
   whenever a wheel passes the start speed), fault-free, >= 100 simulated hours; and a 10 % current loss
   and +30 C with the onset inside a dump (wheels started above the start speed, so that a dump begins
   at once; the onset drawn from the seed inside the first dump of the run's fault-free twin, which is
   the same run up to the onset). Seeds from 87,000,000 (no other bench, training or fitting uses them).
"""
from __future__ import annotations

import time
from dataclasses import replace
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ...fdi_config import FdiConfig
from ...core.closed_loop import simulate
from ...core.physics.environment import MAGNETOMETER_PERIOD, OrbitEnvironment, magnetometer_steps
from ...core.mission.plant_choices import DEFAULT
from ...core.physics.magnetorquers import DumpLog, MomentumDumping
from ...core.mission.scenario import Fault, Manoeuvres, Scenario, load_scenario
from ...core.physics.wheel import WheelParams, top_speed
from ...core.physics.spacecraft import BODY_AXES
from ...core.mission.vehicle import DEFAULT_VEHICLE, load_vehicle
from .kit import (Cell, SpeedAwareChunk, bench_scenario, bench_wheels, cell_figures, fault_wheel, format_rate,
                  screen_cells, vehicle_words, workers,
                  write_cells_table, write_report)
from ...scoring.metrics import observable_level

SEED_BASE = 87_000_000   # docs/fdi.md "Seeds": no other bench, training or fitting uses them
POINTING_LIMIT_DEG = 0.2
SETTLE_S = 600.0   # the first slew (Table 2.3's set-point change at 0 s) is over by then
HOURS = Manoeuvres(interval_s=(60.0, 900.0))
EVERY = magnetometer_steps(DEFAULT.control_period)   # series at the magnetometer's readings


def dumps(dipole, time, every: int = 1) -> list:
    """[(start, end)] [s] of the intervals the rods were on, from series (n, 3) sampled ``every`` steps (the
    dipole changes on magnetometer steps only: take those)."""
    log = DumpLog()
    for t, d in zip(time[::every], dipole[::every]):
        log.add(t, d)
    return log.done()


def zero_crossings(speed) -> int:
    """How often the wheels' speeds (n, N) change sign."""
    s = np.sign(speed)
    return int(np.sum((s[1:] * s[:-1]) < 0))


def day_figures(traj, run: int, limit: float) -> dict:
    """The figures of run ``run`` of a day's trajectory."""
    t = traj.time
    in_use = traj.in_use[:, run]
    speed = np.where(in_use, traj.wheel_speed[:, run], np.nan)
    error = np.rad2deg(np.abs(traj.error[:, run])).max(axis=-1)
    after = t >= SETTLE_S
    at_limit = np.any(in_use & (np.abs(traj.tcv[:, run]) >= limit - 1e-9), axis=-1) & after
    outside = (error > POINTING_LIMIT_DEG) & after
    intervals = dumps(traj.dipole[:, run], t)
    return {"wheel_speed_band": [float(np.nanmin(speed)), float(np.nanmax(speed))],
            "max_abs_wheel_speed": float(np.nanmax(np.abs(speed))),
            "max_pointing_error_deg": float(error[after].max()),
            "first_command_limit_s": float(t[np.argmax(at_limit)]) if at_limit.any() else None,
            "first_pointing_loss_s": float(t[np.argmax(outside)]) if outside.any() else None,
            "dumps": len(intervals),
            "dumping_hours": sum(b - a + MAGNETOMETER_PERIOD for a, b in intervals) / 3600.0,
            "dump_intervals_s": intervals, "zero_crossings": zero_crossings(traj.wheel_speed[:, run][:, in_use[0]])}


def rods_of(vehicle: str) -> MomentumDumping:
    """The magnetorquers and dumping law ``vehicle`` flies (the thesis': MomentumDumping's defaults)."""
    return MomentumDumping() if vehicle == DEFAULT_VEHICLE else load_vehicle(vehicle).magnetorquers


def day_scenario(vehicle: str, hours: float, seed: int) -> Scenario:
    """``dumping_day`` flown by ``vehicle``: the thesis' orbit, another vehicle with its own rods, law and
    residual dipole."""
    day = replace(load_scenario("dumping_day").with_seed(seed), duration=hours * 3600.0)
    if vehicle == DEFAULT_VEHICLE:
        return day
    return bench_scenario(vehicle, day.name, duration=day.duration, seed=seed, magnetorquers=rods_of(vehicle),
                          environment=replace(day.environment, residual_dipole=None))


def bench_day(hours: float = 24.0, seed: int = 1, out: Path | None = None, vehicle: str = DEFAULT_VEHICLE) -> dict:
    """A day in orbit with dumping and with the rods off (the same seed), flown by ``vehicle``."""
    with_dumping = day_scenario(vehicle, hours, seed)
    rods_off = replace(with_dumping, magnetorquers=replace(with_dumping.magnetorquers, enabled=False))
    t0 = time.monotonic()
    traj = simulate([with_dumping, rods_off], duration=with_dumping.duration, every=EVERY)
    limit = with_dumping.spacecraft.wheel.command_limit
    report = {"scenario": "dumping_day", "seed": seed, "hours": hours, "seconds": time.monotonic() - t0,
              "with_dumping": day_figures(traj, 0, limit), "rods_off": day_figures(traj, 1, limit),
              "settle_s": SETTLE_S, "command_limit_V": limit, "start_speed": with_dumping.magnetorquers.start_speed}
    if out is not None:
        plot_day(traj, report, Path(out) / "day.png")
    return report


def plot_day(traj, report: dict, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    h = traj.time / 3600.0
    fig, axes = plt.subplots(4, 1, figsize=(11, 11), sharex=True)
    names = traj.wheel_names
    for run, (label, style) in enumerate((("with dumping", "-"), ("rods off", ":"))):
        for i, name in enumerate(names):
            if traj.in_use[0, run, i]:
                axes[0].plot(h, traj.wheel_speed[:, run, i], style, lw=0.8, color=f"C{i}",
                             label=f"wheel {name}, {label}")
    start = report.get("start_speed", MomentumDumping().start_speed)
    axes[0].axhspan(-start, start, color="0.92", zorder=0)
    axes[0].set_ylabel("wheel speed [rad/s]")
    axes[0].legend(ncol=2, fontsize=7, loc="upper left")
    axes[0].set_title(f"A day in orbit (dumping_day, seed {report['seed']}): shaded, the speeds below the "
                      "dump start", fontsize=10)
    for i, axis in enumerate(BODY_AXES):
        axes[1].plot(h, traj.dipole[:, 0, i], lw=0.8, label=f"m_{axis}")
    axes[1].set_ylabel("rod dipole [A m^2]")
    axes[1].legend(fontsize=7, loc="upper left")
    for run, label in enumerate(("with dumping", "rods off")):
        err = np.rad2deg(np.abs(traj.error[:, run])).max(axis=-1)
        axes[2].semilogy(h, np.maximum(err, 1e-6), lw=0.8, label=label)
        axes[3].plot(h, np.abs(traj.tcv[:, run][:, traj.in_use[0, run]]).max(axis=-1), lw=0.8, label=label)
    axes[2].axhline(POINTING_LIMIT_DEG, color="k", ls="--", lw=0.8)
    axes[2].set_ylabel("pointing error [deg]")
    axes[2].legend(fontsize=7, loc="upper left")
    axes[3].axhline(report.get("command_limit_V", WheelParams().command_limit), color="k", ls="--", lw=0.8)
    axes[3].set_ylabel("largest |tcv| [V]")
    axes[3].set_xlabel("time [h]")
    axes[3].legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- the FDI through dumping ----------------------------------------------------------------------------

# a cell of this bench: 6-h runs
dumping_cell = partial(Cell, duration=6 * 3600.0)


DUMP_START = 38.0   # the fault cells' initial wheel speed: above the start speed, a dump begins at once
# 3x the residual dipole: the wheels drift 3x faster and are dumped 3x as often
STRONG_FACTOR = 3.0
STRONG = OrbitEnvironment(residual_dipole=(1.5, 1.5, 1.5))
CELLS = (
    dumping_cell("operations in orbit with dumping, 6-h runs"),
    dumping_cell("the same, a residual dipole of 2.6 A m^2", environment=STRONG),
    # a fault cell's onset lies inside the run's first dump (cell_scenarios)
    dumping_cell("current loss 10 % during a dump", "current_limiter", 0.9, duration=1800.0, wheel_speed=DUMP_START),
    dumping_cell("temperature +30 C during a dump", "temperature", 53.0, duration=1800.0, wheel_speed=DUMP_START),
)


def cells_of(vehicle: str) -> tuple:
    """CELLS as ``vehicle`` flies them: another vehicle's strong-dipole cell has STRONG_FACTOR times its own."""
    if vehicle == DEFAULT_VEHICLE:
        return CELLS
    dipole = tuple(STRONG_FACTOR * x for x in load_vehicle(vehicle).residual_dipole)
    strong = (f"the same, {STRONG_FACTOR:g}x the vehicle's residual dipole ({np.linalg.norm(dipole):.2g} A m^2)",
              OrbitEnvironment(residual_dipole=dipole))
    return tuple(c if c.environment.residual_dipole is None else replace(c, name=strong[0], environment=strong[1])
                 for c in CELLS)


def cell_scenarios(cell: Cell, seeds, index: int, seed_base: int = SEED_BASE, vehicle: str = DEFAULT_VEHICLE) -> list:
    """The runs ``seeds`` (a range) of a cell flown by ``vehicle``: seed seed_base + 100,000 index + n; in a
    fault cell the fault on a wheel in use (fault_wheel), its onset drawn from the seed inside the first dump
    of the fault-free twin (10 s after it starts to 10 s before it ends)."""
    base, wheels, rods = [], bench_wheels(vehicle), rods_of(vehicle)
    speed = cell.wheel_speed
    if speed is not None and vehicle != DEFAULT_VEHICLE:   # as far above this vehicle's dump start, within reach
        wheel = load_vehicle(vehicle).wheel
        speed = min(speed * rods.start_speed / MomentumDumping().start_speed, 0.95 * top_speed(wheel))
    for n in seeds:
        seed = seed_base + 100_000 * index + n
        initial = {} if speed is None else {"wheel_speed": (speed,) * len(wheels.active)}
        base.append(bench_scenario(vehicle, cell.name, duration=cell.duration, seed=seed, initial=initial,
                                   manoeuvres=HOURS, environment=cell.environment, magnetorquers=rods))
    if cell.kind is None:
        return base
    twins = simulate(base, every=EVERY)
    out = []
    for b, scenario in enumerate(base):
        # already every EVERY steps; a twin that never dumps (its wheels held below the start): onset mid-run
        first = (dumps(twins.dipole[:, b], twins.time) or [(0.25 * cell.duration, 0.75 * cell.duration)])[0]
        lo, hi = first[0] + 10.0, max(first[0] + 10.0, first[1] - 10.0)
        onset = float(np.round(np.random.default_rng(scenario.seed).uniform(lo, hi), 1))
        out.append(scenario.with_faults([Fault(cell.kind, fault_wheel(scenario.seed, wheels), onset, cell.value)]))
    return out


def _cell_runs(cell_index: int, seeds, seed_base: int, vehicle: str = DEFAULT_VEHICLE) -> list:
    return cell_scenarios(cells_of(vehicle)[cell_index], seeds, cell_index, seed_base, vehicle)


def dumping_of(scenario, traj, b: int) -> SimpleNamespace:
    """What a run's trajectory says of its dumping: time with the rods on [s], dumps, the wheels in use's
    zero crossings and fastest speed."""
    intervals = dumps(traj.dipole[:, b], traj.time, EVERY)
    in_use = traj.in_use[0, b]
    speed = traj.wheel_speed[:, b][:, in_use]
    onset = min((f.onset for f in scenario.faults), default=None)
    at = None if onset is None else int(np.searchsorted(traj.time, onset))
    # a dipole is held for a magnetometer period after the reading it answers
    return SimpleNamespace(seed=scenario.seed, dumping_s=sum(e - s + MAGNETOMETER_PERIOD for s, e in intervals),
                           dumps=len(intervals), zero_crossings=zero_crossings(speed),
                           max_speed=float(np.abs(speed).max()),
                           onset_in_dump=None if at is None else bool(np.any(traj.dipole[at, b] != 0.0)))


def bench_dumping(hours: float = 24.0, seed: int = 1, operations_runs: int = 20, runs_per_cell: int = 100,
                  out: str | Path = "reports/dumping", executor=None, day: dict | None = None,
                  vehicle: str = DEFAULT_VEHICLE) -> dict:
    """The day in orbit (``day``: its :func:`bench_day` report, made elsewhere, e.g. beside other work: it is one
    process) and the cells of runs in orbit, flown by ``vehicle`` with its FDI; the report in ``out``."""
    t0 = time.monotonic()
    day = day if day is not None else bench_day(hours, seed, Path(out), vehicle)
    _, curves = FdiConfig().for_vehicle(vehicle).load()
    level = observable_level(curves, load_vehicle(vehicle).wheel)
    cells_run = cells_of(vehicle)
    sizes = [operations_runs if c.kind is None else runs_per_cell for c in cells_run]
    judged = screen_cells(sizes, SpeedAwareChunk(partial(_cell_runs, vehicle=vehicle), SEED_BASE, dumping_of,
                                                 vehicle=vehicle), "dumping bench (FDI)", executor,
                          chunk=10, out=out, name="dumping")
    write_cells_table(judged, [c.name for c in cells_run], out, "dumping")
    cells = {}
    for i, cell in enumerate(cells_run):
        runs = judged[i]["speed_aware"]
        columns = list(runs[0].series)
        entry = {"cell": {"name": cell.name, "kind": cell.kind, "value": cell.value, "duration": cell.duration,
                          "wheel_speed": cell.wheel_speed},
                 "seeds": [SEED_BASE + 100_000 * i, SEED_BASE + 100_000 * i + sizes[i] - 1],
                 "hours": sum(r.series[columns[0]].time[-1] for r in runs) / 3600.0,
                 "observers": {obs: cell_figures(runs, obs, level) for obs in columns}}
        seen = judged[i]["runs"]
        entry["dumping"] = {"hours": sum(d.dumping_s for d in seen) / 3600.0, "dumps": sum(d.dumps for d in seen),
                            "zero_crossings": sum(d.zero_crossings for d in seen),
                            "max_speed": max(d.max_speed for d in seen)}
        if cell.kind is not None:
            entry["dumping"]["onset_in_dump"] = sum(bool(d.onset_in_dump) for d in seen)
        if cell.kind is None:
            entry["runs_not_judged_somewhere"] = sum(bool(r.health) for r in runs)
            entry["false_alarm_runs"] = {obs: sum(bool(r.series[obs].alarm.any()) for r in runs) for obs in columns}
        cells[cell.name] = entry
    report = {"schema": "rw_fdi_ros/dumping_bench/1", "seconds": time.monotonic() - t0, "jobs": workers(executor),
              "date": time.strftime("%Y-%m-%d"), "vehicle": vehicle, "seed_base": SEED_BASE,
              "observable_level_Nm": level, "day": day, "cells": cells, "settings": rods_of(vehicle).__dict__}
    return write_report(report, out, "dumping", format_dumping)


def _hours(seconds) -> str:
    return "never" if seconds is None else f"{seconds / 3600.0:.1f} h"


def format_dumping(report: dict) -> str:
    day, on, off = report["day"], report["day"]["with_dumping"], report["day"]["rods_off"]
    s = report["settings"]
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    flown = "" if vehicle == DEFAULT_VEHICLE else f", {vehicle_words(vehicle)}"
    fdi = "Shipped" if vehicle == DEFAULT_VEHICLE else "The vehicle's"
    lines = [f"# Momentum dumping and the FDI through it (`rw-fdi bench dumping`{flown})", "",
             f"Measured {report['date']}; {report['seconds'] / 60:.0f} min on this machine. Law: cross-product, "
             f"gain {s['gain']:g} 1/s, rods {s['dipole_limit']:g} A m^2, a dump from a wheel in use above "
             f"{s['start_speed']:g} rad/s until the net momentum is what one wheel holds at {s['stop_speed']:g} "
             "rad/s.", "",
             f"## A day in orbit (`dumping_day`, seed {day['seed']}, {day['hours']:g} h)", "",
             "![a day in orbit](day.png)", "",
             "| | with dumping | rods off |", "|---|---|---|",
             f"| wheel speeds (wheels in use) [rad/s] | {on['wheel_speed_band'][0]:.1f} .. "
             f"{on['wheel_speed_band'][1]:.1f} | {off['wheel_speed_band'][0]:.1f} .. "
             f"{off['wheel_speed_band'][1]:.1f} |",
             f"| largest pointing error after {day['settle_s']:g} s [deg] | {on['max_pointing_error_deg']:.4f} | "
             f"{off['max_pointing_error_deg']:.3f} |",
             f"| a wheel first at the {day.get('command_limit_V', 5.0):g} V command limit | "
             f"{_hours(on['first_command_limit_s'])} | "
             f"{_hours(off['first_command_limit_s'])} |",
             f"| pointing first beyond {POINTING_LIMIT_DEG} deg | {_hours(on['first_pointing_loss_s'])} | "
             f"{_hours(off['first_pointing_loss_s'])} |",
             f"| dumps (hours with the rods on) | {on['dumps']} ({on['dumping_hours']:.1f} h) | - |",
             f"| wheel speed zero crossings | {on['zero_crossings']} | {off['zero_crossings']} |", "",
             "## The FDI through dumping", "",
             f"{fdi} speed-aware FDI, seeds from "
             f"{report['seed_base']:,}. Rates with 95 % Wilson intervals; `verdict`: what /diagnostics says.", ""]
    cells = report["cells"]
    columns = list(next(iter(cells.values()))["observers"])
    lines += ["| case | hours | dumping: hours, dumps, zero crossings | " + " | ".join(
        f"{o} false alarms" for o in columns) + " |", "|---|---|---|" + "---|" * len(columns)]
    for name, c in cells.items():
        if c["cell"]["kind"] is None:
            d = c["dumping"]
            lines.append(f"| {name} | {c['hours']:.0f} | {d['hours']:.1f} h, {d['dumps']}, {d['zero_crossings']} | "
                         + " | ".join(format_rate(c["observers"][o]["false_alarm"]) for o in columns) + " |")
    lines += ["", "Runs in which /diagnostics said STALE somewhere (a wheel beyond the operating envelope's 45 "
              "rad/s, not judged there): " + ", ".join(
                  f"{name}: {c['runs_not_judged_somewhere']} of {c['observers'][columns[0]]['false_alarm']['n']}"
                  for name, c in cells.items() if c["cell"]["kind"] is None) + "."]
    lines += ["", "Faults with the onset inside a dump: " + ", ".join(
        f"{name}: {c['dumping']['onset_in_dump']} of {c['observers'][columns[0]]['correct']['n']}"
        for name, c in cells.items() if c["cell"]["kind"] is not None) + ".", "",
        "| case | observer | correct | detected | delay median / p90 [s] | held to end | alarm before onset |",
        "|---|---|---|---|---|---|---|"]
    for name, c in cells.items():
        if c["cell"]["kind"] is None:
            continue
        for obs in columns:
            f = c["observers"][obs]
            d = f["delay_s"]
            delay = f"{d['median']:.0f} / {d['p90']:.0f}" if d["median"] is not None else "-"
            lines.append(f"| {name} | {obs} | {format_rate(f['correct'])} | {format_rate(f['detected'])} | {delay} | "
                         f"{format_rate(f['held_to_end'])} | {format_rate(f['alarm_before_onset'])} |")
    return "\n".join(lines) + "\n"
