"""`rw-fdi screen`: FDI figures of many seeds in seconds, the node code on the core loop (no ROS)."""
import sys

from ..options import executor, fdi_config, flown_scenarios, parse_seeds, writable_file

NAME = "screen"
HELP = "FDI figures for many seeds in seconds (core loop + node code, no ROS)"
PARENTS = ("fdi_files", "method", "unit", "decision", "observers", "cluster", "vehicle")


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", nargs="+", default=None,
                        help="scenario names or YAML files (required without --vehicle)")
    parser.add_argument("--seeds", default="100..129", help="A..B inclusive")
    parser.add_argument("--fdir", action="store_true",
                        help="reconfigure on the verdict in the core loop, as `rw-fdi run` does (default: detection "
                             "alone, every wheel kept in use)")
    parser.add_argument("--json", action="store_true",
                        help="print the counts per scenario and observer as JSON instead of text")
    parser.add_argument("--table", default=None, metavar="CSV",
                        help="also write one row per run (seed, faults, each observer's verdict and delay, the "
                             "identification) to CSV (pandas.read_csv, polars.read_csv)")


def main(args) -> int:
    seeds = parse_seeds(args.seeds, "--seeds")   # before the imports: a bad option answers at once
    if args.table:
        writable_file(args.table, "--table")
    import json
    from tqdm import tqdm
    from ...core.controller_design import scenario_design
    from ...core.mission.scenario import load_scenario
    from ...tools.benches.kit import write_runs_table
    from ...tools.evaluation.screen import format_screen, screen
    from ...scoring.metrics import run_row
    refs = flown_scenarios(args, args.scenario)
    scenarios = [load_scenario(ref) for ref in refs]
    names = args.scenario or [scenarios[0].name]
    for name, scenario in zip(names, scenarios):
        scenario_design(scenario, name)   # its vehicle's controllers, or one line before any run
    fdis = [fdi_config(args).for_vehicle(s.spacecraft.name) for s in scenarios]   # each its vehicle's FDI
    for scenario, fdi in zip(scenarios, fdis):
        fdi.check(scenario.plant_choices(), scenario.duration)
    pool = executor(args)   # --jobs local processes (default: the cores), or --scheduler's Dask cluster
    counts, rows = {}, []
    with tqdm(total=len(seeds) * len(scenarios), desc="screen (core loop)", unit="run", file=sys.stderr,
              disable=None) as bar:
        for name, scenario, fdi in zip(names, scenarios, fdis):
            counts[name], runs = screen(scenario, seeds, fdi, progress=bar.update, executor=pool)
            rows += [run_row(r) for r in runs]
            if not args.json:
                bar.clear()
                print(format_screen(name, counts[name]), flush=True)
    if args.json:
        print(json.dumps(counts, indent=1))
    if args.table:
        print(f"runs: {write_runs_table(rows, args.table)}", file=sys.stderr)
    return 0
