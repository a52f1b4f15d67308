"""`rw-fdi screen`: FDI figures of many seeds in seconds, the node code on the core loop (no ROS)."""
from ..options import parse_seeds

NAME = "screen"
HELP = "FDI figures for many seeds in seconds (core loop + node code, no ROS)"
PARENTS = ("fdi_files", "method", "unit")


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", nargs="+", required=True)
    parser.add_argument("--seeds", default="100..129", help="A..B inclusive")


def main(args) -> int:
    seeds = parse_seeds(args.seeds, "--seeds")   # before the imports: a bad option answers at once
    from ...core.scenario import load_scenario
    from ...tools.campaigns.fdi import check_fdi_files
    from ...tools.evaluation.screen import format_screen, screen
    for name in args.scenario:
        if args.unit_calibration:
            check_fdi_files(args.models, args.thresholds, None, args.fdi_method, args.unit_calibration,
                            load_scenario(name).duration)
        print(format_screen(name, screen(load_scenario(name), seeds, args.models, args.thresholds,
                                         args.persistence, args.fdi_method, args.unit_calibration)))
    return 0
