"""`rw-fdi bench X`: the benchmarks that print figures, one sub-command per bench, each given only the options
it reads (another is an argparse error, not a flag silently ignored)."""
import argparse
import json
import sys

from ..options import COUNT, SEED, executor, number

NAME = "bench"
HELP = "benchmarks that print figures"
PARENTS = ()


def _options() -> dict:
    """Every bench option, each defined once as an argparse parent, by flag: a bench is given the ones it reads."""
    made = {}

    def option(flag, **kwargs):
        made[flag] = argparse.ArgumentParser(add_help=False)
        made[flag].add_argument(flag, **kwargs)
    for group in (_service_options, _long_run_options, _sample_options, _fdi_options, _run_options):
        group(option)
    return made


def _service_options(option):
    """The in-service bench's: its runs, the wheel given up, re-identification, every observer."""
    option("--service-runs", type=COUNT, default=1000,
           help="service: in-service runs, each drawn from its seed (default 1000)")
    option("--given-up-runs", type=number(int, 0), default=300,
           help="service: seeds whose faulty draws run with FDIR giving up every wheel it confirms, for the "
                "identification of a wheel given up (default 300: about 200 runs; 0: none)")
    option("--reidentify", action="store_true",
           help="service: re-measure the identification of the report in --out after a change to the identifier "
                "(its runs with an identification and its given-up runs simulated again, each checked to act and "
                "point as recorded; every other run kept)")
    option("--max-hours", type=number(float, 0, 6, low_open=True), default=None,
           help="service: shorten the runs drawn longer than this to it [h] (default: none, up to 6 h); scaling: "
                "the same (default 0.25)")
    option("--every-observer", action="store_true",
           help="service: judge every observer (ours, and --observer's) beside the decision on the same runs, acted "
                "on by nothing: their false alarms, right wheel, held alarm and delay in service")


def _long_run_options(option):
    """The benches of long operations: scaling, dumping in orbit, memory, continuous operations."""
    option("--scaling-runs", type=COUNT, default=100,
           help="scaling: in-service runs timed on each worker count (default 100: enough that the family's "
                "batches fill about as in a campaign of thousands; a dozen runs are batches of one or two, 4x dearer "
                "a run)")
    option("--day-hours", type=number(float, 0, 240, low_open=True), default=24.0,
           help="dumping: the length of the day in orbit [h] (default 24)")
    option("--orbit-runs", type=COUNT, default=20,
           help="dumping: 6-hour runs of operations in orbit with dumping (default 20: 120 simulated hours)")
    option("--hours", default="1,6", help="memory: run lengths in hours, comma-separated (default 1,6)")
    option("--hours-runs", type=COUNT, default=50,
           help="operations: 2-hour runs of continuous operations (default 50: 100 simulated hours)")


def _sample_options(option):
    """The sample sizes of detection, identification and recovery."""
    option("--fault-free-runs", type=COUNT, default=1000,
           help="detection, units: fault-free runs; service: fault-free 600-s runs of the family (default 1000)")
    option("--runs-per-cell", type=COUNT, default=None,
           help="detection: runs per fault or ripple case (default 200); identification: per grid size "
                "(default 100); recovery: per fault case (default 100)")
    option("--units", action="store_true",
           help="identification: on varied wheels, calibrated 150 s, sizes drawn over ranges (default "
                "200 runs per kind, the bus 340; reports/identification_units)")
    option("--thesis-runs", type=COUNT, default=None,
           help="identification: runs per thesis size (default 200; the bus 340, as 6 in 10 are observable)")


