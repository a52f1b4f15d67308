"""Everything the FDI needs for one vehicle, from nothing (`rw-fdi defaults --vehicle FILE --out DIR`).

On the core loop (rw-fdi screen's: the graph's numbers, no bags), the speed-aware method:

1. the controllers designed to the vehicle's targets (core/controller_design.py; the runs fly them);
2. fault-free runs of the vehicle: fitting (seeds 1040-1139), held-out (5000-5099); for the network, fault-free
   600-s runs of its datasheet wheels as in service (the in-service family's draws,
   tools/benches/service_bench.py: manoeuvres every 60-900 s, a share in orbit with dumps through zero; seeds
   61,000,000-61,000,039); for the calibrated bands, such runs of drawn wheel units (seeds
   60,000,000-60,000,299) and their held-out runs (5,200-5,299): training, fitting and checking never
   share a run;
3. one speed-aware Elman network of the wheel type, a grey box that learns the nominal model's error
   r - r_model on every wheel's healthy stretches (tools/design/service_training.py), each wheel's uncertainty
   gain from its own: the nominal model carries the vehicle's physics to speeds and manoeuvres the network
   never saw, where a network of r itself alarmed in every run from 0 or 40 rad/s (docs/fdi.md);
4. the three observers' bands for the designed per-run false-alarm rate, for datasheet wheels and for
   observers that learn their wheel over the first 150 s (``unit_calibrated/``);
5. the held-out runs judged by the FDI just made: their false alarms, with 95 % intervals;
6. runs with 10 % current losses and +30 C (seeds 5400+) judged by each observer on its own: one that misses
   is named with the measured cause and a figure of its worst miss (tools/design/observer_check.py).

The directory holds the vehicle, its fault-free scenarios, the networks, both band sets and a report
(defaults.json, defaults_report.md), laid out as config/fdi is: ``--models DIR`` gives every command it.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import yaml

from ...core.controller_design import design_controller
from ...core.fdi.detection import FALSE_ALARM_RATE, PERSISTENCE_SPEED_AWARE
from ...core.mission.vehicle import load_vehicle, to_mapping
from ...scoring.metrics import wilson
from .observer_check import GOAL, check_observers
from .offline import alarmed_runs, fit_thresholds, load_models, observe, threshold_set
from .samples import simulated_fault_free_runs
from .service_training import family_plant, family_runs, train_type_network
from .train import EPOCHS

TRAIN_SEED, HELDOUT_SEED = 1000, 5000           # fitting runs from TRAIN_SEED + train_runs; held-out runs
NETWORK_SEED = 61_000_000                       # the network's in-service training runs (datasheet wheels)
UNITS_SEED, UNITS_HELDOUT_SEED = 60_000_000, 5200   # drawn wheel units: fitting; held-out
FAULT_SEED = 5400                               # runs with a fault each observer must see
UNIT_CALIBRATION = 150.0                        # [s] the calibrated observers' learning window (config/fdi's)
DURATION = 400.0                                # [s] the fault-free runs (the thesis' operation)


def _log(msg):
    print(msg, file=sys.stderr, flush=True)


def vehicle_scenarios(vehicle_file: Path, out: Path) -> dict:
    """kind -> path of the vehicle's fault-free scenarios written under ``out/scenarios`` (datasheet wheels;
    drawn units), each naming the vehicle file copied to ``out/vehicle.yaml``."""
    folder = out / "scenarios"
    folder.mkdir(parents=True, exist_ok=True)
    bodies = {"fault_free": "", "fault_free_units": "wheels: {variation: true}\n"}
    paths = {}
    for kind, body in bodies.items():
        path = folder / f"{kind}.yaml"
        path.write_text(f"name: {kind}\ndescription: fault-free runs of {vehicle_file.name}, initial conditions and "
                        f"set-point change drawn from its dispersions\nvehicle: ../{vehicle_file.name}\n"
                        f"duration: {DURATION:g}\nseed: 1\n{body}faults: []\n")
        paths[kind] = path
    return paths


def service_unit_runs(vehicle_file: Path, seeds, executor=None, desc: str = "unit runs") -> tuple:
    """(FdiSamples, plant choices) of the in-service family's fault-free 600-s draws of ``seeds`` on drawn wheel
    units of the vehicle (tools/campaigns/service_family.draw: manoeuvres every 60-900 s, a share in orbit with
    dumping), flown without FDIR. A calibrated observer learns its unit at the speed it holds then; it is in
    service, after slews to other speeds and through dumps, that what it could not learn shows (viscous against
    coulomb friction), so its bands are fitted there, not on one-slew runs."""
    runs = family_runs(seeds, "units", True, executor, desc, vehicle=Path(vehicle_file).resolve(), act=False)
    return [s for _, s in runs], family_plant(runs[0][0])


def held_out_alarms(samples, models, thresholds_dir, calibration: float = 0.0) -> dict:
    """observer -> (runs with any alarm, runs) of fault-free ``samples`` under the bands in ``thresholds_dir``."""
    from ...core.fdi.calibration import calibration_samples
    runs = [observe(s, models, calibration_samples=calibration_samples(calibration)) for s in samples]
    return {obs: (k, len(runs)) for obs, k in alarmed_runs(runs, threshold_set(thresholds_dir, "speed_aware")).items()}


def vehicle_defaults(vehicle_source, out, train_runs: int = 40, fit_runs: int = 100, heldout_runs: int = 100,
                     unit_runs: int = 300, unit_heldout_runs: int = 100, epochs: int = EPOCHS, executor=None,
                     false_alarm_rate: float = FALSE_ALARM_RATE, fault_runs: int = 40) -> dict:
    """Make the FDI of the vehicle ``vehicle_source`` (a shipped name or a vehicle file) in ``out``; returns the
    report (also written as out/defaults.json and out/defaults_report.md)."""
    t0 = time.monotonic()
    vehicle = load_vehicle(vehicle_source)   # one line naming the field, before any run
    stages = {}
    _log(f"[1/6] controllers designed to {vehicle.name}'s targets")
    design = design_controller(vehicle)   # a vehicle that cannot meet its targets is refused before out is written
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    vehicle_file = out / "vehicle.yaml"
    vehicle_file.write_text(yaml.safe_dump(to_mapping(vehicle), sort_keys=False))
    controller = {"kp": list(map(float, design.gains.kp)), "ki": list(map(float, design.gains.ki)),
                  "kd": list(map(float, design.gains.kd)), "natural_frequency": list(design.natural_frequency),
                  "settling_time": list(design.settling_time), "overshoot": list(design.overshoot)}
    stages["controller_s"] = time.monotonic() - t0

    t = time.monotonic()
    scenarios = vehicle_scenarios(vehicle_file, out)
    _log(f"[2/6] fault-free runs of {vehicle.name} on the core loop")
    fit, plant = simulated_fault_free_runs(scenarios["fault_free"], range(TRAIN_SEED + train_runs,
                                                                         TRAIN_SEED + train_runs + fit_runs),
                                           executor, desc="fitting runs")
    network_runs = family_runs(range(NETWORK_SEED, NETWORK_SEED + train_runs), "datasheet", True, executor,
                               "in-service training runs (datasheet wheels)", vehicle=vehicle_file.resolve(),
                               act=False)
    heldout, _ = simulated_fault_free_runs(scenarios["fault_free"], range(HELDOUT_SEED, HELDOUT_SEED + heldout_runs),
                                           executor, desc="held-out runs")
    units, units_plant = service_unit_runs(vehicle_file, range(UNITS_SEED, UNITS_SEED + unit_runs), executor,
                                           "in-service unit runs (calibrated bands)")
    units_heldout, _ = service_unit_runs(vehicle_file, range(UNITS_HELDOUT_SEED,
                                                             UNITS_HELDOUT_SEED + unit_heldout_runs),
                                         executor, "held-out in-service unit runs")
    stages["runs_s"] = time.monotonic() - t

    t = time.monotonic()
    _log(f"[3/6] the wheel type's Elman network (the nominal model's error), {epochs} epochs on {train_runs} runs")
    card = train_type_network(network_runs, out, tuple(fit[0].wheels), epochs, units="datasheet",
                              false_alarm_rate=false_alarm_rate)
    stages["training_s"] = time.monotonic() - t

    t = time.monotonic()
    _log(f"[4/6] bands for a per-run false-alarm rate of {false_alarm_rate:g}: datasheet wheels, and observers "
         f"that learn their wheel over {UNIT_CALIBRATION:g} s")
    models = load_models(out)
    bands = fit_thresholds(fit, models, out, model_ref="model_set.json", false_alarm_rate=false_alarm_rate,
                           persistence=PERSISTENCE_SPEED_AWARE, plant=plant)
    unit_bands = fit_thresholds(units, models, out / "unit_calibrated", model_ref="../model_set.json",
                                false_alarm_rate=false_alarm_rate, persistence=PERSISTENCE_SPEED_AWARE,
                                unit_calibration=UNIT_CALIBRATION, plant=units_plant)
    stages["fitting_s"] = time.monotonic() - t

    t = time.monotonic()
    _log(f"[5/6] held-out runs judged: {heldout_runs} with datasheet wheels, {unit_heldout_runs} of drawn units")
    checks = {"datasheet": held_out_alarms(heldout, models, out),
              "unit_calibrated": held_out_alarms(units_heldout, models, out / "unit_calibrated", UNIT_CALIBRATION)}
    stages["held_out_s"] = time.monotonic() - t

    t = time.monotonic()
    _log(f"[6/6] each observer on its own: {fault_runs} runs of a 10 % current loss and {fault_runs} of +30 C")
    caught = check_observers(scenarios["fault_free"], vehicle.wheel, models, threshold_set(out, "speed_aware"),
                             range(FAULT_SEED, FAULT_SEED + fault_runs), out)
    stages["faults_s"] = time.monotonic() - t
    stages["total_s"] = time.monotonic() - t0

    report = {"command": f"rw-fdi defaults --vehicle {vehicle_source} --out {out}", "vehicle": vehicle.name,
              "wheel_set": plant["wheel_set"], "controller": controller, "plant": plant,
              "seeds": {"training": [NETWORK_SEED, NETWORK_SEED + train_runs - 1],
                        "fitting": [TRAIN_SEED + train_runs, TRAIN_SEED + train_runs + fit_runs - 1],
                        "held_out": [HELDOUT_SEED, HELDOUT_SEED + heldout_runs - 1],
                        "unit_fitting": [UNITS_SEED, UNITS_SEED + unit_runs - 1],
                        "unit_held_out": [UNITS_HELDOUT_SEED, UNITS_HELDOUT_SEED + unit_heldout_runs - 1],
                        "faults": [FAULT_SEED, FAULT_SEED + fault_runs - 1]},
              "networks": {"wheels": card["wheels"], "epochs": epochs, "learns": card["learns"],
                           "speeds_learnt": card["speeds_learnt"],
                           "final_loss": card["final_loss"], "windows": card["windows"],
                           "uncertainty_gain": {a: c["uncertainty_gain"] for a, c in card["axes"].items()}},
              "bands": {"datasheet": bands, "unit_calibrated": unit_bands,
                        "false_alarm_rate_design": false_alarm_rate, "persistence": PERSISTENCE_SPEED_AWARE,
                        "unit_calibration_s": UNIT_CALIBRATION},
              "held_out_false_alarms": {kind: {obs: {"alarmed": k, "runs": n, "ci95": list(wilson(k, n))}
                                               for obs, (k, n) in rows.items()} for kind, rows in checks.items()},
              "faults_caught": caught, "stages": stages}
    (out / "defaults.json").write_text(json.dumps(report, indent=2))
    (out / "defaults_report.md").write_text(format_report(report))
    _log(f"wrote {out} in {stages['total_s'] / 60:.1f} min")
    return report


def short_of_goal(caught: dict) -> list:
    """One line per case with runs the physics hides (observer_check.invisible_why), and one per observer that
    missed observable faults it must see, with the cause (observer_check.why_missed)."""
    lines = []
    for case, rows in caught.items():
        hidden = next(iter(rows.values()))["invisible"]   # the same runs for every observer
        if hidden["runs"]:
            lines.append(f"{case}: {hidden['runs']} of {hidden['of']} runs not judged: {hidden['why']}")
        for obs, x in rows.items():
            if "why" in x:
                verdict = "below" if x["ci95"][1] < GOAL else "short of"
                lines.append(f"{obs} observer: {case} right in {x['right']} of {x['runs']} runs, {verdict} "
                             f"{GOAL * 100:g} %: {x['why']} (figure {x['worst_miss']['figure']})")
    return lines


def format_report(r: dict) -> str:
    """The report as Markdown: what was made, on which seeds, and the held-out check."""
    c, s, b = r["controller"], r["seeds"], r["bands"]
    wheels = list(next(iter(b["datasheet"].values())))
    def seeds(key):
        return f"{s[key][0]}-{s[key][1]}"
    lines = [f"# FDI of vehicle {r['vehicle']}", "",
             f"Made from nothing by `{r['command']}` on the core loop (the graph's numbers). Wheel set "
             f"{r['wheel_set']}; fault-free runs of {DURATION:g} s drawn from the vehicle's dispersions. Seeds: "
             f"fitting {seeds('fitting')}, held-out {seeds('held_out')}; the network's fault-free 600-s in-service "
             f"runs {seeds('training')}. The calibrated "
             f"bands: fault-free 600-s runs of drawn units as in service (manoeuvres every 60-900 s, a share in "
             f"orbit), seeds {seeds('unit_fitting')}, held-out {seeds('unit_held_out')}.", "",
             "## Controllers (designed to the vehicle's targets)", "",
             "| axis | k_p | k_i | k_d | w_n [rad/s] | settling [s] | overshoot |", "|---|---|---|---|---|---|---|"]
    for i, axis in enumerate("xyz"):
        lines.append(f"| {axis} | {c['kp'][i]:.4g} | {c['ki'][i]:.4g} | {c['kd'][i]:.4g} | "
                     f"{c['natural_frequency'][i]:g} | {c['settling_time'][i]:.0f} | {c['overshoot'][i] * 100:.0f} % |")
    n = r["networks"]
    lines += ["", f"## Elman network (speed-aware, {n['epochs']} epochs, one of the wheel type: it learns "
              f"{n['learns']}; final training MSE {n['final_loss']:.2e})", "",
              "| wheel | healthy 300-s training windows | uncertainty gain kappa |", "|---|---|---|"]
    lines += [f"| {a} | {n['windows'].get(a, 0)} | {n['uncertainty_gain'][a]:.3f} |" for a in n["wheels"]]
    if n["speeds_learnt"] is not None:
        lines += ["", "Speeds it learnt [rad/s] (beyond them its estimate is the nominal model's): "
                  + ", ".join(f"{lo:g} to {hi:g}" for lo, hi in n["speeds_learnt"]) + "."]
    lines += ["", f"## Bands (per-run false-alarm rate {b['false_alarm_rate_design']:g}, P = {b['persistence']})", "",
              "| set | observer | " + " | ".join(f"c {a} [1e-3 N m]" for a in wheels) + " |",
              "|---|---|" + "---|" * len(wheels)]
    for kind in ("datasheet", "unit_calibrated"):
        for obs, row in b[kind].items():
            lines.append(f"| {kind} | {obs} | " + " | ".join(f"{row[a] * 1e3:.4g}" for a in wheels) + " |")
    lines += ["", "## Held-out fault-free runs with any alarm (95 % Wilson interval)", "",
              "| set | observer | alarmed | runs | rate | 95 % interval |", "|---|---|---|---|---|---|"]
    for kind, rows in r["held_out_false_alarms"].items():
        for obs, x in rows.items():
            lo, hi = x["ci95"]
            lines.append(f"| {kind} | {obs} | {x['alarmed']} | {x['runs']} | {x['alarmed'] / x['runs'] * 100:.1f} % "
                         f"| [{lo * 100:.1f}, {hi * 100:.1f}] % |")
    if "faults_caught" in r:
        f = r["faults_caught"]
        lines += ["", f"## Each observer on its own: faults it must see (seeds {seeds('faults')}, datasheet wheels, "
                  f"manoeuvres every 100-300 s, onset at 60-300 s)", "",
                  "| case | observer | right | observable runs | rate | 95 % interval | physically invisible |",
                  "|---|---|---|---|---|---|---|"]
        for case, rows in f.items():
            for obs, x in rows.items():
                lo, hi = x["ci95"]
                judged = (f"{x['right'] / x['runs'] * 100:.1f} % | [{lo * 100:.1f}, {hi * 100:.1f}] %" if x["runs"]
                          else "- | -")
                lines.append(f"| {case} | {obs} | {x['right']} | {x['runs']} | {judged} | {x['invisible']['runs']} |")
        short = short_of_goal(f)
        lines += [""] + ([f"- {line}" for line in short] if short else
                         [f"Every observer caught every fault here (the goal: >= {GOAL * 100:g} % each)."])
        lines += [f"\n![{obs}, {case}: its worst miss](observer_misses/{Path(x['worst_miss']['figure']).name})"
                  for case, rows in f.items() for obs, x in rows.items() if "why" in x]
        lines += ["", "A small sample: the figures of record are `rw-fdi bench operations --vehicle DIR`'s."]
    lines += ["", "Stage times [s]: " + ", ".join(f"{k} {v:.0f}" for k, v in r["stages"].items()), ""]
    return "\n".join(lines)
