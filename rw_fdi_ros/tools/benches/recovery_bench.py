"""`rw-fdi bench recovery`: the redundant wheel takes over from a wheel the FDI confirmed faulty.

Each run is the core loop with the FDI's verdict made in it (core/fdi/pipeline.py) and the
reconfiguration it decides (core/fdir.py): three orthogonal wheels and the standby wheel s
along (1, 1, 1)/sqrt(3) (wheel set ``orthogonal_skew``). One fault on wheel seed mod 3 at an
onset drawn from the seed; the pointing requirement is 0.2 deg on every axis.

A run *recovers* when its pointing error is within 0.2 deg on every axis from at most 60 s after
the onset to the end. Angular momentum decides whether it can: the wheel given up spins down and
its momentum must go into the wheels in use; s, at 1/sqrt(3) to the axis it takes over, must spin
sqrt(3) times as fast as the lost wheel did (fdir.held_speeds). Each run is classed by that need at
the onset: *holdable* when every wheel in use would stay within 45 rad/s (the FDI's envelope, just
under the 47.3 rad/s where friction takes the whole 5 V). Where it is not, FDIR holds the faulty
wheel at its speed instead of giving it up (*held*), and the wheels in use take only the momentum
it sheds. Two wheel-speed envelopes: Table 2.3's 20-30 rad/s, and 10-22 rad/s.

Seeds: evaluation from 86,000,000 (the figures of record); the design was looked at on 85,000,000+.
"""
from __future__ import annotations

import time
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np

from ...fdi_config import FdiConfig
from ...core.flight import Fdir
from ...core.closed_loop import simulate
from ...core.fdir import held_speeds
from ...core.fdi.verdict import speed_envelope
from ...core.mission.scenario import Fault, Manoeuvres, Scenario
from ...core.physics.spacecraft import BODY_AXES
from ...core.mission.vehicle import DEFAULT_VEHICLE, load_vehicle
from ...core.physics.wheel_set import WHEEL_SETS
from ...scoring.metrics import rate
from .kit import (Cell, bench_scenario, bench_wheels, cell_on_bus, fault_wheel, format_rate, write_report,
                  write_runs_table)

SEED_BASES = {"tuning": 85_000_000, "evaluation": 86_000_000}
POINTING_DEG = 0.2
RECOVERY_S = 60.0
WHEELS = WHEEL_SETS["orthogonal_skew"]
BATCH = 50
ACTED = ("out_of_use", "held", "kept_in_use")   # what FDIR does with a wheel it confirmed faulty


# a cell of this bench: the fault's onset in 120-280 s
recovery_cell = partial(Cell, onset_range=(120.0, 280.0))
# what this bench varies and reports of a cell
FIELDS = ("name", "kind", "value", "speeds", "onset_range", "second", "manoeuvres")
FAULTS = (("bus 4 V", "bus_voltage", 4.0), ("bus 5.5 V", "bus_voltage", 5.5),
          ("current loss 40 %", "current_limiter", 0.6), ("temperature +150 C", "temperature", 173.0),
          ("current loss 10 %", "current_limiter", 0.9), ("temperature +30 C", "temperature", 53.0))
CELLS = (
    *(recovery_cell(f"{name}, wheels 20-30 rad/s", kind, value) for name, kind, value in FAULTS),
    *(recovery_cell(f"{name}, wheels 10-22 rad/s", kind, value, speeds=(10.0, 22.0)) for name, kind, value in FAULTS),
    recovery_cell("fault-free operations", manoeuvres=Manoeuvres(interval_s=(100.0, 300.0))),
    recovery_cell("current loss 40 %, then +150 C on s", "current_limiter", 0.6, speeds=(10.0, 22.0),
         onset_range=(100.0, 180.0), second=("temperature", 173.0)),
)


def cells_of(vehicle: str = DEFAULT_VEHICLE) -> tuple:
    """(index in CELLS, cell) of ``vehicle``: all of CELLS, but the second fault on the standby wheel where there
    is none; the wheel speeds its own (:func:`vehicle_speeds`)."""
    standby = bool(bench_wheels(vehicle).standby)
    return tuple((i, vehicle_cell(c, vehicle)) for i, c in enumerate(CELLS) if c.second is None or standby)


def vehicle_speeds(speeds: tuple, vehicle: str) -> tuple:
    """A cell's wheel speeds on ``vehicle``: Table 2.3's 20-30 rad/s is its initial wheel-speed dispersion
    (lo, hi), and the slower 10-22 rad/s its (lo / 2, hi - 0.8 (hi - lo)), as they are for the thesis' vehicle."""
    lo, hi = load_vehicle(vehicle).dispersions.wheel_speed
    return (lo, hi) if speeds == (20.0, 30.0) else (lo / 2.0, hi - 0.8 * (hi - lo))


