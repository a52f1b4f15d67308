"""`rw-fdi reproduce`: the whole thesis study from nothing (campaigns, training, fitting, evaluation), resumable."""
from ..options import executor, number

NAME = "reproduce"
HELP = "the whole thesis study from nothing (resumable)"
PARENTS = ("cluster", "persistence")


def add_arguments(parser) -> None:
    parser.add_argument("--out", required=True)
    parser.add_argument("--scale", default="small", choices=["small", "thesis"])
    parser.add_argument("--engine", default="core", choices=["core", "graph"],
                        help="core (default): the node code on the core loop records and judges every run, and a "
                             "sample goes through the graph as reference; graph: every run through the graph")
    parser.add_argument("--graph-sample", type=number(int, 0), default=1, metavar="N",
                        help="with the core engine: runs per group recorded and replayed through the graph as well, "
                             "and compared (default 1; 0: none)")


def main(args) -> int:
    import time
    from ...tools.evaluation.reproduce import reproduce
    t0 = time.monotonic()
    report = reproduce(args.out, args.scale, executor=executor(args), persistence=args.persistence,
                       engine=args.engine, graph_sample=args.graph_sample)
    print(f"reproduce ({args.scale}) done in {time.monotonic() - t0:.0f} s wall: {report['runs']} runs evaluated; "
          f"report {args.out}/report/report.md")
    return 0
