"""What several `rw-fdi` commands share, each defined once: the range-checked number types, seed ranges, the
output check, the executor, the options given as argparse parents, and the fault-free samples they learn from."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path


def number(kind=float, low=None, high=None, low_open=False):
    """An argparse type: ``kind`` (int or float), finite, within [low, high] (``low_open``: > low).
    argparse turns its ValueError into one line naming the option, before anything starts."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}")
        if kind is float and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        below = low is not None and (value <= low if low_open else value < low)
        if below or (high is not None and value > high):
            bounds = ([f"{'>' if low_open else '>='} {low}"] if low is not None else []) + \
                ([f"<= {high}"] if high is not None else [])
            raise argparse.ArgumentTypeError(f"{text} is out of range: must be {' and '.join(bounds)}")
        return value
    parse.__name__ = kind.__name__   # argparse names the type in its message
    return parse


COUNT = number(int, 1)            # runs, jobs, epochs: at least one
SEED_MAX = 2**63 - 1              # numpy's seeds: non-negative (core/mission/scenario.SEED_MAX)
SEED = number(int, 0, SEED_MAX)
SEEDS_MAX = 1_000_000             # runs of one seed range: days on one machine already
RUNS = number(int, 1, SEEDS_MAX)


def parse_seeds(text: str, option: str) -> range:
    """'A..B' (inclusive) or 'A' -> range; a one-line ValueError naming the option otherwise."""
    first, sep, last = text.partition("..")
    try:
        a, b = int(first), int(last if sep else first)
    except ValueError:
        raise ValueError(f"{option} must be A..B or A with whole numbers, got {text!r}") from None
    if b < a:
        raise ValueError(f"{option} {text}: the last seed is below the first")
    if a < 0 or b > SEED_MAX:
        raise ValueError(f"{option} {text}: seeds are whole numbers in [0, {SEED_MAX}]")
    if b - a + 1 > SEEDS_MAX:
        raise ValueError(f"{option} {text}: {b - a + 1:,} runs; one command takes at most {SEEDS_MAX:,} (split the "
                         "range)")
    return range(a, b + 1)


def writable_dir(path: str, option: str) -> Path:
    """``path`` made (with its parents) and writable, or a one-line ValueError naming the option: an
    output that cannot be written fails before any node starts, not inside the recorder."""
    import os
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot create it ({exc.strerror or exc})") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {path}: not writable")
    return folder


def writable_file(path: str, option: str) -> Path:
    """``path`` as a file a command will write at its end, checked now: its folder made and writable, and not
    a directory itself (a one-line ValueError naming the option, before any run is spent)."""
    file = Path(path)
    if file.is_dir():
        raise ValueError(f"{option} {path}: a directory; give a file name")
    writable_dir(str(file.parent), option)
    return file


def executor(args):
    """Where a command's runs go: --jobs processes here, or the Dask cluster of --scheduler."""
    from ..tools.campaigns.campaign import make_executor
    out = make_executor(getattr(args, "jobs", None), getattr(args, "scheduler", None))
    if getattr(out, "asked", None) and out.asked > out.jobs:
        print(f"--jobs {out.asked}: this machine has {out.jobs} cores, {out.jobs} jobs at once (a cluster: "
              "--scheduler)", file=sys.stderr)
    return out


def dumps(value) -> str:
    """``value`` as JSON for --json: numpy numbers and arrays as plain ones, paths as text."""
    import json
    return json.dumps(value, indent=1, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))


def fdi_config(args):
    """The FdiConfig of a command's FDI options (those it takes; the others at their defaults): one line
    for a value out of range, before anything starts."""
    from ..fdi_config import FdiConfig
    return FdiConfig(method=getattr(args, "fdi_method", None) or "speed_aware", models=getattr(args, "models", None),
                     thresholds=getattr(args, "thresholds", None), persistence=getattr(args, "persistence", None),
                     unit_calibration=float(getattr(args, "unit_calibration", 0.0) or 0.0),
                     fdir=getattr(args, "fdir", True), decision=getattr(args, "decision", None),
                     plugins=tuple(getattr(args, "plugins", None) or ()))