def vehicle_cell(cell: Cell, vehicle: str) -> Cell:
    """``cell`` with ``vehicle``'s wheel speeds and bus (kit.cell_on_bus), its name saying them (the thesis'
    vehicle: itself)."""
    cell = cell_on_bus(cell, vehicle)
    speeds = vehicle_speeds(cell.speeds, vehicle)
    if speeds == cell.speeds:
        return cell
    name = cell.name.replace(f"{cell.speeds[0]:g}-{cell.speeds[1]:g} rad/s", f"{speeds[0]:g}-{speeds[1]:g} rad/s")
    return replace(cell, name=name, speeds=speeds)


def cell_scenarios(cell: Cell, runs: int, index: int, seed_base: int, vehicle: str = DEFAULT_VEHICLE) -> list:
    wheels = bench_wheels(vehicle)
    out = []
    for n in range(runs):
        seed = seed_base + 100_000 * index + n
        rng = np.random.default_rng([seed, 9])
        faults = ()
        if cell.kind is not None:
            onset = float(np.round(rng.uniform(*cell.onset_range), 1))
            faults = (Fault(cell.kind, fault_wheel(seed, wheels), onset, cell.value),)
            if cell.second is not None:   # on the standby wheel
                faults += (Fault(cell.second[0], wheels.names.index(wheels.standby[0]), onset + 100.0,
                                 cell.second[1]),)
        # one speed per wheel in use: three body-axis speeds spread minimum-norm over a pyramid leave two wheels
        # near zero, where the Coulomb friction flips and the null-space hold keeps them (the thesis' set: three)
        speeds = tuple(float(v) for v in rng.uniform(*cell.speeds, len(wheels.active)))
        # the thesis' runs name their set (the default's), as they always did
        plant = {"plant": {"wheel_set": WHEELS.name}} if vehicle == DEFAULT_VEHICLE else {}
        out.append(bench_scenario(vehicle, cell.name, seed=seed, faults=faults, initial={"wheel_speed": speeds},
                                  manoeuvres=cell.manoeuvres, **plant))
    return out


def run_figures(traj, b: int, scenario: Scenario) -> dict:
    """What one run did: decisions, whether the momentum was holdable, recovery time and peak error."""
    wheels = scenario.wheel_set()
    error = np.degrees(np.abs(traj.error[:, b])).max(axis=1)
    decisions = [(d.time, d.wheel, d.action) for d in traj.decisions[b]]
    out = {"seed": scenario.seed, "decisions": decisions}
    if not scenario.faults:
        return out
    fault = scenario.faults[0]
    lost = wheels.names[fault.wheel]
    i0 = int(np.searchsorted(traj.time, fault.onset))
    need = held_speeds(wheels, [n for n in wheels.names if n != lost], traj.wheel_speed[i0, b])
    late = np.nonzero(error[i0:] >= POINTING_DEG)[0]
    recover = float(traj.time[i0 + late[-1]] + 0.1 - fault.onset) if len(late) else 0.0
    given_up = [w for t, w, a in decisions if a == "out_of_use"]
    envelope = speed_envelope(scenario.spacecraft.wheel)   # the FDI's envelope of the wheel type (45 rad/s, Type A)
    out.update(wheel=lost, onset=fault.onset, holdable=bool(np.abs(need).max() <= envelope),
               need_rad_s=float(np.abs(need).max()), peak_deg=float(error[i0:].max()), recover_s=recover,
               recovered=recover <= RECOVERY_S, reconfigured=lost in given_up,
               kept=any(w == lost and a == "kept_in_use" for _, w, a in decisions),
               held=any(w == lost and a == "held" for _, w, a in decisions),
               healthy_given_up=[w for _, w, a in decisions if a in ACTED and w != lost
                                 and not (len(scenario.faults) > 1 and w in wheels.standby)],
               reconfigured_s=next((t - fault.onset for t, w, a in decisions
                                    if w == lost and a in ACTED),
                                   None))
    if len(scenario.faults) > 1:   # the later fault on s: confirmed (kept in use: no wheel is left)
        out["second_detected"] = any(w in wheels.standby for _, w, a in decisions
                                     if a in ("kept_in_use", "held", "out_of_use"))
    return out


