"""`rw-fdi evaluate`: recorded bags replayed through the observers and isolation, judged in one report."""
from ..options import executor, fdi_config, writable_dir

NAME = "evaluate"
HELP = "replay bags through the observers and isolation; write the report"
PARENTS = ("fdi_files", "cluster", "unit", "decision", "observers")


def add_arguments(parser) -> None:
    parser.add_argument("--bags", required=True, help="directory of bags (searched recursively)")
    parser.add_argument("--report", required=True, help="directory for report.md, report.json, plots, replays")
    parser.add_argument("--vehicle", default=None, metavar="NAME|DIR",
                        help="the vehicle the bags flew, with its FDI: a shipped name (the default: each bag's "
                             "recorded vehicle's shipped FDI) or your vehicle's FDI directory (`rw-fdi defaults "
                             "--vehicle FILE --out DIR`; as --models DIR)")
    parser.add_argument("--engine", default="graph", choices=["graph", "core"],
                        help="graph: replay every bag through the FDI graph (the reference); core: the observer and "
                             "isolation nodes' code on each bag's recorded telemetry, no replay (the same report)")


def main(args) -> int:
    writable_dir(args.report, "--report")   # a file in the way is said before any bag is read
    from ...tools.evaluation.evaluate import evaluate, main_summary
    if args.vehicle is not None:   # read (one line naming the field) before any bag; a directory's FDI judges
        from pathlib import Path
        from ...core.mission.vehicle import load_vehicle
        load_vehicle(args.vehicle)
        if Path(args.vehicle).is_dir() and not (args.models or args.thresholds):
            args.models = str(Path(args.vehicle).resolve())
    report = evaluate(args.bags, args.report, fdi_config(args), executor=executor(args), engine=args.engine)
    print(main_summary(report))
    print(f"report: {args.report}/report.md, {args.report}/report.json")
    return 0 if report["runs"] else 1