def parents() -> dict:
    """The options several commands share, each defined once as an argparse parent, by name: a command
    lists the names it takes (its PARENTS)."""
    from ..core.fdi.detection import FALSE_ALARM_RATE, METHODS, PERSISTENCE_MAX
    models = argparse.ArgumentParser(add_help=False)
    models.add_argument("--models", default=None, help="Elman model directory (default: config/fdi)")
    persistence = argparse.ArgumentParser(add_help=False)
    persistence.add_argument("--persistence", type=number(int, 1, PERSISTENCE_MAX), default=None,
                             help="samples above the threshold before an alarm (P; default: the threshold file's; "
                                  "fit-thresholds fits for 3 speed_aware, 5 thesis and writes it in the file)")
    fdi_files = argparse.ArgumentParser(add_help=False, parents=[models, persistence])
    fdi_files.add_argument("--thresholds", default=None, help="threshold directory (default: config/fdi)")
    false_alarms = argparse.ArgumentParser(add_help=False)
    false_alarms.add_argument("--false-alarm-rate", type=number(float, 0, 1, low_open=True),
                              default=FALSE_ALARM_RATE,
                              help="designed per-run false-alarm probability (speed_aware; default %(default)g)")
    unit = argparse.ArgumentParser(add_help=False)
    unit.add_argument("--unit-calibration", type=number(float, 0), default=0.0, metavar="SECONDS",
                      help="the observers learn each wheel's own unit from the first SECONDS of a run, assumed "
                           "healthy (core/fdi/calibration.py; speed_aware only; default 0: the datasheet wheel; "
                           "shipped thresholds for 150)")
    method = argparse.ArgumentParser(add_help=False)
    method.add_argument("--fdi-method", default="speed_aware", choices=list(METHODS),
                        help="speed_aware (ours: wheel speed, signed residual, designed false-alarm rate) or "
                             "thesis (2-input Elman, |r - r^|, mean + 3 sigma curves); without --models it "
                             "picks config/fdi or config/fdi/thesis")
    decision = argparse.ArgumentParser(add_help=False)
    decision.add_argument("--decision", default=None, metavar="OBSERVER|KofN",
                          help="what makes /diagnostics (and FDIR's verdict in the graph): one observer of the "
                               "method (model, linear, elman) or a vote, e.g. 2of3: a wheel at least two alarm "
                               "(default: the method's, model speed-aware; docs/fdi.md 'The decision')")
    observers = argparse.ArgumentParser(add_help=False)
    observers.add_argument("--observer", dest="plugins", action="append", default=None, metavar="SPEC",
                           help="a user's observer beside ours (repeatable): an entry point of rw_fdi_ros.observers, "
                                "module:Class or file.py:Class; its state and bands in the --thresholds directory "
                                "(docs/observers.md)")
    jobs = argparse.ArgumentParser(add_help=False)
    jobs.add_argument("--jobs", type=COUNT, default=None, help="graphs at once (default: 2 on 2 cores)")
    cluster = argparse.ArgumentParser(add_help=False, parents=[jobs])
    cluster.add_argument("--scheduler", default=None, help="dask.distributed scheduler address: run on that cluster")
    vehicle = argparse.ArgumentParser(add_help=False)
    vehicle.add_argument("--vehicle", default=None, metavar="NAME|DIR|FILE",
                         help="the vehicle the scenarios fly (those that name none; default: the thesis' MakSat): a "
                              "shipped name, your vehicle's FDI directory (`rw-fdi defaults --vehicle FILE --out "
                              "DIR`, whose FDI then judges) or a vehicle file (with --models DIR); without "
                              "--scenario, a 400-s fault-free run of it")
    return dict(models=models, persistence=persistence, fdi_files=fdi_files, false_alarms=false_alarms, unit=unit,
                method=method, decision=decision, observers=observers, jobs=jobs, cluster=cluster, vehicle=vehicle)