def summarize(cell: Cell, runs: list) -> dict:
    if cell.kind is None:
        return {"reconfigured": rate(bool(r["decisions"]) for r in runs)}
    held = [r for r in runs if r["holdable"]]
    out = {"recovered": rate(r["recovered"] for r in runs),
           "holdable": rate(r["holdable"] for r in runs),
           "recovered_holdable": rate(r["recovered"] for r in held),
           "recovered_not_holdable": rate(r["recovered"] for r in runs if not r["holdable"]),
           "reconfigured": rate(r["reconfigured"] for r in runs),
           "kept": rate(r["kept"] for r in runs),
           "held": rate(r.get("held", False) for r in runs),
           "recovered_holdable_reconfigured": rate(r["recovered"] for r in held if r["reconfigured"]),
           "healthy_given_up": rate(bool(r["healthy_given_up"]) for r in runs)}
    for key in ("peak_deg", "recover_s", "reconfigured_s"):   # over every run: a held wheel recovers too
        values = np.array([r[key] for r in runs if r[key] is not None])
        out[key] = ({"median": float(np.median(values)), "p90": float(np.percentile(values, 90)),
                     "max": float(values.max())} if values.size else None)
    if cell.second is not None:
        out["second_detected"] = rate(r["second_detected"] for r in runs)
    return out


def bench_recovery(runs_per_cell: int = 100, fault_free_runs: int = 1000, seeds: str = "evaluation",
                   out: str | Path = "reports/recovery", progress=None, executor=None,
                   vehicle: str = DEFAULT_VEHICLE) -> dict:
    """The recovery figures of every cell, its runs in batches on ``executor`` (local processes by default, or a
    Dask cluster; the same runs either way: each is drawn from its seed); the report, and one row a run
    (recovery_runs.csv), in ``out``."""
    from ..campaigns.campaign import LocalExecutor
    from .journal import resumable_map
    seed_base = SEED_BASES[seeds]
    t0 = time.monotonic()
    cells_run = [c for _, c in cells_of(vehicle)]
    sizes = [fault_free_runs if cell.kind is None else runs_per_cell for cell in cells_run]
    work = [(i, seed_base, range(start, min(start + BATCH, n)), vehicle) for i, n in enumerate(sizes)
            for start in range(0, n, BATCH)]
    by_cell = {i: [] for i in range(len(cells_run))}
    # the campaigns' executor: SIGTERM or Ctrl-C drops the queued batches and ends the workers at once; the
    # finished ones are kept in out, and the same command resumes
    for i, runs in resumable_map(executor or LocalExecutor(), _batch, work, out, "recovery"):
        by_cell[i] += runs
        if progress:
            progress(len(runs))
    cells = {}
    for i, cell in enumerate(cells_run):
        runs = sorted(by_cell[i], key=lambda r: r["seed"])
        manoeuvres = cell.manoeuvres and cell.manoeuvres.__dict__
        cells[cell.name] = {"cell": {**cell.as_dict(FIELDS), "manoeuvres": manoeuvres},
                            "seeds": [runs[0]["seed"], runs[-1]["seed"]], "figures": summarize(cell, runs),
                            "runs": runs}
    Path(out).mkdir(parents=True, exist_ok=True)
    write_runs_table([{"cell": name, **r} for name, c in cells.items() for r in c["runs"]],
                     Path(out) / "recovery_runs.csv")
    report = {"schema": "rw_fdi_ros/recovery_bench/1", "seconds": time.monotonic() - t0,
              "date": time.strftime("%Y-%m-%d"), "seed_set": seeds, "seed_base": seed_base,
              "vehicle": vehicle, "wheel_set": bench_wheels(vehicle).name, "pointing_deg": POINTING_DEG,
              "recovery_s": RECOVERY_S, "cells": cells}
    report = write_report(report, out, "recovery", format_recovery)
    if vehicle == DEFAULT_VEHICLE:   # the thesis' figure: a bus drop on x, s taking over
        plot_before_after(Path(out) / "pointing_before_after.png", Fdir(FdiConfig().loaded()))
    return report


def _batch(work) -> tuple:
    """(cell index, the figures of its runs ``seeds``): one batch of the core loop, what a worker computes."""
    i, seed_base, seeds, vehicle = work
    fdi = FdiConfig().for_vehicle(vehicle).loaded()
    # a cell's seeds follow its index among all CELLS: a vehicle's runs are the thesis' seeds where they share it
    index, cell = cells_of(vehicle)[i]
    scenarios = cell_scenarios(cell, seeds.stop, index, seed_base, vehicle)[seeds.start:]
    traj = simulate(scenarios, fdir=Fdir(fdi))
    return i, [run_figures(traj, b, s) for b, s in enumerate(scenarios)]


