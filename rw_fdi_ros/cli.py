"""rw-fdi: the command line of rw_fdi_ros (run, scenarios, bench, bag)."""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path


def writable_dir(path: str, option: str) -> Path:
    """``path`` made (with its parents) and writable, or a one-line ValueError naming the option: an
    output that cannot be written fails before any node starts, not inside the recorder."""
    import os
    folder = Path(path)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot create it ({exc.strerror or exc})") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {path}: not writable")
    return folder


def _cmd_run(args) -> int:
    from .tools.campaigns.run import run_scenario
    from .tools.campaigns.summary import format_summary
    from .tools.campaigns.run import resolve_scenario
    scenario, _ = resolve_scenario(args.scenario, args.seed)   # a bad scenario is the first thing to say
    writable_dir(args.out, "--out")
    wheels = scenario.wheel_set()
    nodes = f"plant with {wheels.count} wheels ({wheels.name}), 3 PID controllers, wheel allocation, recorder"
    if args.fdi:
        from .tools.campaigns.fdi import check_fdi_files, format_verdict, run_with_fdi
        check_fdi_files(args.models, args.thresholds, scenario.plant_choices(emf_limit=args.emf_limit),
                        args.fdi_method, args.unit_calibration, scenario.duration)
        nodes = (f"plant with {wheels.count} wheels ({wheels.name}), 3 PID controllers, wheel allocation with FDIR, "
                 f"{wheels.count} Elman observers, linear observer, "
                 + ("model observer, " if args.fdi_method == "speed_aware" else "") + "isolation, recorder")
    print(f"running scenario {args.scenario}" + (f" seed {args.seed}" if args.seed is not None else "") +
          f" ({nodes}; private DDS domain)", flush=True)
    common = dict(seed=args.seed, out_dir=args.out, keep_logs=args.keep_logs, emf_limit=args.emf_limit,
                  command_timeout=args.command_timeout)
    if args.fdi:
        outcome = run_with_fdi(args.scenario, models=args.models, thresholds=args.thresholds,
                               persistence=args.persistence, figure=True, method=args.fdi_method,
                               unit_calibration=args.unit_calibration, fdir=args.fdir, **common)
    else:
        outcome = run_scenario(args.scenario, **common)
    if outcome.summary:
        print(format_summary(outcome.summary))
        if "fdi" in outcome.summary:
            print(f"fault detection and isolation ({args.fdi_method}"
                  + (f", persistence P = {args.persistence}" if args.persistence else "")
                  + (f", wheels learnt over the first {args.unit_calibration:g} s" if args.unit_calibration else "")
                  + "):")
            print(format_verdict(outcome.summary["fdi"]))
            print(f"  figure: {outcome.summary.get('figure')}")
    if not outcome.ok:
        where = f" (node logs: {outcome.log_dir})" if outcome.log_dir and outcome.log_dir.exists() else ""
        print(f"rw-fdi: run failed: {outcome.reason}{where}", file=sys.stderr)
        return 1
    rtf = outcome.summary["end_time"] / outcome.wall_time if outcome.summary else float("nan")
    print(f"  wall time {outcome.wall_time:.1f} s ({rtf:.0f}x real time)")
    return 0


def _cmd_campaign(args) -> int:
    from .tools.campaigns.campaign import run_campaign
    writable_dir(args.out, "--out")
    res = run_campaign(args.scenario, args.runs, args.seed_start, args.out, fdi=args.fdi,
                       executor=_executor(args), engine=args.engine)
    print(f"campaign {args.scenario}: {len(res.done)} recorded, {len(res.skipped)} already complete, "
          f"{len(res.failed)} failed" + (f", {len(res.retried)} started over" if res.retried else "")
          + f" -> {args.out}")
    for seed, reason in res.retried:
        print(f"  seed {seed} started over after: {reason}", file=sys.stderr)
    for seed, reason in res.failed:
        print(f"  seed {seed}: {reason}", file=sys.stderr)
    return 1 if res.failed else 0


