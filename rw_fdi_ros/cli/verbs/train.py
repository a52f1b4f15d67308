"""`rw-fdi train`: the three Elman observers trained on fault-free bags (torch)."""
from ..options import COUNT, fault_free_samples

NAME = "train"
HELP = "train the three Elman observers from fault-free bags (torch)"
PARENTS = ("method",)


def add_arguments(parser) -> None:
    parser.add_argument("--bags", required=True, help="directory of fault-free bags")
    parser.add_argument("--out", required=True, help="model directory to write (elman_<axis>.npz + cards)")
    parser.add_argument("--mode", default="recall", choices=["recall", "teacher"],
                        help="recall: trained on its own feedback (ours); teacher: delayed measured torque (thesis)")
    parser.add_argument("--runs", type=COUNT, default=None, help="use only the first N bags (thesis: 1)")
    parser.add_argument("--epochs", type=COUNT, default=None,
                        help="default: 1000 speed_aware, 300 thesis (tools/train.EPOCHS)")


def main(args) -> int:
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
