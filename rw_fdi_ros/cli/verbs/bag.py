"""`rw-fdi bag`: what a bag holds (also a truncated one), its run summary and FDI verdict, read as a stream."""
import sys
from pathlib import Path

NAME = "bag"
HELP = ("what a bag holds (also a truncated one), its run summary and FDI verdict; read as a stream (memory does "
        "not grow with the run)")
PARENTS = ()


def add_arguments(parser) -> None:
    parser.add_argument("bag")
    parser.add_argument("--figure", default=None, metavar="PNG", help="also draw the residuals against the thresholds")
    parser.add_argument("--json", action="store_true",
                        help="print it as JSON: complete, damage, topics (type, count, span), run summary, FDI verdict")


def main(args) -> int:
    """Topics, counts and spans of a bag, its run summary and, where it holds FDI outputs, the FDI
    verdict: each a stream over the file, so memory does not grow with the run's length."""
    from ...graph import topics as T
    from ...storage.bag import bag_info, read_series
    from ...runner.summary import format_summary, run_summary
    info = bag_info(args.bag)
    if args.json:
        return _json(args, info)
    state = "complete" if info.complete else f"incomplete: {info.note}"
    print(f"{info.path}: {state}")
    if info.damaged:   # what was still read is listed below; the tools that train, fit and judge skip it
        print(f"rw-fdi: error: {info.path}: {info.damage()}", file=sys.stderr)
    for topic in sorted(info.counts):
        first, last = info.span[topic]
        print(f"  {topic:28s} {info.types[topic]:38s} {info.counts[topic]:7d} msgs  "
              f"{first * 1e-9:8.1f} .. {last * 1e-9:8.1f} s")
    if T.SCENARIO not in info.counts:
        return 1 if info.damaged else 0
    if T.ATTITUDE in info.counts:
        print(format_summary(run_summary(args.bag)))
        if T.PLANT_DONE not in info.counts:   # what a script checks after a launch that ended early
            print(f"  run interrupted: no {T.PLANT_DONE} (the plant did not reach the run's end)")
    if T.fdi_output_topics("elman")["alarm"] in info.counts:
        from ...scoring.bag_series import health_from_bag, plugin_slots_of
        from ...runner.residual_figure import plot_residuals
        from ...runner.verdict import fdi_verdict, format_verdict, verdict_topics
        data = read_series(args.bag, verdict_topics(plugin_slots_of(info.counts)))
        verdict = {**fdi_verdict(data), "health": health_from_bag(args.bag)}
        print(f"fault detection and isolation:\n{format_verdict(verdict)}")
        if args.figure:
            print(f"  figure: {plot_residuals(data, Path(args.figure))}")
    return 1 if info.damaged else 0


def _json(args, info) -> int:
    from ...graph import topics as T
    from ...storage.bag import read_series
    from ..options import dumps
    out = {"bag": str(info.path), "complete": info.complete, "note": info.note,
           "damage": info.damage() if info.damaged else None,
           "topics": {t: {"type": info.types[t], "messages": info.counts[t], "first_s": info.span[t][0] * 1e-9,
                          "last_s": info.span[t][1] * 1e-9} for t in sorted(info.counts)},
           "summary": None, "fdi": None}
    if T.ATTITUDE in info.counts and T.SCENARIO in info.counts:
        from ...runner.summary import run_summary
        out["summary"] = run_summary(args.bag)
    if T.fdi_output_topics("elman")["alarm"] in info.counts and T.SCENARIO in info.counts:
        from ...scoring.bag_series import health_from_bag, plugin_slots_of
        from ...runner.verdict import fdi_verdict, verdict_topics
        out["fdi"] = {**fdi_verdict(read_series(args.bag, verdict_topics(plugin_slots_of(info.counts)))),
                      "health": health_from_bag(args.bag)}
    print(dumps(out))
    return 1 if info.damaged else 0