def _executor(args):
    from .tools.campaigns.campaign import make_executor
    return make_executor(getattr(args, "jobs", None), getattr(args, "scheduler", None))


def _cmd_evaluate(args) -> int:
    writable_dir(args.report, "--report")   # a file in the way is said before any bag is read
    from .tools.evaluation.evaluate import evaluate, main_summary
    report = evaluate(args.bags, args.report, models=args.models, thresholds=args.thresholds,
                      persistence=args.persistence, executor=_executor(args), unit_calibration=args.unit_calibration,
                      engine=args.engine)
    print(main_summary(report))
    print(f"report: {args.report}/report.md, {args.report}/report.json")
    return 0 if report["runs"] else 1


def _cmd_reproduce(args) -> int:
    import time
    from .tools.evaluation.reproduce import reproduce
    t0 = time.monotonic()
    report = reproduce(args.out, args.scale, executor=_executor(args), persistence=args.persistence,
                       engine=args.engine, graph_sample=args.graph_sample)
    print(f"reproduce ({args.scale}) done in {time.monotonic() - t0:.0f} s wall: {report['runs']} runs evaluated; "
          f"report {args.out}/report/report.md")
    return 0


def _fault_free_samples(bags, load_samples) -> list:
    """FDI samples of the fault-free bags under ``bags`` recorded under one plant (what trains and fits): each
    bag skipped said by name, their count, and an error where none is left."""
    from .tools.design.offline import under_one_plant
    skipped = []
    samples = under_one_plant(load_samples(bags, on_skip=skipped.append, fault_free=True), skipped.append)
    for reason in skipped:
        print(f"skipped: {reason}", file=sys.stderr)
    if skipped:
        print(f"skipped {len(skipped)} of {len(skipped) + len(samples)} bags", file=sys.stderr)
    if not samples:
        raise ValueError(f"--bags {bags}: no fault-free bag to learn from")
    return samples


def _cmd_train(args) -> int:
    from .tools.design.offline import plant_conditions
    from .tools.design.samples import load_samples
    from .tools.design.train import EPOCHS, THESIS_EPOCHS, train_models
    samples = _fault_free_samples(args.bags, load_samples)
    if args.runs:
        samples = samples[:args.runs]
    speed_aware = args.fdi_method == "speed_aware"
    epochs = args.epochs or (EPOCHS if speed_aware else THESIS_EPOCHS)
    card = train_models(samples, args.out, mode=args.mode, epochs=epochs, plant=plant_conditions(samples),
                        speed_aware=speed_aware)
    print(f"trained 3 Elman networks ({args.mode} mode) on {len(samples)} runs in {card['train_seconds']:.0f} s "
          f"-> {args.out}")
    for a, c in card["axes"].items():
        print(f"  {a}: final MSE {c['final_loss']:.2e} (normalised), torque scale {c['torque_scale']:.4f} N m")
    return 0


def _cmd_fit(args) -> int:
    # the options first: a bad one answers at once, before torch loads
    if not 0.0 < args.false_alarm_rate < 1.0:
        raise ValueError(f"--false-alarm-rate must lie in (0, 1), got {args.false_alarm_rate}")
    if (args.bags is None) == (args.simulate is None):
        raise ValueError("give either --bags DIR or --simulate SCENARIO --seeds A..B")
    seeds = parse_seeds(args.seeds, "--seeds") if args.simulate else None
    from .tools.design.offline import fdi_method_of, fit_thresholds, load_models
    from .tools.design.samples import load_samples
    from .paths import config_dir, shown_path
    import time
    models_dir = args.models or str(config_dir() / "fdi")
    models = load_models(models_dir)
    t0 = time.monotonic()
    plant = None
    if args.simulate:
        samples, plant = _simulated_fitting_runs(args.simulate, seeds)
    else:
        samples = _fault_free_samples(args.bags, load_samples)
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