def flown_scenarios(args, scenarios: list) -> list:
    """The scenario references a command runs, flown by --vehicle (:func:`parents`): each scenario (name or
    file) rewritten into a file of this process naming the vehicle; a scenario naming another vehicle is
    refused in one line. A vehicle's FDI directory becomes --models where no FDI files are given.

    Parameters
    ----------
    args : argparse.Namespace
        The command's options (``vehicle``; ``models`` and ``thresholds`` where it takes them).
    scenarios : list of str or None
        Scenario names or files; None or empty with --vehicle: a 400-s fault-free run of it.

    Returns
    -------
    list of str
        The references to run (``scenarios`` as given without --vehicle).
    """
    if getattr(args, "vehicle", None) is None:
        if not scenarios:
            raise ValueError("give --scenario (or --vehicle: a fault-free run of it)")
        return list(scenarios)
    import atexit
    import shutil
    import tempfile
    import yaml
    from ..core.mission.scenario import load_scenario, scenario_dir
    from ..core.mission.vehicle import VEHICLE_FILE, load_vehicle, shipped_vehicles
    from ..core.mission.yaml_text import read_yaml_file
    vehicle = load_vehicle(args.vehicle)   # one line naming the field, before any run
    source = args.vehicle if args.vehicle in shipped_vehicles() else str(Path(args.vehicle).resolve())
    if Path(source).is_dir() and not (getattr(args, "models", None) or getattr(args, "thresholds", None)):
        args.models = source   # the vehicle with its FDI (VEHICLE_FILE beside its networks and bands)
    source = str(Path(source) / VEHICLE_FILE) if Path(source).is_dir() else source
    folder = Path(tempfile.mkdtemp(prefix="rw_fdi_flown_"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    out = []
    for ref in scenarios or [None]:
        if ref is None:
            raw = {"name": f"{vehicle.name}_fault_free", "duration": 400.0, "faults": []}
        else:
            path = Path(ref) if Path(ref).is_file() else scenario_dir() / f"{ref}.yaml"
            raw = read_yaml_file(path) if path.is_file() else None
            if not isinstance(raw, dict) or raw.get("vehicle") is not None:
                own = load_scenario(ref).vehicle   # not a scenario: its one line; or one naming its vehicle
                if own != vehicle:
                    raise ValueError(f"--vehicle {args.vehicle}: scenario {ref} flies vehicle {own.name}; give a "
                                     "scenario that names none")
            raw = dict(raw)
        raw["vehicle"] = source
        flown = folder / f"{len(out)}.yaml"   # not the scenario's name: it is checked only when parsed
        flown.write_text(yaml.safe_dump(raw, sort_keys=False))
        try:   # what the vehicle cannot fly (a wheel it has not, a fault size out of its range), one line
            load_scenario(str(flown))
        except ValueError as exc:
            raise ValueError(f"--vehicle {args.vehicle}: {str(exc).replace(str(flown), ref or 'its fault-free run')}"
                             ) from None
        out.append(str(flown))
    return out


def fault_free_samples(bags, load_samples, executor=None) -> list:
    """FDI samples of the fault-free bags under ``bags`` recorded under one plant (what trains and fits), read
    on ``executor`` (default: here): each bag skipped said by name, their count, and an error where none is left."""
    from ..tools.design.offline import under_one_plant
    skipped = []
    samples = under_one_plant(load_samples(bags, on_skip=skipped.append, fault_free=True, executor=executor),
                              skipped.append)
    for reason in skipped:
        print(f"skipped: {reason}", file=sys.stderr)
    if skipped:
        print(f"skipped {len(skipped)} of {len(skipped) + len(samples)} bags", file=sys.stderr)
    if not samples:
        raise ValueError(f"--bags {bags}: no fault-free bag to learn from")
    return samples