def _stat(s) -> str:
    return "-" if s is None else f"{s['median']:.2f} / {s['p90']:.2f} / {s['max']:.2f}"


def format_recovery(report: dict) -> str:
    vehicle = report.get("vehicle", DEFAULT_VEHICLE)
    envelope = speed_envelope(load_vehicle(vehicle).wheel)
    lines = ["# The redundant wheel takes over (`rw-fdi bench recovery`)" if vehicle == DEFAULT_VEHICLE else
             f"# The wheels left take over (`rw-fdi bench recovery --vehicle {vehicle}`)", "",
             f"Measured {report['date']}, {report['seed_set']} seeds from {report['seed_base']:,}; "
             f"{report['seconds'] / 60:.0f} min on this machine. Wheel set {report['wheel_set']}; the core loop with "
             "the FDI verdict and FDIR in it. Recovered: within 0.2 deg on every axis from at most 60 s after the "
             "onset to the end of the 400-s run. Holdable: at the onset, the wheels in use after the reconfiguration "
             f"can hold the spacecraft's momentum within {envelope:.4g} rad/s (the FDI's envelope of the wheel "
             "type). Given up: 0 V from the decision on. Kept: in "
             "use beside s, all four sharing the work (the three left could not hold the momentum and still slew; "
             "it gives at least half its torque). Held: confirmed, relieved of control and held at its speed (a "
             "momentum store): it gives less than half its torque. 95 % Wilson intervals.", "",
             "| case | recovered, all | holdable | recovered, holdable | given up | kept beside s | held "
             "| healthy wheel given up | peak error [deg] med/p90/max | time to recover [s] med/p90/max "
             "| onset to decision [s] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, c in report["cells"].items():
        f = c["figures"]
        if c["cell"]["kind"] is None:
            continue
        lines.append(f"| {name} | {format_rate(f['recovered'])} | {format_rate(f['holdable'])} | "
                     f"{format_rate(f['recovered_holdable'])} | {format_rate(f['reconfigured'])} | "
                     f"{format_rate(f['kept'])} | {format_rate(f['held'])} | "
                     f"{format_rate(f['healthy_given_up'])} | {_stat(f['peak_deg'])} | {_stat(f['recover_s'])} | "
                     f"{_stat(f['reconfigured_s'])} |")
    for name, c in report["cells"].items():
        f = c["figures"]
        if c["cell"]["kind"] is None:
            lines += ["", f"Fault-free ({name}, 400 s, manoeuvres every 100-300 s): a reconfiguration in "
                      f"{format_rate(f['reconfigured'])}."]
        elif "second_detected" in f:
            lines += ["", f"A later fault on the redundant wheel ({name}): confirmed in "
                      f"{format_rate(f['second_detected'])} (kept in use: no wheel left to replace it)."]
    every = [r for c in report["cells"].values() if c["cell"]["kind"] is not None and c["cell"]["second"] is None
             for r in c["runs"]]
    if every:
        lines += ["", f"Every single-fault run: recovered in {format_rate(rate(r['recovered'] for r in every))}; "
                  f"a healthy wheel given up in {format_rate(rate(bool(r['healthy_given_up']) for r in every))}."]
    return "\n".join(lines) + "\n"


def plot_before_after(path: Path, fdir: Fdir):
    """The pointing error of the main job's scenario (fdir_bus_x: bus 4.5 V on x), without and with FDIR."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from ...core.mission.scenario import load_scenario
    scenario = load_scenario("fdir_bus_x")
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), sharey=True)
    for ax, (label, f) in zip(axes, (("before: the faulty wheel x stays in use", None),
                                     ("after: FDIR (x held, s brought in)", fdir))):
        traj = simulate([scenario], fdir=f)
        for i, a in enumerate(BODY_AXES):
            ax.semilogy(traj.time, np.maximum(np.degrees(np.abs(traj.error[:, 0, i])), 1e-5), label=a)
        ax.axhline(POINTING_DEG, color="k", ls="--", lw=0.8)
        for fault in scenario.faults:
            ax.axvline(fault.onset, color="r", ls=":", lw=0.8)
        for d in traj.decisions[0] if traj.decisions else ():
            ax.axvline(d.time, color="g", ls=":", lw=0.8)
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("time [s]")
        ax.set_xlim(100, 400)
    axes[0].set_ylabel("|pointing error| [deg]")
    axes[0].legend(loc="lower right")
    faults = ", ".join(f"{f.kind}={f.value:g} on {WHEELS.names[f.wheel]} at {f.onset:g} s" for f in scenario.faults)
    fig.suptitle(f"{scenario.name}: {faults}; red: onsets, green: reconfigurations", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
