"""`rw-fdi vehicle`: the shipped vehicles, or one vehicle file checked and summarised (core/vehicle.py)."""
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
    from ...core.vehicle import load_vehicle, shipped_vehicles, summary, to_mapping
    if args.vehicle is None:
        for name in shipped_vehicles():
            vehicle = load_vehicle(name)
            print(f"{name:14s} {vehicle.wheel_set.count} wheels, {vehicle.wheel_type}: {vehicle.description}")
        return 0
    vehicle = load_vehicle(args.vehicle)
    print(yaml.safe_dump(to_mapping(vehicle), sort_keys=False) if args.yaml else summary(vehicle))
    return 0
