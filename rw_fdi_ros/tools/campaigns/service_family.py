"""The in-service family of ``rw-fdi bench service`` (its docstring says what a run holds): each run drawn
from its seed (:func:`draw`), made a Scenario (:func:`scenario`), flown by the family's onboard FDIR
(:func:`fdir_for`) in batches the core loop can step together (:func:`batches`). The service bench judges these
runs; the service observers' training (tools/design/service_training.py) learns from them."""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import yaml

from ...fdi_config import FdiConfig
from ...core.flight import Fdir
from ...core.mission.plant_choices import FDI_PERIOD
from ...core.mission.scenario import Scenario, parse_scenario
from ...core.mission.vehicle import DEFAULT_VEHICLE, load_vehicle

FAULT_FREE_S = 600.0
CALIBRATION_S = 150.0    # [s] the shipped unit_calibrated bands
DURATIONS = ((600.0, 0.7), (1800.0, 0.15), (7200.0, 0.12), (21600.0, 0.03))   # [s], share of runs
FAULT_KINDS = ("current_limiter", "temperature", "bus_voltage")   # the kinds drawn, in the draw's order
BATCH = 25


@dataclass(frozen=True)
class Draw:
    """What one in-service run is, before it is a Scenario (the report lists these)."""

    seed: int
    duration: float
    units: bool
    orbit: bool
    interval_s: tuple
    size_deg: float
    faults: tuple    # ({kind, wheel, onset, value, ramp}, ...)
    fault_free: bool = False   # drawn as one of the fault-free 600-s runs (draw(fault_free=True))
    give_up: bool = False      # run with FDIR made to give up every wheel it confirms (fdir_for)
    vehicle: str = DEFAULT_VEHICLE   # the spacecraft (a shipped name): its wheel set, fault sizes, slews, FDI


@lru_cache(maxsize=None)
def _vehicle(name: str):
    """The vehicle of a draw (a shipped name), and what the family draws from it: its wheel set, the in-service
    fault sizes and the largest set-point change [deg] (MakSat: Table 2.3's 5 deg, the four-wheel set)."""
    vehicle = load_vehicle(name)
    return vehicle, vehicle.wheel_set, vehicle.dispersions.fault_ranges, max(
        abs(v) for v in vehicle.dispersions.setpoint_change_deg)


def draw(seed: int, max_duration: float | None = None, fault_free: bool = False,
         vehicle: str = DEFAULT_VEHICLE) -> Draw:
    """The in-service run of ``seed`` (module docstring); ``max_duration`` [s] shortens the longer ones (the
    rest of the draw unchanged); ``fault_free``: a 600-s run of the family without a fault (the false
    reconfiguration figure needs a thousand of them); ``vehicle``: the spacecraft's name (its wheels, sizes)."""
    _, wheels, ranges, largest = _vehicle(vehicle)
    rng = np.random.default_rng([int(seed), 34])
    durations, shares = zip(*DURATIONS)
    duration = float(rng.choice(durations, p=shares))
    if fault_free:
        duration = FAULT_FREE_S
    if max_duration is not None:
        duration = min(duration, float(max_duration))
    units = bool(rng.random() < 0.5)
    orbit = bool(rng.random() < 0.2)
    low = float(rng.uniform(60.0, 300.0))
    interval = (round(low, 1), round(float(min(900.0, low + rng.uniform(0.0, 600.0))), 1))
    size = round(float(rng.uniform(min(1.0, largest), largest)), 2)
    faults = []
    if rng.random() < 2.0 / 3.0 and not fault_free:
        earliest = CALIBRATION_S + 5.0 if units else 20.0
        if units and rng.random() < 0.15:   # right after the calibration
            onset = rng.uniform(earliest, earliest + 20.0)
        else:
            onset = rng.uniform(earliest, duration - 240.0)
        wheel = str(rng.choice(wheels.active))
        faults.append(_fault(rng, wheel, onset, ranges))
        if rng.random() < 0.2 and onset + 100.0 < duration - 240.0:
            others = [w for w in wheels.names if w != wheel]
            second = rng.uniform(onset + 100.0, min(onset + 600.0, duration - 240.0))
            faults.append(_fault(rng, str(rng.choice(others)), second, ranges))
    return Draw(int(seed), duration, units, orbit, interval, size, tuple(faults), bool(fault_free), vehicle=vehicle)


def _fault(rng, wheel: str, onset: float, ranges: dict) -> dict:
    kind = str(rng.choice(FAULT_KINDS))
    value = round(float(rng.uniform(*ranges[kind])), 4)
    ramp = 0.0 if rng.random() < 0.5 else round(float(rng.uniform(50.0, 300.0)), 1)
    return {"kind": kind, "wheel": wheel, "onset": round(float(onset), 1), "value": value, "ramp": ramp}


def scenario(d: Draw) -> Scenario:
    """The Scenario of a draw, through the scenario file's own checks (and its text, as a bag records it)."""
    raw = {"name": "service", "duration": d.duration, "seed": d.seed,
           "description": "in service: every capability at once (rw-fdi bench service)",
           **({"plant": {"wheel_set": _vehicle(d.vehicle)[1].name}} if d.vehicle == DEFAULT_VEHICLE
              else {"vehicle": d.vehicle}),
           "manoeuvres": {"interval_s": list(d.interval_s), "size_deg": [-d.size_deg, d.size_deg]},
           "faults": [dict(f) for f in d.faults]}
    if d.units:
        raw["wheels"] = {"variation": True}
    if d.orbit:
        raw["environment"] = {"epoch": "2026-01-01T00:00:00"}
        raw["magnetorquers"] = {}
    return parse_scenario(yaml.safe_dump(raw, sort_keys=False), origin=f"service seed {d.seed}")


def fdir_for(units: bool, give_up: bool = False, vehicle: str = DEFAULT_VEHICLE, watch: FdiConfig | None = None,
             fdi: FdiConfig | None = None) -> Fdir:
    """The onboard FDIR of the family: ``fdi`` (default: the shipped FDI of ``vehicle``), calibrated to the units
    where they vary; ``give_up``: made to give up every wheel it confirms (no holding, no keeping), for the
    identification of a wheel whose driver goes off at its decision. ``watch``: every observer of that FDI
    configuration (ours, and its plug-ins) judged beside, acted on by nothing (pipeline.FdiPipeline)."""
    from dataclasses import replace
    calibration = CALIBRATION_S if units else 0.0
    loaded = replace(fdi or FdiConfig(), unit_calibration=calibration).for_vehicle(vehicle).loaded(FDI_PERIOD)
    policy = {"holdable": float("inf"), "slew_rate": 0.0} if give_up else {}
    watched = None
    if watch is not None and not give_up:
        watched = replace(watch, unit_calibration=calibration).for_vehicle(vehicle).loaded(FDI_PERIOD)
    return Fdir(loaded, identification=True, watch=watched, **policy)


def batches(draws: list, size: int = BATCH) -> list:
    """Draws grouped by what a batch must share (duration, units, orbit), longest first, in batches."""
    groups = defaultdict(list)
    for d in draws:
        groups[(d.duration, d.units, d.orbit, d.give_up, d.vehicle)].append(d)
    out = []
    for key in sorted(groups, key=lambda k: -k[0]):   # longest first: the pool's tail is short runs
        members = groups[key]
        out += [members[i:i + size] for i in range(0, len(members), size)]
    return out
