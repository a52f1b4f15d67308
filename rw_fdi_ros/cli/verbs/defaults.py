"""`rw-fdi defaults`: the shipped models and threshold curves regenerated from nothing (campaigns, training,
fitting, a held-out check); with --vehicle, everything the FDI needs for that vehicle."""
from ..options import COUNT, executor

NAME = "defaults"
HELP = ("regenerate the shipped models and threshold curves from nothing; with --vehicle, make the FDI of that "
        "vehicle (controllers, networks, bands)")
PARENTS = ("jobs", "false_alarms")


def add_arguments(parser) -> None:
    parser.add_argument("--vehicle", default=None, metavar="NAME|FILE",
                        help="a shipped vehicle's name or a vehicle file (docs/vehicles.md): its controllers, a "
                             "network per wheel in use, datasheet and unit-calibrated bands, all on the core loop "
                             "(then give every command --models OUT)")
    parser.add_argument("--service", choices=["datasheet", "mixed"], default=None, metavar="WHEELS",
                        help="a speed-aware set trained and fitted for service (tools/design/service_training.py, "
                             "docs/fdi.md 'Learned observers in service'): one network of the wheel type learning "
                             "the nominal model's error on the in-service family's healthy stretches of every wheel "
                             "(manoeuvres, reconfigurations, dumps through zero), flown on the core loop; WHEELS: "
                             "datasheet (chosen) or mixed (the family's units and datasheet wheels); every "
                             "observer's bands on its fault-free 600-s runs, datasheet and calibrated (then "
                             "--models OUT)")
    parser.add_argument("--work", default="bags/defaults", help="where the campaigns' bags go (resumable; not with "
                                                                "--vehicle, which records no bags)")
    parser.add_argument("--out", default=None, help="default: config/fdi; with --vehicle: fdi_<vehicle name>")
    parser.add_argument("--fit-runs", type=COUNT, default=100)
    parser.add_argument("--heldout-runs", type=COUNT, default=None,
                        help="default: 20 (--vehicle: 100 of datasheet wheels and 100 of drawn units)")
    parser.add_argument("--train-runs", type=COUNT, default=40,
                        help="runs the Elman networks learn from: the thesis' 400-s one-slew runs; with --vehicle or "
                             "--service, the in-service family's fault-free 600-s runs (manoeuvres)")
    parser.add_argument("--unit-runs", type=COUNT, default=300,
                        help="with --vehicle: runs of drawn wheel units the calibrated bands are fitted on")
    parser.add_argument("--fault-runs", type=COUNT, default=40,
                        help="with --vehicle: runs of a 10 %% current loss and of +30 C each observer is judged on "
                             "alone (an observer that misses is named with its cause and residuals)")
    parser.add_argument("--epochs", type=COUNT, default=None,
                        help="speed-aware set (default 1000; the thesis set: 300)")
    parser.add_argument("--hidden", type=COUNT, default=None,
                        help="with --service: the network's hidden units (default 25, the thesis')")
    parser.add_argument("--window", type=COUNT, default=None,
                        help="with --service: the training window in FDI samples (default 300: two of a 600-s run)")
    parser.add_argument("--loss", choices=["mse", "huber"], default=None,
                        help="with --service: the training loss (default mse, the thesis')")


def main(args) -> int:
    if args.service is None:
        given = [f"--{k}" for k in ("hidden", "window", "loss") if getattr(args, k) is not None]
        if given:
            raise ValueError(f"{', '.join(given)} only with --service (the set trained for service)")
    if args.vehicle is not None:
        return _vehicle(args)
    if args.service is not None:
        return _service(args)
    from ...paths import config_dir
    from ...tools.design.defaults import format_report, regenerate_defaults
    report = regenerate_defaults(work=args.work, out=args.out or config_dir() / "fdi", fit_runs=args.fit_runs,
                                 heldout_runs=args.heldout_runs or 20, train_runs=args.train_runs,
                                 **({"epochs": args.epochs} if args.epochs else {}),
                                 executor=executor(args), false_alarm_rate=args.false_alarm_rate)
    print(format_report(report))
    return 0


def _vehicle(args) -> int:
    from ...core.mission.vehicle import load_vehicle
    from ...tools.design.vehicle_defaults import short_of_goal, vehicle_defaults
    from ...core.controller_design import design_controller
    vehicle = load_vehicle(args.vehicle)   # a bad file: one line naming the field, before anything runs
    design_controller(vehicle)   # targets it cannot meet: one line too (the design is cached for the first stage)
    out = args.out or f"fdi_{vehicle.name}"
    report = vehicle_defaults(args.vehicle, out, train_runs=args.train_runs, fit_runs=args.fit_runs,
                              heldout_runs=args.heldout_runs or 100, unit_runs=args.unit_runs,
                              unit_heldout_runs=args.heldout_runs or 100,
                              **({"epochs": args.epochs} if args.epochs else {}), executor=executor(args),
                              false_alarm_rate=args.false_alarm_rate, fault_runs=args.fault_runs)
    held = report["held_out_false_alarms"]
    print(f"FDI of vehicle {vehicle.name} in {out} ({report['stages']['total_s'] / 60:.1f} min): networks for "
          f"{', '.join(report['networks']['wheels'])}; held-out fault-free runs alarmed: "
          + "; ".join(f"{kind} " + ", ".join(f"{obs} {x['alarmed']}/{x['runs']}" for obs, x in rows.items())
                      for kind, rows in held.items()))
    for line in short_of_goal(report["faults_caught"]):
        print(line)
    print(f"use it: rw-fdi run --scenario {out}/scenarios/fault_free.yaml --models {out} (report: "
          f"{out}/defaults_report.md)")
    return 0


def _service(args) -> int:
    from ...tools.design.service_training import service_defaults
    out = args.out or f"fdi_service_{args.service}"
    report = service_defaults(out, train_runs=args.train_runs, fit_runs=args.fit_runs, units=args.service,
                              epochs=args.epochs or 1000, executor=executor(args),
                              **{k: getattr(args, k) for k in ("hidden", "window", "loss")
                                 if getattr(args, k) is not None})
    print(f"service-trained FDI in {out} ({report['seconds'] / 60:.1f} min): one network of the wheel type on "
          + ", ".join(f"{n} windows of {a}" for a, n in report["windows"].items())
          + "; kappa " + ", ".join(f"{a} {k:.3f}" for a, k in report["uncertainty_gain"].items()))
    print(f"use it: rw-fdi screen --models {out} ...; in service: rw-fdi bench service --every-observer "
          f"--thresholds {out}")
    return 0
