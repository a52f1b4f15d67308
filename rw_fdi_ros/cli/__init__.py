"""rw-fdi: the command line of rw_fdi_ros, one module per verb in verbs/ (each NAME, HELP, PARENTS: the shared
options it takes from options.py, add_arguments(parser) and main(args)), assembled here."""
from __future__ import annotations

import argparse
import sys

from .verbs import (bag, bench, campaign, defaults, evaluate, fit_thresholds, reproduce, run, scenarios, screen,
                    telemetry, train, vehicle)

VERBS = [run, campaign, train, fit_thresholds, defaults, evaluate, reproduce, screen, scenarios, vehicle, telemetry,
         bench, bag]


def build_parser() -> argparse.ArgumentParser:
    from .options import parents
    p = argparse.ArgumentParser(prog="rw-fdi", description="Reaction-wheel FDI on a ROS 2 node graph.")
    sub = p.add_subparsers(dest="command", required=True)
    shared = parents()
    for verb in VERBS:
        parser = sub.add_parser(verb.NAME, help=verb.HELP, parents=[shared[name] for name in verb.PARENTS])
        verb.add_arguments(parser)
        parser.set_defaults(func=verb.main)
    return p


def _terminate(signum, frame):
    # SIGTERM (a CI job cancelled, `kill`) ends a run as Ctrl-C does: nodes stopped, the bag closed
    # complete, a non-zero exit; Python's default would die at once and orphan the nodes
    raise KeyboardInterrupt


def main(argv=None) -> int:
    import signal
    args = build_parser().parse_args(argv)
    signal.signal(signal.SIGTERM, _terminate)
    # Ctrl-C and `kill -INT` stop every command the same way, also when a script started it in the background:
    # a shell without job control starts those with SIGINT ignored, and Python keeps an ignored SIGINT ignored
    # (a bench sent SIGINT by a test under such a shell ran on to its end)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    from ..core.mission.scenario import ScenarioError
    from ..storage.bag import BagError
    try:
        code = args.func(args)
        sys.stdout.flush()   # a closed pipe shows here, not at interpreter exit
        return code
    except (ScenarioError, BagError, FileNotFoundError, ValueError, RuntimeError) as exc:
        print(f"rw-fdi: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # the maps in progress end their pools; a command that never imported the campaigns has none (and `run`,
        # the product path, imports no tools)
        campaign = sys.modules.get("rw_fdi_ros.tools.campaigns.campaign")
        if campaign is not None:
            campaign.end_interrupted()
        print("rw-fdi: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (`rw-fdi bag DIR | head`): stop quietly, as other Unix tools do
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:   # a file that exists, cannot be written, is a directory: the system's words, one line
        where = f": {exc.filename}" if exc.filename else ""
        print(f"rw-fdi: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