def _fdi_options(option):
    """The vehicle flown and the FDI judging: shipped, or a user's observer with its bands."""
    option("--vehicle", default="maksat", metavar="NAME|DIR",
           help="detection, identification, units, operations, recovery, service, dumping: the vehicle the runs "
                "fly with its FDI: a shipped one's name (config/fdi/vehicles; default %(default)s, the thesis' "
                "spacecraft) or your own's FDI directory (`rw-fdi defaults --vehicle FILE --out DIR`; the reports go "
                "to DIR/reports)")
    option("--observer", dest="plugins", action="append", default=None, metavar="SPEC",
           help="detection, units, operations: a user's observer judged beside ours (repeatable; entry point, "
                "module:Class or file.py:Class; docs/observers.md), its bands and ours from --thresholds")
    option("--thresholds", default=None, metavar="DIR",
           help="detection, units, operations: the FDI directory `rw-fdi fit-thresholds --observer` wrote (with "
                "--observer; default: the shipped FDI)")


def _run_options(option):
    """Where the report goes, which seeds, where the runs run, and the benches' own few."""
    option("--out", default=None, help="detection / identification / units / memory: report directory "
                                       "(default reports/<what>)")
    option("--seed-set", default="evaluation", choices=["evaluation", "tuning"],
           help="operations, recovery, service: the seeds of record (default) or the ones the design "
                "was chosen on")
    option("--runs", type=COUNT, default=8, help="study: runs to record and replay")
    option("--jobs", type=COUNT, default=None,
           help="local processes (study: graphs) at a time (default: one per core, at most 2)")
    option("--scheduler", default=None,
           help="dask.distributed scheduler address: run the bench's runs on that cluster instead")
    option("--duration", type=number(float, 0, low_open=True), default=None,
           help="graph, study: the run's simulated seconds (default 400); fdi: the in-service run's (default 600)")
    option("--seed", type=SEED, default=1)
    option("--only", default=None,
           help="figures: the benches to re-measure, comma-separated (detection, operations, "
                "identification_units, recovery, service, service_observers, dumping, reproduce, graph, study, "
                "vehicle_detection, "
                "vehicle_recovery, vehicle_service, cubesat_detection, cubesat_recovery, cubesat_service; default "
                "all)")
    option("--json", action="store_true")


def _bench_fdi(args):
    """The FdiConfig a bench judges with where --observer or --thresholds says (else None: the shipped FDI);
    one line for a plug-in that cannot be loaded, before any run."""
    if not (args.plugins or args.thresholds):
        return None
    from ...fdi_config import FdiConfig
    fdi = FdiConfig(thresholds=args.thresholds, plugins=tuple(args.plugins or ()))
    fdi.load_plugins()
    return fdi


def _out(args, what: str) -> str:
    """--out, else the bench's report directory: a user's observers' under reports/observers/<slots>/."""
    if args.out:
        return args.out
    if getattr(args, "plugins", None):
        from ...fdi_config import FdiConfig
        return f"reports/observers/{'_'.join(FdiConfig(plugins=tuple(args.plugins)).plugin_slots)}/{what}"
    return _vehicle_out(args, what)


def _graph(args) -> dict:
    from ...tools.benches.speed_bench import bench_graph
    return bench_graph(duration=args.duration or 400.0, seed=args.seed)


def _fdi(args) -> dict:
    from ...tools.benches.speed_bench import bench_fdi
    return bench_fdi(duration=args.duration or 600.0, seed=args.seed)


def _study(args) -> dict:
    from ...tools.benches.speed_bench import bench_study
    return bench_study(runs=args.runs, duration=args.duration or 400.0, seed=args.seed, jobs=args.jobs)


def _detection(args) -> dict:
    from ...tools.benches.detection_bench import bench_detection
    return bench_detection(fault_free_runs=args.fault_free_runs, runs_per_cell=args.runs_per_cell or 200,
                           out=_out(args, "detection"), executor=executor(args),
                           vehicle=_checked_vehicle(args), fdi=_bench_fdi(args))


