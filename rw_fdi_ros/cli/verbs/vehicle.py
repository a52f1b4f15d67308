"""`rw-fdi vehicle`: the shipped vehicles, or one vehicle file checked and summarised (core/mission/vehicle.py)."""
NAME = "vehicle"
HELP = ("the shipped vehicles; with a name or a vehicle file, that vehicle checked (one line naming the field "
        "when it is wrong or cannot fly) and summarised")
PARENTS = ()


def add_arguments(parser) -> None:
    parser.add_argument("vehicle", nargs="?", default=None,
                        help="a shipped vehicle's name or a vehicle file (YAML, docs/vehicles.md); none: list them")
    parser.add_argument("--yaml", action="store_true",
                        help="print the vehicle as its file reads back (every value with its unit): what a bag records")


def main(args) -> int:
    import yaml
    from ...core.mission.vehicle import load_vehicle, shipped_vehicles, summary, to_mapping
    if args.vehicle is None:
        names = shipped_vehicles()
        width = max(map(len, names), default=0)
        for name in names:
            vehicle = load_vehicle(name)
            print(f"{name:{width}s}  {vehicle.wheel_set.count} wheels, {vehicle.wheel_type}: {vehicle.description}")
        return 0
    from ...core.controller_design import design_controller
    vehicle = load_vehicle(args.vehicle)
    if args.yaml:
        print(yaml.safe_dump(to_mapping(vehicle), sort_keys=False))
        return 0
    print(summary(vehicle))
    design = design_controller(vehicle)   # its targets met, or the reason it cannot fly
    t = vehicle.controller
    print(f"  controllers: w_n {', '.join(f'{w:g}' for w in design.natural_frequency)} rad/s; the largest step "
          f"settles in {', '.join(f'{s:.0f}' for s in design.settling_time)} s (target {t.settling_time:g}), "
          f"overshoot {', '.join(f'{o:.0%}' for o in design.overshoot)} (target {t.overshoot:.0%})")
    return 0
