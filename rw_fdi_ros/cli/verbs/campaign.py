"""`rw-fdi campaign`: N recorded runs of a scenario over consecutive seeds, resumable."""
import sys

from ..options import RUNS, SEED, executor, writable_dir

NAME = "campaign"
HELP = "record N runs of a scenario (seeds S..S+N-1), resumable"
PARENTS = ("cluster",)


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", required=True, help="scenario name or YAML file")
    parser.add_argument("--runs", type=RUNS, required=True)
    parser.add_argument("--seed-start", type=SEED, default=1)
    parser.add_argument("--out", required=True, help="directory for the bags")
    parser.add_argument("--fdi", action="store_true", help="run the observers and isolation live too (graph engine)")
    parser.add_argument("--engine", default="graph", choices=["graph", "core"],
                        help="graph: the ROS graph records each run (the reference); core: the node code on the "
                             "batched core loop writes the same bags, ~10x faster (docs/evaluation.md \"Engines\")")


def main(args) -> int:
    from ...tools.campaigns.campaign import run_campaign
    writable_dir(args.out, "--out")
    res = run_campaign(args.scenario, args.runs, args.seed_start, args.out, fdi=args.fdi,
                       executor=executor(args), engine=args.engine)
    print(f"campaign {args.scenario}: {len(res.done)} recorded, {len(res.skipped)} already complete, "
          f"{len(res.failed)} failed" + (f", {len(res.retried)} started over" if res.retried else "")
          + f" -> {args.out}")
    for seed, reason in res.retried:
        print(f"  seed {seed} started over after: {reason}", file=sys.stderr)
    for seed, reason in res.failed:
        print(f"  seed {seed}: {reason}", file=sys.stderr)
    return 1 if res.failed else 0