def _checked_vehicle(args) -> str:
    """--vehicle read (one line naming the field) before any run: a shipped vehicle's name, or the absolute path
    of a user's vehicle's FDI directory (its vehicle.yaml, networks and bands)."""
    from pathlib import Path
    from ...core.mission.vehicle import VEHICLE_FILE, load_vehicle, shipped_vehicles
    if args.vehicle in shipped_vehicles():
        return load_vehicle(args.vehicle).name
    folder = Path(args.vehicle)
    if not (folder / VEHICLE_FILE).is_file():
        raise ValueError(f"--vehicle {args.vehicle}: neither a shipped vehicle ({', '.join(shipped_vehicles())}) nor "
                         f"a vehicle's FDI directory (no {VEHICLE_FILE} in it); for your own vehicle file, make its "
                         "FDI with `rw-fdi defaults --vehicle FILE --out DIR`, then give --vehicle DIR")
    load_vehicle(folder)
    return str(folder.resolve())


def _vehicle_out(args, what: str) -> str:
    """A bench's default report directory: reports/<what>, reports/vehicles/<vehicle>/<what> on another shipped
    vehicle than the thesis', DIR/reports/<what> on a user's vehicle's FDI directory."""
    from pathlib import Path
    from ...core.mission.vehicle import DEFAULT_VEHICLE
    if Path(args.vehicle).is_dir():
        return str(Path(args.vehicle) / "reports" / what)
    return f"reports/{what}" if args.vehicle == DEFAULT_VEHICLE else f"reports/vehicles/{args.vehicle}/{what}"


