"""`rw-fdi campaign`: N recorded runs of a scenario over consecutive seeds, resumable."""
import sys

from ..options import RUNS, SEED, executor, flown_scenarios, writable_dir

NAME = "campaign"
HELP = "record N runs of a scenario (seeds S..S+N-1), resumable"
PARENTS = ("cluster", "vehicle")


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", default=None, help="scenario name or YAML file (required without --vehicle)")
    parser.add_argument("--runs", type=RUNS, required=True)
    parser.add_argument("--seed-start", type=SEED, default=1)
    parser.add_argument("--out", required=True, help="directory for the bags")
    parser.add_argument("--fdi", action="store_true", help="run the observers and isolation live too (graph engine)")
    parser.add_argument("--engine", default="graph", choices=["graph", "core"],
                        help="graph: the ROS graph records each run (the reference); core: the node code on the "
                             "batched core loop writes the same bags, ~10x faster (docs/evaluation.md \"Engines\")")


def main(args) -> int:
    from ...tools.campaigns.campaign import run_campaign
    ref = flown_scenarios(args, [args.scenario] if args.scenario else [])[0]
    writable_dir(args.out, "--out")
    fdi = args.fdi
    if fdi and getattr(args, "models", None):   # a vehicle's FDI directory (--vehicle DIR) judges live
        from ...fdi_config import FdiConfig
        fdi = FdiConfig(models=args.models)
    res = run_campaign(ref, args.runs, args.seed_start, args.out, fdi=fdi, executor=executor(args),
                       engine=args.engine)
    print(f"campaign {args.scenario or 'fault-free'}: {len(res.done)} recorded, {len(res.skipped)} already complete, "
          f"{len(res.failed)} failed" + (f", {len(res.retried)} started over" if res.retried else "")
          + f" -> {args.out}")
    for seed, reason in res.retried:
        print(f"  seed {seed} started over after: {reason}", file=sys.stderr)
    for seed, reason in res.failed:
        print(f"  seed {seed}: {reason}", file=sys.stderr)
    return 1 if res.failed else 0
