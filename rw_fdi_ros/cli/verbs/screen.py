"""`rw-fdi screen`: FDI figures of many seeds in seconds, the node code on the core loop (no ROS)."""
from ..options import fdi_config, parse_seeds

NAME = "screen"
HELP = "FDI figures for many seeds in seconds (core loop + node code, no ROS)"
PARENTS = ("fdi_files", "method", "unit")


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", nargs="+", required=True)
    parser.add_argument("--seeds", default="100..129", help="A..B inclusive")


def main(args) -> int:
    seeds = parse_seeds(args.seeds, "--seeds")   # before the imports: a bad option answers at once
    from ...core.scenario import load_scenario
    from ...tools.evaluation.screen import format_screen, screen
    fdi = fdi_config(args)
    for name in args.scenario:
        scenario = load_scenario(name)
        fdi.check(scenario.plant_choices(), scenario.duration)
        print(format_screen(name, screen(scenario, seeds, fdi)))
    return 0