def _simulated_fitting_runs(ref: str, seeds) -> tuple:
    """FDI samples of fault-free runs of scenario ``ref`` over ``seeds`` by the core loop (screen), and
    the plant choices they were made under."""
    from tqdm import tqdm
    from .core.plant_choices import PlantChoices
    from .core.scenario import load_scenario
    from .tools.evaluation.screen import simulated_runs
    scenario = load_scenario(ref)
    if scenario.faults:
        raise ValueError(f"--simulate {ref}: thresholds are fitted on fault-free runs, this scenario has faults")
    with tqdm(total=len(seeds), desc="fitting runs (core loop)", unit="run", file=sys.stderr) as bar:
        samples = [s for _, s, _ in simulated_runs([scenario.with_seed(k) for k in seeds], progress=bar.update)]
    # what a bag of such a run would record: the same choices the recorded runs' fitting gets
    plant = PlantChoices.of_recording(scenario.plant_choices().scenario_dict()).as_dict()
    return samples, plant


def _cmd_defaults(args) -> int:
    from .tools.design.defaults import format_report, regenerate_defaults
    from .paths import config_dir
    report = regenerate_defaults(work=args.work, out=args.out or config_dir() / "fdi", fit_runs=args.fit_runs,
                                 heldout_runs=args.heldout_runs, train_runs=args.train_runs,
                                 **({"epochs": args.epochs} if args.epochs else {}),
                                 executor=_executor(args), false_alarm_rate=args.false_alarm_rate)
    print(format_report(report))
    return 0


def parse_seeds(text: str, option: str) -> range:
    """'A..B' (inclusive) or 'A' -> range; a one-line ValueError naming the option otherwise."""
    first, sep, last = text.partition("..")
    try:
        a, b = int(first), int(last if sep else first)
    except ValueError:
        raise ValueError(f"{option} must be A..B or A with whole numbers, got {text!r}") from None
    if b < a:
        raise ValueError(f"{option} {text}: the last seed is below the first")
    if a < 0 or b > SEED_MAX:
        raise ValueError(f"{option} {text}: seeds are whole numbers in [0, {SEED_MAX}]")
    if b - a + 1 > SEEDS_MAX:
        raise ValueError(f"{option} {text}: {b - a + 1:,} runs; one command takes at most {SEEDS_MAX:,} (split the "
                         "range)")
    return range(a, b + 1)


def _cmd_screen(args) -> int:
    seeds = parse_seeds(args.seeds, "--seeds")   # before the imports: a bad option answers at once
    from .core.scenario import load_scenario
    from .tools.evaluation.screen import format_screen, screen
    from .tools.campaigns.fdi import check_fdi_files
    for name in args.scenario:
        if args.unit_calibration:
            check_fdi_files(args.models, args.thresholds, None, args.fdi_method, args.unit_calibration,
                            load_scenario(name).duration)
        print(format_screen(name, screen(load_scenario(name), seeds, args.models, args.thresholds,
                                         args.persistence, args.fdi_method, args.unit_calibration)))
    return 0


def _cmd_scenarios(args) -> int:
    from .core.scenario import available_scenarios, load_scenario
    for name in available_scenarios():
        s = load_scenario(name)
        print(f"{name:28s} {s.duration:6.0f} s  {s.description}")
    return 0