def _identification(args) -> dict:
    from ...tools.benches.identification_bench import bench_identification
    default_out = _vehicle_out(args, "identification_units" if args.units else "identification")
    return bench_identification(runs_per_cell=args.runs_per_cell or (200 if args.units else 100),
                                out=args.out or default_out, units=args.units, executor=executor(args),
                                vehicle=_checked_vehicle(args),
                                **({"thesis_runs": args.thesis_runs, "bus_thesis_runs": args.thesis_runs * 17 // 10}
                                   if args.thesis_runs else {}))


def _units(args) -> dict:
    from ...tools.benches.units_bench import bench_units
    return bench_units(fault_free_runs=args.fault_free_runs, runs_per_cell=args.runs_per_cell or 200,
                       out=_out(args, "units"), executor=executor(args),
                       vehicle=_checked_vehicle(args), fdi=_bench_fdi(args))


def _memory(args) -> dict:
    from ...tools.benches.memory_bench import bench_memory
    try:
        hours = tuple(float(h) for h in args.hours.split(","))
    except ValueError:
        raise ValueError(f"--hours: expected numbers like 1,6, got {args.hours!r}") from None
    if not all(0 < h <= 48 for h in hours):
        raise ValueError(f"--hours: each length must be in (0, 48] hours, got {args.hours!r}")
    return bench_memory(hours, seed=args.seed, out=args.out or "reports/memory")


def _operations(args) -> dict:
    from ...tools.benches.operations_bench import bench_operations
    return bench_operations(fault_free_runs=args.fault_free_runs, runs_per_cell=args.runs_per_cell or 200,
                            hours_runs=args.hours_runs, seeds=args.seed_set,
                            out=_out(args, "operations"), executor=executor(args),
                            vehicle=_checked_vehicle(args), fdi=_bench_fdi(args))


def _recovery(args) -> dict:
    from tqdm import tqdm
    from ...tools.benches.recovery_bench import bench_recovery, cells_of
    vehicle = _checked_vehicle(args)
    runs = args.runs_per_cell or 100
    total = sum(args.fault_free_runs if c.kind is None else runs for _, c in cells_of(vehicle))
    with tqdm(total=total, desc="recovery bench (core loop)", unit="run", file=sys.stderr) as bar:
        return bench_recovery(runs_per_cell=runs, fault_free_runs=args.fault_free_runs, seeds=args.seed_set,
                              out=args.out or _vehicle_out(args, "recovery"), progress=bar.update,
                              executor=executor(args), vehicle=vehicle)


def _dumping(args) -> dict:
    from ...tools.benches.dumping_bench import bench_dumping
    return bench_dumping(hours=args.day_hours, seed=args.seed, operations_runs=args.orbit_runs,
                         runs_per_cell=args.runs_per_cell or 100, out=args.out or _vehicle_out(args, "dumping"),
                         executor=executor(args), vehicle=_checked_vehicle(args))


def _service(args) -> dict:
    from tqdm import tqdm
    from ...tools.benches.service_bench import GIVEN_UP_SEEDS, SEED_BASES, bench_service, given_up_draws
    from ...tools.campaigns.service_family import FAULT_FREE_S
    if args.reidentify:
        return _reidentify(args)
    if args.max_hours is not None and 3600.0 * args.max_hours < FAULT_FREE_S:   # the family's shortest runs
        raise ValueError(f"--max-hours: at least {FAULT_FREE_S / 3600.0:.3g} h, the family's shortest runs "
                         f"({FAULT_FREE_S:g} s); got {args.max_hours:g}")
    base = SEED_BASES[args.seed_set] + GIVEN_UP_SEEDS
    vehicle = _checked_vehicle(args)
    from ...fdi_config import FdiConfig
    watch = _bench_fdi(args) or (FdiConfig() if args.every_observer else None)
    if watch is not None:   # both calibrations' bands of every observer, before any run (the family flies both)
        from dataclasses import replace
        from ...tools.campaigns.service_family import CALIBRATION_S
        for seconds in (0.0, CALIBRATION_S):
            replace(watch, unit_calibration=seconds).for_vehicle(vehicle).load()
    given_up = len(given_up_draws(range(base, base + args.given_up_runs), vehicle))   # the faulty draws among them
    with tqdm(total=args.service_runs + args.fault_free_runs + given_up, desc="service bench (core loop)",
              unit="run", file=sys.stderr) as bar:
        return bench_service(runs=args.service_runs, seeds=args.seed_set,
                             out=_out(args, "service_observers" if args.every_observer else "service"),
                             executor=executor(args), progress=bar.update, max_hours=args.max_hours,
                             fault_free_runs=args.fault_free_runs, given_up_runs=args.given_up_runs,
                             vehicle=vehicle, watch=watch)


def _reidentify(args) -> dict:
    from tqdm import tqdm
    from ...tools.benches.service_bench import RecordMismatch, reidentify
    if args.every_observer or args.plugins or args.thresholds:
        raise SystemExit("rw-fdi bench service: --reidentify re-measures a report as it was run; give only --out "
                         "(and --jobs / --scheduler)")
    out = _out(args, "service")
    from pathlib import Path
    if not (Path(out) / "service.json").is_file():
        raise SystemExit(f"rw-fdi bench service: {out}/service.json: no service report to re-identify (run "
                         "`rw-fdi bench service` first)")
    with tqdm(desc=f"service bench: re-identifying {out} (core loop)", unit="run", file=sys.stderr) as bar:
        try:
            return reidentify(out, executor(args), bar.update)
        except (FileNotFoundError, ValueError, RecordMismatch) as e:
            raise SystemExit(f"rw-fdi bench service: {e}") from None


def _scaling(args) -> dict:
    from tqdm import tqdm
    from ...tools.benches.scaling_bench import bench_scaling
    workers = (1, 2)
    with tqdm(total=args.scaling_runs * (1 if args.scheduler else len(workers)), desc="scaling bench (core loop)",
              unit="run", file=sys.stderr) as bar:
        return bench_scaling(runs=args.scaling_runs, max_hours=args.max_hours or 0.25, workers=workers,
                             scheduler=args.scheduler, progress=bar.update)


def _figures(args) -> dict:
    from ...tools.benches.figures_check import check_figures

    def said(name, lines):   # each bench's figures as soon as they are in: the whole takes minutes
        print(f"figures: re-measuring {name} ..." if lines is None else "\n".join(
            f"figures: {x['figure']}: {x['small']} (record {x['record']})"
            + ("  << OUTSIDE" if x["flagged"] else "") for x in lines), file=sys.stderr, flush=True)
    return check_figures(benches=args.only.split(",") if args.only else None, progress=said)


POOL = ("--jobs", "--scheduler")   # where a Monte-Carlo bench's runs go (campaign.make_executor)
# name, what it measures (its help), the options it reads besides --json, what runs it (its report)
BENCHES = [
    ("graph", "real-time factor of a recorded fault-free run", ("--duration", "--seed"), _graph),
    ("fdi", "the flight budget: CPU per FDI period of every FDI node in service, memory", ("--duration", "--seed"),
     _fdi),
    ("study", "record and replay throughput and the thesis-scale reproduce time they give",
     ("--runs", "--duration", "--seed", "--jobs"), _study),
    ("detection", "false-alarm and detection rates with 95 %% intervals on >= 1000 held-out runs, both FDI methods "
     "(core loop)", ("--fault-free-runs", "--runs-per-cell", "--vehicle", "--observer", "--thresholds", "--out", *POOL),
     _detection),
    ("identification", "fault kind and size per kind and size, confusion matrix (core loop)",
     ("--runs-per-cell", "--units", "--thesis-runs", "--vehicle", "--out", *POOL), _identification),
    ("units", "the detection cells on wheels drawn around the datasheet and on the datasheet wheel, with and "
     "without unit calibration (core loop)", ("--fault-free-runs", "--runs-per-cell", "--vehicle", "--observer",
                                              "--thresholds", "--out", *POOL), _units),
    ("memory", "peak memory of the run summary, `rw-fdi bag` and evaluation for fault-free runs of --hours "
     "(recorded, minutes)", ("--hours", "--seed", "--out"), _memory),
    ("operations", "every observer and the /diagnostics verdict in operations (manoeuvres at random times, "
     "hours-long runs, faults a manoeuvre follows, bus drops that tumble an axis; core loop)",
     ("--fault-free-runs", "--runs-per-cell", "--hours-runs", "--seed-set", "--vehicle", "--observer", "--thresholds",
      "--out", *POOL), _operations),
    ("recovery", "the redundant wheel taking over from a wheel the FDI confirmed faulty (pointing back within "
     "0.2 deg, peak error, time to recover; FDI and FDIR in the core loop)",
     ("--runs-per-cell", "--fault-free-runs", "--seed-set", "--vehicle", "--out", *POOL), _recovery),
    ("dumping", "a day in orbit with the magnetorquers dumping and with them off (wheel speed band, pointing, when "
     "the wheels saturate; a plot), the FDI through hours of dumping and faults during a dump (core loop)",
     ("--day-hours", "--orbit-runs", "--runs-per-cell", "--seed", "--vehicle", "--out", *POOL), _dumping),
    ("service", "FDIR in service, every capability at once (units and datasheet wheels, manoeuvres before and after "
     "faults of every kind, size, wheel, onset and ramp, second faults, orbit with dumping, 600 s to 6 h; "
     "reconfigurations without a fault, the right wheel acted on, pointing kept, identification; core loop)",
     ("--service-runs", "--fault-free-runs", "--given-up-runs", "--max-hours", "--seed-set", "--vehicle", "--out",
      "--reidentify", "--every-observer", "--observer", "--thresholds", *POOL), _service),
    ("scaling", "in-service runs per second on 1 and 2 local workers (or a Dask cluster's) and the wall time "
     "projected for 100,000 in-service runs (core loop)", ("--scaling-runs", "--max-hours", "--scheduler"),
     _scaling),
    ("figures", "every figure of the README's table re-measured at small n (about 13 min on 2 cores at the "
     "record's machine speed), printed beside the README's and the record's, flagged where the two disagree "
     "beyond chance", ("--only",), _figures),
]


def add_arguments(parser) -> None:
    options = _options()
    benches = parser.add_subparsers(dest="what", required=True)
    for name, text, flags, run in BENCHES:
        # the help is %-formatted by argparse, the description is shown as written
        bench = benches.add_parser(name, help=text, description=text.replace("%%", "%"),
                                   parents=[options[f] for f in flags + ("--json",)])
        bench.set_defaults(bench=run)


def main(args) -> int:
    report = args.bench(args)
    print(json.dumps({k: v for k, v in report.items() if k != "text"}, indent=2) if args.json else report["text"])
    return 0 if report["ok"] else 1
