"""`rw-fdi fit-thresholds`: the observers' thresholds fitted on fault-free runs, recorded bags or runs of the
core loop (speed_aware: bands for a designed false-alarm rate; thesis: mean + 3 sigma curves)."""

from ..options import executor, fault_free_samples, parse_seeds

NAME = "fit-thresholds"
HELP = ("fit the thresholds of the observers from fault-free bags (speed_aware models: bands for a designed "
        "false-alarm rate; thesis models: mean + 3 sigma curves)")
PARENTS = ("models", "false_alarms", "persistence", "unit", "observers", "cluster")


def add_arguments(parser) -> None:
    parser.add_argument("--bags", default=None, help="directory of fault-free bags")
    parser.add_argument("--simulate", default=None, metavar="SCENARIO",
                        help="instead of bags: fault-free runs of SCENARIO by the core loop (rw-fdi screen's, the "
                             "graph's numbers) over --seeds")
    parser.add_argument("--seeds", default="60000000..60000299",
                        help="with --simulate: A..B inclusive (default %(default)s, disjoint from every bench)")
    parser.add_argument("--out", required=True)


def main(args) -> int:
    # the options first: a bad one answers at once, before torch loads
    if not 0.0 < args.false_alarm_rate < 1.0:
        raise ValueError(f"--false-alarm-rate must lie in (0, 1), got {args.false_alarm_rate}")
    if (args.bags is None) == (args.simulate is None):
        raise ValueError("give either --bags DIR or --simulate SCENARIO --seeds A..B")
    seeds = parse_seeds(args.seeds, "--seeds") if args.simulate else None
    import time
    from ...paths import config_dir, shown_path
    from ...tools.design.offline import fdi_method_of, fit_thresholds, load_models
    from ...tools.design.samples import load_samples, simulated_fault_free_runs
    models_dir = args.models or str(config_dir() / "fdi")
    models = load_models(models_dir)
    if args.plugins:   # a user's observers, with their trained state from --out (or --models)
        from ...fdi_config import FdiConfig
        from ...core.fdi.observer_plugin import ObserverModels
        models = ObserverModels(models, FdiConfig(models=models_dir, thresholds=args.out, plugins=tuple(args.plugins),
                                                  unit_calibration=args.unit_calibration).load_plugins())
    t0 = time.monotonic()
    plant = None
    pool = executor(args)   # --jobs local processes, or --scheduler's Dask cluster
    if args.simulate:
        samples, plant = simulated_fault_free_runs(args.simulate, seeds, pool)
    else:
        samples = fault_free_samples(args.bags, load_samples, pool)
    result = fit_thresholds(samples, models, args.out, model_ref=shown_path(models_dir, args.out),
                            false_alarm_rate=args.false_alarm_rate, persistence=args.persistence,
                            unit_calibration=args.unit_calibration, plant=plant)
    print(f"thresholds from {len(samples)} fault-free runs in {time.monotonic() - t0:.0f} s -> {args.out}")
    speed_aware = fdi_method_of(models) == "speed_aware"
    for obs, row in result.items():
        if speed_aware:
            print(f"  {obs:7s} band c [1e-3 N m] " + "  ".join(f"{a}={v * 1e3:.4f}" for a, v in row.items())
                  + f"  (per-run false-alarm rate {args.false_alarm_rate:g})")
        else:
            print(f"  {obs:7s} reliability " + "  ".join(f"{a}={v * 100:.0f}%" for a, v in row.items()))
    return 0
