"""`rw-fdi train`: the Elman observers trained on fault-free bags (torch), or a user's observers (their train hook)."""
from ..options import COUNT, executor, fault_free_samples, parse_seeds

NAME = "train"
HELP = "train the Elman observers from fault-free bags (torch), or with --observer a user's observer"
PARENTS = ("method", "observers", "cluster")
TRAIN_SEEDS = "61000000..61000099"   # --simulate's default: disjoint from fit-thresholds' and every bench's


def add_arguments(parser) -> None:
    parser.add_argument("--bags", default=None, help="directory of fault-free bags")
    parser.add_argument("--simulate", default=None, metavar="SCENARIO",
                        help="with --observer, instead of bags: fault-free runs of SCENARIO by the core loop over "
                             "--seeds")
    parser.add_argument("--seeds", default=TRAIN_SEEDS, help="with --simulate: A..B inclusive (default %(default)s)")
    parser.add_argument("--out", required=True, help="model directory to write (elman_<axis>.npz + cards)")
    parser.add_argument("--mode", default="recall", choices=["recall", "teacher"],
                        help="recall: trained on its own feedback (ours); teacher: delayed measured torque (thesis)")
    parser.add_argument("--runs", type=COUNT, default=None, help="use only the first N bags (thesis: 1)")
    parser.add_argument("--epochs", type=COUNT, default=None,
                        help="default: 1000 speed_aware, 300 thesis (tools/train.EPOCHS)")


def main(args) -> int:
    if (args.bags is None) == (args.simulate is None):
        raise ValueError("give either --bags DIR or (with --observer) --simulate SCENARIO --seeds A..B")
    if args.simulate and not args.plugins:
        raise ValueError("--simulate trains a user's observer (--observer); the Elman networks train on --bags "
                         "(or all of the FDI at once: rw-fdi defaults)")
    seeds = parse_seeds(args.seeds, "--seeds") if args.simulate else None
    if args.plugins:
        return _train_plugins(args, seeds)
    from ...tools.design.offline import plant_conditions
    from ...tools.design.samples import load_samples
    from ...tools.design.train import EPOCHS, THESIS_EPOCHS, train_models
    samples = fault_free_samples(args.bags, load_samples)
    if args.runs:
        samples = samples[:args.runs]
    speed_aware = args.fdi_method == "speed_aware"
    epochs = args.epochs or (EPOCHS if speed_aware else THESIS_EPOCHS)
    card = train_models(samples, args.out, mode=args.mode, epochs=epochs, plant=plant_conditions(samples),
                        speed_aware=speed_aware)
    print(f"trained {len(card['wheels'])} Elman networks ({', '.join(card['wheels'])}; {args.mode} mode) on "
          f"{len(samples)} runs in {card['train_seconds']:.0f} s -> {args.out}")
    for a, c in card["axes"].items():
        print(f"  {a}: final MSE {c['final_loss']:.2e} (normalised), torque scale {c['torque_scale']:.4f} N m")
    return 0


def _train_plugins(args, seeds) -> int:
    """Each --observer's train hook on the fault-free runs; its state -> --out/observer_<slot>.json."""
    import time
    from ...core.fdi.observer_plugin import load_observer, save_state, trains
    from ...core.mission.plant_choices import FDI_PERIOD
    from ...tools.design.samples import load_samples, simulated_fault_free_runs
    classes = [load_observer(spec) for spec in args.plugins]   # a bad spec answers before any run
    pool = executor(args)
    samples = (simulated_fault_free_runs(args.simulate, seeds, pool, desc="training runs (core loop)")[0]
               if args.simulate else fault_free_samples(args.bags, load_samples, pool))
    if args.runs:
        samples = samples[:args.runs]
    for spec, cls in zip(args.plugins, classes):
        if not trains(cls):
            print(f"  {cls.slot}: nothing to train (no train hook)")
            continue
        t0 = time.monotonic()
        state = cls.train(samples, tuple(samples[0].wheels), FDI_PERIOD)
        path = save_state(args.out, cls, spec, state or {}, [s.seed for s in samples])
        print(f"  {cls.slot}: trained on {len(samples)} runs in {time.monotonic() - t0:.1f} s -> {path}")
    return 0
