"""`rw-fdi run`: one scenario through the whole graph, recorded as a bag, with its summary and FDI verdict."""
import sys

from ..options import SEED, dumps, fdi_config, flown_scenarios, number, writable_dir

NAME = "run"
HELP = "run one scenario through the whole graph and record a bag"
PARENTS = ("fdi_files", "method", "unit", "decision", "observers", "vehicle")


def add_arguments(parser) -> None:
    parser.add_argument("--scenario", default=None,
                        help="scenario name (see `rw-fdi scenarios`) or YAML file (required without --vehicle)")
    parser.add_argument("--seed", type=SEED, default=None, help="seed for initial conditions and disturbance")
    parser.add_argument("--out", default="bags", help="directory for the bag (default: bags/)")
    parser.add_argument("--emf-limit", default=None, choices=["kf_scaled", "pwm_saturation"],
                        help="EMF torque-limiting model (physics.md [choice]; default: the scenario's, else kf_scaled)")
    parser.add_argument("--command-timeout", type=number(float, 0.01, 1e9), default=5.0,
                        help="wall seconds the plant waits for a command (0.01 to 1e9: the plant's own range, "
                             "graph/parameters.TIMEOUT)")
    parser.add_argument("--keep-logs", action="store_true", help="keep node logs also after a successful run")
    parser.add_argument("--no-fdi", dest="fdi", action="store_false",
                        help="without the observers and isolation (plant, controllers, wheel allocation, recorder "
                             "only)")
    parser.add_argument("--no-fdir", dest="fdir", action="store_false",
                        help="detect, isolate and identify, but keep commanding every wheel in use (no "
                             "reconfiguration: the FDI alone, as before the redundant wheel)")
    parser.add_argument("--live", type=number(int, 0, 65_535), nargs="?", const=8765, default=None, metavar="PORT",
                        help="watch the run in Foxglove as it happens: a WebSocket server on ws://127.0.0.1:PORT "
                             "(default 8765; 0: any free port) with every recorded topic; open a connection to it "
                             "and the layout config/foxglove/rw_fdi.json (needs foxglove-sdk)")
    parser.add_argument("--json", action="store_true",
                        help="print the outcome (ok, reason, bag, wall time, run summary, FDI verdict) as JSON on "
                             "stdout; the progress lines go to stderr")


def _nodes(args, wheels, fdi) -> str:
    """The nodes the run starts, as its first line says them."""
    if fdi is None:
        nodes = f"plant with {wheels.count} wheels ({wheels.name}), 3 PID controllers, wheel allocation, recorder"
    else:
        nodes = (f"plant with {wheels.count} wheels ({wheels.name}), 3 PID controllers, wheel allocation"
                 f"{' with FDIR' if fdi.fdir else ' (no FDIR: every wheel kept)'}, "
                 f"{wheels.count} Elman observers, linear observer, "
                 + ("model observer, " if args.fdi_method == "speed_aware" else "")
                 + "".join(f"{slot} observer (plug-in), " for slot in fdi.plugin_slots) + "isolation, recorder")
    return nodes + (", live view" if args.live is not None else "")


def _report(args, outcome, fdi=None) -> int:
    """The outcome printed (JSON, or the summary and the FDI verdict, as ``fdi`` ran it); the exit status."""
    from ...runner.summary import format_summary
    if args.json:
        print(dumps({"ok": outcome.ok, "reason": outcome.reason, "bag": str(outcome.bag),
                     "wall_time_s": outcome.wall_time, "summary": outcome.summary}))
        return 0 if outcome.ok else 1
    if outcome.summary:
        if "scenario" in outcome.summary:   # a run stopped before its bag held a step has the FDI's part alone
            print(format_summary(outcome.summary))
        if "fdi" in outcome.summary:
            from ...runner.verdict import format_verdict
            print(f"fault detection and isolation ({fdi.method}"
                  + (f", persistence P = {fdi.persistence}" if fdi.persistence else "")
                  + (f", wheels learnt over the first {fdi.unit_calibration:g} s" if fdi.unit_calibration else "")
                  + "):")
            print(format_verdict(outcome.summary["fdi"]))
            print(f"  figure: {outcome.summary.get('figure')}")
    if not outcome.ok:
        where = f" (node logs: {outcome.log_dir})" if outcome.log_dir and outcome.log_dir.exists() else ""
        print(f"rw-fdi: run failed: {outcome.reason}{where}", file=sys.stderr)
        return 1
    rtf = (outcome.summary or {}).get("end_time", float("nan")) / max(outcome.wall_time, 1e-9)
    print(f"  wall time {outcome.wall_time:.1f} s ({rtf:.0f}x real time)")
    return 0


def main(args) -> int:
    from ...runner.scenario_run import resolve_scenario, run_scenario
    ref = flown_scenarios(args, [args.scenario] if args.scenario else [])[0]
    scenario, _ = resolve_scenario(ref, args.seed)   # a bad scenario is the first thing to say
    writable_dir(args.out, "--out")
    if args.live is not None:   # the live view node's server: said here, before any node starts
        from ...extras import require
        try:
            require("foxglove", "live")
        except RuntimeError as exc:
            print(f"rw-fdi: --live: {exc}", file=sys.stderr)
            return 2
    wheels, fdi = scenario.wheel_set(), None
    if args.fdi:
        from ...runner.fdi_run import run_with_fdi
        fdi = fdi_config(args).for_vehicle(scenario.spacecraft.name)
        fdi.check(scenario.plant_choices(emf_limit=args.emf_limit), scenario.duration)
    seed = f" seed {args.seed}" if args.seed is not None else ""
    print(f"running scenario {args.scenario or scenario.name}{seed}" +
          f" ({_nodes(args, wheels, fdi)}; private DDS domain)", flush=True,
          file=sys.stderr if args.json else sys.stdout)
    if args.live is not None:
        print(f"live view: ws://127.0.0.1:{args.live or '<a free port, in the live_view log>'} (Foxglove: Open "
              "connection; layout config/foxglove/rw_fdi.json)", flush=True,
              file=sys.stderr if args.json else sys.stdout)
    from tqdm import tqdm
    # the simulated time as it goes (the plant's, once a wall second): a day in orbit takes minutes
    with tqdm(total=round(scenario.duration), desc="simulated", unit="s", file=sys.stderr, disable=None,
              bar_format="{desc}: {n:.0f}/{total:.0f} s |{bar}| {elapsed} wall") as bar:
        def progress(simulated, duration):
            bar.update(min(simulated, duration) - bar.n)
        common = dict(seed=args.seed, out_dir=args.out, keep_logs=args.keep_logs, emf_limit=args.emf_limit,
                      command_timeout=args.command_timeout, progress=progress, live=args.live)
        if args.fdi:
            outcome = run_with_fdi(ref, fdi=fdi, figure=True, **common)
        else:
            outcome = run_scenario(ref, **common)
    return _report(args, outcome, fdi)
