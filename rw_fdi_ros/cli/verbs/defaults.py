"""`rw-fdi defaults`: the shipped models and threshold curves regenerated from nothing (campaigns, training,
fitting, a held-out check)."""
from ..options import COUNT, executor

NAME = "defaults"
HELP = "regenerate the shipped models and threshold curves from nothing"
PARENTS = ("jobs", "false_alarms")


def add_arguments(parser) -> None:
    parser.add_argument("--work", default="bags/defaults", help="where the campaigns' bags go (resumable)")
    parser.add_argument("--out", default=None, help="default: config/fdi")
    parser.add_argument("--fit-runs", type=COUNT, default=100)
    parser.add_argument("--heldout-runs", type=COUNT, default=20)
    parser.add_argument("--train-runs", type=COUNT, default=40)
    parser.add_argument("--epochs", type=COUNT, default=None,
                        help="speed-aware set (default 1000; the thesis set: 300)")


def main(args) -> int:
    from ...paths import config_dir
    from ...tools.design.defaults import format_report, regenerate_defaults
    report = regenerate_defaults(work=args.work, out=args.out or config_dir() / "fdi", fit_runs=args.fit_runs,
                                 heldout_runs=args.heldout_runs, train_runs=args.train_runs,
                                 **({"epochs": args.epochs} if args.epochs else {}),
                                 executor=executor(args), false_alarm_rate=args.false_alarm_rate)
    print(format_report(report))
    return 0