def _cmd_bench(args) -> int:
    from .tools.benches.bench import bench_fdi, bench_graph, bench_study
    if args.what == "study":
        report = bench_study(runs=args.runs, duration=args.duration, seed=args.seed, jobs=args.jobs)
    elif args.what == "detection":
        from .tools.benches.detection_bench import bench_detection
        report = bench_detection(fault_free_runs=args.fault_free_runs, runs_per_cell=args.runs_per_cell or 200,
                                 out=args.out or "reports/detection")
    elif args.what == "memory":
        from .tools.benches.memory_bench import bench_memory
        try:
            hours = tuple(float(h) for h in args.hours.split(","))
        except ValueError:
            raise ValueError(f"--hours: expected numbers like 1,6, got {args.hours!r}") from None
        if not all(0 < h <= 48 for h in hours):
            raise ValueError(f"--hours: each length must be in (0, 48] hours, got {args.hours!r}")
        report = bench_memory(hours, seed=args.seed, out=args.out or "reports/memory")
    elif args.what == "units":
        from .tools.benches.units_bench import bench_units
        report = bench_units(fault_free_runs=args.fault_free_runs, runs_per_cell=args.runs_per_cell or 200,
                             out=args.out or "reports/units")
    elif args.what == "operations":
        from .tools.benches.operations_bench import bench_operations
        report = bench_operations(fault_free_runs=args.fault_free_runs, runs_per_cell=args.runs_per_cell or 200,
                                  hours_runs=args.hours_runs, seeds=args.seed_set, out=args.out or "reports/operations")
    elif args.what == "dumping":
        from .tools.benches.dumping_bench import bench_dumping
        report = bench_dumping(hours=args.day_hours, seed=args.seed if args.seed is not None else 1,
                               operations_runs=args.orbit_runs, runs_per_cell=args.runs_per_cell or 100,
                               out=args.out or "reports/dumping")
    elif args.what == "recovery":
        from .tools.benches.recovery_bench import CELLS, bench_recovery
        runs = args.runs_per_cell or 100
        total = sum(args.fault_free_runs if c.kind is None else runs for c in CELLS)
        from tqdm import tqdm
        with tqdm(total=total, desc="recovery bench (core loop)", unit="run", file=sys.stderr) as bar:
            report = bench_recovery(runs_per_cell=runs, fault_free_runs=args.fault_free_runs, seeds=args.seed_set,
                                    out=args.out or "reports/recovery", progress=bar.update)
    elif args.what == "service":
        from .tools.benches.service_bench import bench_service
        from tqdm import tqdm
        with tqdm(total=args.service_runs + args.fault_free_runs, desc="service bench (core loop)", unit="run",
                  file=sys.stderr) as bar:
            report = bench_service(runs=args.service_runs, seeds=args.seed_set, out=args.out or "reports/service",
                                   jobs=args.jobs or 2, progress=bar.update, max_hours=args.max_hours,
                                   fault_free_runs=args.fault_free_runs)
    elif args.what == "figures":
        from .tools.benches.figures_check import check_figures
        def said(name, lines):   # each bench's figures as soon as they are in: the whole takes minutes
            print(f"figures: re-measuring {name} ..." if lines is None else "\n".join(
                f"figures: {x['figure']}: {x['small']} (record {x['record']})"
                + ("  << OUTSIDE" if x["flagged"] else "") for x in lines), file=sys.stderr, flush=True)
        report = check_figures(benches=args.only.split(",") if args.only else None, progress=said)
    elif args.what == "identification":
        from .tools.benches.identification_bench import bench_identification
        default_out = "reports/identification_units" if args.units else "reports/identification"
        report = bench_identification(runs_per_cell=args.runs_per_cell or (200 if args.units else 100),
                                      out=args.out or default_out, units=args.units,
                                      **({"thesis_runs": args.thesis_runs,
                                          "bus_thesis_runs": args.thesis_runs * 17 // 10}
                                         if args.thesis_runs else {}))
    else:
        report = (bench_graph if args.what == "graph" else bench_fdi)(duration=args.duration, seed=args.seed)
    print(json.dumps({k: v for k, v in report.items() if k != "text"}, indent=2) if args.json else report["text"])
    return 0 if report["ok"] else 1


def _cmd_bag(args) -> int:
    """Topics, counts and spans of a bag, its run summary and, where it holds FDI outputs, the FDI
    verdict: each a stream over the file, so memory does not grow with the run's length."""
    from .graph import topics as T
    from .storage.bag import bag_info, read_series
    from .tools.campaigns.summary import format_summary, run_summary
    info = bag_info(args.bag)
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
        from .tools.campaigns.fdi import fdi_verdict, format_verdict, plot_residuals, verdict_topics
        from .tools.bag_series import health_from_bag
        data = read_series(args.bag, verdict_topics())
        verdict = {**fdi_verdict(data), "health": health_from_bag(args.bag)}
        print(f"fault detection and isolation:\n{format_verdict(verdict)}")
        if args.figure:
            print(f"  figure: {plot_residuals(data, Path(args.figure))}")
    return 1 if info.damaged else 0


def number(kind=float, low=None, high=None, low_open=False):
    """An argparse type: ``kind`` (int or float), finite, within [low, high] (``low_open``: > low).
    argparse turns its ValueError into one line naming the option, before anything starts."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}")
        if kind is float and not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        below = low is not None and (value <= low if low_open else value < low)
        if below or (high is not None and value > high):
            bounds = ([f"{'>' if low_open else '>='} {low}"] if low is not None else []) + \
                ([f"<= {high}"] if high is not None else [])
            raise argparse.ArgumentTypeError(f"{text} is out of range: must be {' and '.join(bounds)}")
        return value
    parse.__name__ = kind.__name__   # argparse names the type in its message
    return parse


COUNT = number(int, 1)            # runs, jobs, epochs: at least one
SEED_MAX = 2**63 - 1              # numpy's seeds: non-negative
SEED = number(int, 0, SEED_MAX)
SEEDS_MAX = 1_000_000             # runs of one seed range: days on one machine already


def build_parser() -> argparse.ArgumentParser:
    from .core.detection import FALSE_ALARM_RATE, METHODS, PERSISTENCE_MAX
    p = argparse.ArgumentParser(prog="rw-fdi", description="Reaction-wheel FDI on a ROS 2 node graph.")
    sub = p.add_subparsers(dest="command", required=True)
    # options several commands share, each defined once (argparse parents)
    models = argparse.ArgumentParser(add_help=False)
    models.add_argument("--models", default=None, help="Elman model directory (default: config/fdi)")
    persistence = argparse.ArgumentParser(add_help=False)
    persistence.add_argument("--persistence", type=number(int, 1, PERSISTENCE_MAX), default=None,
                             help="samples above the threshold before an alarm (P; default: the threshold file's; "
                                  "fit-thresholds fits for 3 speed_aware, 5 thesis and writes it in the file)")
    fdi_files = argparse.ArgumentParser(add_help=False, parents=[models, persistence])
    fdi_files.add_argument("--thresholds", default=None, help="threshold directory (default: config/fdi)")
    false_alarms = argparse.ArgumentParser(add_help=False)
    false_alarms.add_argument("--false-alarm-rate", type=number(float, 0, 1, low_open=True),
                              default=FALSE_ALARM_RATE,
                              help="designed per-run false-alarm probability (speed_aware; default %(default)g)")
    unit = argparse.ArgumentParser(add_help=False)
    unit.add_argument("--unit-calibration", type=number(float, 0), default=0.0, metavar="SECONDS",
                      help="the observers learn each wheel's own unit from the first SECONDS of a run, assumed "
                           "healthy (core/calibration.py; speed_aware only; default 0: the datasheet wheel; "
                           "shipped thresholds for 150)")
    method = argparse.ArgumentParser(add_help=False)
    method.add_argument("--fdi-method", default="speed_aware", choices=list(METHODS),
                        help="speed_aware (ours: wheel speed, signed residual, designed false-alarm rate) or "
                             "thesis (2-input Elman, |r - r^|, mean + 3 sigma curves); without --models it "
                             "picks config/fdi or config/fdi/thesis")
    jobs = argparse.ArgumentParser(add_help=False)
    jobs.add_argument("--jobs", type=COUNT, default=None, help="graphs at once (default: 2 on 2 cores)")
    cluster = argparse.ArgumentParser(add_help=False, parents=[jobs])
    cluster.add_argument("--scheduler", default=None, help="dask.distributed scheduler address: run on that cluster")

    r = sub.add_parser("run", help="run one scenario through the whole graph and record a bag",
                       parents=[fdi_files, method, unit])
    r.add_argument("--scenario", required=True, help="scenario name (see `rw-fdi scenarios`) or YAML file")
    r.add_argument("--seed", type=SEED, default=None, help="seed for initial conditions and disturbance")
    r.add_argument("--out", default="bags", help="directory for the bag (default: bags/)")
    r.add_argument("--emf-limit", default=None, choices=["kf_scaled", "pwm_saturation"],
                   help="EMF torque-limiting model (physics.md [choice]; default: the scenario's, else kf_scaled)")
    r.add_argument("--command-timeout", type=number(float, 0, low_open=True), default=5.0,
                   help="wall seconds the plant waits for a command")
    r.add_argument("--keep-logs", action="store_true", help="keep node logs also after a successful run")
    r.add_argument("--no-fdi", dest="fdi", action="store_false",
                   help="without the observers and isolation (plant, controllers, wheel allocation, recorder only)")
    r.add_argument("--no-fdir", dest="fdir", action="store_false",
                   help="detect, isolate and identify, but keep commanding every wheel in use (no reconfiguration: "
                        "the FDI alone, as before the redundant wheel)")
    r.set_defaults(func=_cmd_run)

    c = sub.add_parser("campaign", help="record N runs of a scenario (seeds S..S+N-1), resumable",
                       parents=[cluster])
    c.add_argument("--scenario", required=True, help="scenario name or YAML file")
    c.add_argument("--runs", type=COUNT, required=True)
    c.add_argument("--seed-start", type=SEED, default=1)
    c.add_argument("--out", required=True, help="directory for the bags")
    c.add_argument("--fdi", action="store_true", help="run the observers and isolation live too (graph engine)")
    c.add_argument("--engine", default="graph", choices=["graph", "core"],
                   help="graph: the ROS graph records each run (the reference); core: the node code on the batched "
                        "core loop writes the same bags, ~10x faster (docs/evaluation.md \"Engines\")")
    c.set_defaults(func=_cmd_campaign)

    t = sub.add_parser("train", help="train the three Elman observers from fault-free bags (torch)",
                       parents=[method])
    t.add_argument("--bags", required=True, help="directory of fault-free bags")
    t.add_argument("--out", required=True, help="model directory to write (elman_<axis>.npz + cards)")
    t.add_argument("--mode", default="recall", choices=["recall", "teacher"],
                   help="recall: trained on its own feedback (ours); teacher: delayed measured torque (thesis)")
    t.add_argument("--runs", type=COUNT, default=None, help="use only the first N bags (thesis: 1)")
    t.add_argument("--epochs", type=COUNT, default=None,
                   help="default: 1000 speed_aware, 300 thesis (tools/train.EPOCHS)")
    t.set_defaults(func=_cmd_train)

    f = sub.add_parser("fit-thresholds", help="fit the thresholds of the observers from fault-free bags "
                                              "(speed_aware models: bands for a designed false-alarm rate; "
                                              "thesis models: mean + 3 sigma curves)",
                       parents=[models, false_alarms, persistence, unit])
    f.add_argument("--bags", default=None, help="directory of fault-free bags")
    f.add_argument("--simulate", default=None, metavar="SCENARIO",
                   help="instead of bags: fault-free runs of SCENARIO by the core loop (rw-fdi screen's, the "
                        "graph's numbers) over --seeds")
    f.add_argument("--seeds", default="60000000..60000299", help="with --simulate: A..B inclusive "
                                                                 "(default %(default)s, disjoint from every bench)")
    f.add_argument("--out", required=True)
    f.set_defaults(func=_cmd_fit)

    d = sub.add_parser("defaults", help="regenerate the shipped models and threshold curves from nothing",
                       parents=[jobs, false_alarms])
    d.add_argument("--work", default="bags/defaults", help="where the campaigns' bags go (resumable)")
    d.add_argument("--out", default=None, help="default: config/fdi")
    d.add_argument("--fit-runs", type=COUNT, default=100)
    d.add_argument("--heldout-runs", type=COUNT, default=20)
    d.add_argument("--train-runs", type=COUNT, default=40)
    d.add_argument("--epochs", type=COUNT, default=None, help="speed-aware set (default 1000; the thesis set: 300)")
    d.set_defaults(func=_cmd_defaults)

    e = sub.add_parser("evaluate", help="replay bags through the observers and isolation; write the report",
                       parents=[fdi_files, cluster, unit])
    e.add_argument("--bags", required=True, help="directory of bags (searched recursively)")
    e.add_argument("--report", required=True, help="directory for report.md, report.json, plots, replays")
    e.add_argument("--engine", default="graph", choices=["graph", "core"],
                   help="graph: replay every bag through the FDI graph (the reference); core: the observer and "
                        "isolation nodes' code on each bag's recorded telemetry, no replay (the same report)")
    e.set_defaults(func=_cmd_evaluate)

    p2 = sub.add_parser("reproduce", help="the whole thesis study from nothing (resumable)",
                        parents=[cluster, persistence])
    p2.add_argument("--out", required=True)
    p2.add_argument("--scale", default="small", choices=["small", "thesis"])
    p2.add_argument("--engine", default="core", choices=["core", "graph"],
                    help="core (default): the node code on the core loop records and judges every run, and a "
                         "sample goes through the graph as reference; graph: every run through the graph")
    p2.add_argument("--graph-sample", type=number(int, 0), default=1, metavar="N",
                    help="with the core engine: runs per group recorded and replayed through the graph as well, "
                         "and compared (default 1; 0: none)")
    p2.set_defaults(func=_cmd_reproduce)

    q = sub.add_parser("screen", help="FDI figures for many seeds in seconds (core loop + node code, no ROS)",
                       parents=[fdi_files, method, unit])
    q.add_argument("--scenario", nargs="+", required=True)
    q.add_argument("--seeds", default="100..129", help="A..B inclusive")
    q.set_defaults(func=_cmd_screen)

    s = sub.add_parser("scenarios", help="list the shipped scenarios")
    s.set_defaults(func=_cmd_scenarios)

    b = sub.add_parser("bench", help="benchmarks that print figures")
    b.add_argument("what", choices=["graph", "fdi", "study", "detection", "identification", "units", "memory",
                                    "operations", "recovery", "dumping", "service", "figures"],
                   help="graph: real-time factor of a recorded fault-free run; fdi: observer step times, "
                        "node callback times and memory; study: record and replay throughput and the "
                        "thesis-scale reproduce time they give; detection: false-alarm and detection rates "
                        "with 95 %% intervals on >= 1000 held-out runs, both FDI methods (core loop); "
                        "identification: fault kind and size per kind and size, confusion matrix (core loop); "
                        "units: the same cells on wheels drawn around the datasheet and on the datasheet wheel, "
                        "with and without unit calibration (core loop); memory: peak memory of the run summary, "
                        "`rw-fdi bag` and evaluation for fault-free runs of --hours (recorded, minutes); operations: "
                        "every observer and the /diagnostics verdict in operations (manoeuvres at random times, "
                        "hours-long runs, faults a manoeuvre follows, bus drops that tumble an axis; core loop); "
                        "recovery: the redundant wheel taking over from a wheel the FDI confirmed faulty (pointing "
                        "back within 0.2 deg, peak error, time to recover; FDI and FDIR in the core loop); dumping: "
                        "a day in orbit with the magnetorquers dumping and with them off (wheel speed band, "
                        "pointing, when the wheels saturate; a plot), the FDI through hours of dumping and faults "
                        "during a dump (core loop); service: FDIR in service, every capability at once (units "
                        "and datasheet wheels, manoeuvres before and after faults of every kind, size, wheel, "
                        "onset and ramp, second faults, orbit with dumping, 600 s to 6 h; reconfigurations "
                        "without a fault, the right wheel acted on, pointing kept, identification; core loop); "
                        "figures: every figure of the README's table re-measured at small n (about 12 min), "
                        "printed beside the README's and the record's, flagged where the two disagree beyond chance")
    b.add_argument("--service-runs", type=COUNT, default=1000,
                   help="service: in-service runs, each drawn from its seed (default 1000)")
    b.add_argument("--max-hours", type=number(float, 0, 6, low_open=True), default=None,
                   help="service: shorten the runs drawn longer than this to it [h] (default: none, up to 6 h)")
    b.add_argument("--day-hours", type=number(float, 0, 240, low_open=True), default=24.0,
                   help="dumping: the length of the day in orbit [h] (default 24)")
    b.add_argument("--orbit-runs", type=COUNT, default=20,
                   help="dumping: 6-hour runs of operations in orbit with dumping (default 20: 120 simulated hours)")
    b.add_argument("--hours", default="1,6", help="memory: run lengths in hours, comma-separated (default 1,6)")
    b.add_argument("--fault-free-runs", type=COUNT, default=1000,
                   help="detection, units: fault-free runs; service: fault-free 600-s runs of the family "
                        "(default 1000)")
    b.add_argument("--runs-per-cell", type=COUNT, default=None,
                   help="detection: runs per fault or ripple case (default 200); identification: per grid size "
                        "(default 100); recovery: per fault case (default 100)")
    b.add_argument("--units", action="store_true",
                   help="identification: on varied wheels, calibrated 150 s, sizes drawn over ranges (default "
                        "200 runs per kind, the bus 340; reports/identification_units)")
    b.add_argument("--thesis-runs", type=COUNT, default=None,
                   help="identification: runs per thesis size (default 200; the bus 340, as 6 in 10 are observable)")
    b.add_argument("--out", default=None, help="detection / identification / units / memory: report directory "
                                                "(default reports/<what>)")
    b.add_argument("--hours-runs", type=COUNT, default=50,
                   help="operations: 2-hour runs of continuous operations (default 50: 100 simulated hours)")
    b.add_argument("--seed-set", default="evaluation", choices=["evaluation", "tuning"],
                   help="operations, recovery, service: the seeds of record (default) or the ones the design "
                        "was chosen on")
    b.add_argument("--runs", type=COUNT, default=8, help="study: runs to record and replay")
    b.add_argument("--jobs", type=COUNT, default=None, help="study, service: processes at a time (default: 2)")
    b.add_argument("--duration", type=number(float, 0, low_open=True), default=400.0)
    b.add_argument("--seed", type=SEED, default=1)
    b.add_argument("--only", default=None,
                   help="figures: the benches to re-measure, comma-separated (detection, operations, "
                        "identification_units, recovery, service, dumping, reproduce, graph, study; default all)")
    b.add_argument("--json", action="store_true")
    b.set_defaults(func=_cmd_bench)

    g = sub.add_parser("bag", help="what a bag holds (also a truncated one), its run summary and FDI verdict; "
                       "read as a stream (memory does not grow with the run)")
    g.add_argument("bag")
    g.add_argument("--figure", default=None, metavar="PNG", help="also draw the residuals against the thresholds")
    g.set_defaults(func=_cmd_bag)
    return p


def _terminate(signum, frame):
    # SIGTERM (a CI job cancelled, `kill`) ends a run as Ctrl-C does: nodes stopped, the bag closed
    # complete, a non-zero exit; Python's default would die at once and orphan the nodes
    raise KeyboardInterrupt


def main(argv=None) -> int:
    import signal
    args = build_parser().parse_args(argv)
    signal.signal(signal.SIGTERM, _terminate)
    from .core.scenario import ScenarioError
    from .storage.bag import BagError
    try:
        code = args.func(args)
        sys.stdout.flush()   # a closed pipe shows here, not at interpreter exit
        return code
    except (ScenarioError, BagError, FileNotFoundError, ValueError, RuntimeError) as exc:
        print(f"rw-fdi: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
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


if __name__ == "__main__":
    sys.exit(main())
