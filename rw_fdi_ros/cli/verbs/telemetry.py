"""`rw-fdi telemetry`: anyone's wheel telemetry (CSV or Parquet) checked and judged by the FDI the nodes run."""
NAME = "telemetry"
HELP = ("a telemetry table of any wheels (CSV or Parquet: time, <joint>.speed, <joint>.command, optional torque and "
        "ground truth, units in the header) checked, then judged by the vehicle's FDI (docs/telemetry.md)")
PARENTS = ("fdi_files", "decision", "false_alarms")   # --false-alarm-rate: with --fit, per segment


def add_arguments(parser) -> None:
    from ..options import number
    parser.add_argument("table", help="the table: 'time [s]', '<joint>.speed [rad/s|rpm]', '<joint>.command [V]', "
                                      "optionally '<joint>.torque [N m|mN m]' and '<joint>.fault [1]'")
    parser.add_argument("--vehicle", default=None, metavar="NAME|DIR|FILE",
                        help="the spacecraft whose wheels these are: a shipped name, a vehicle file or its FDI "
                             "directory (default: the thesis' MakSat)")
    parser.add_argument("--joints", default=None, metavar="A,B,...",
                        help="the table's joint names in the vehicle's wheel set's order (default: the table's order)")
    parser.add_argument("--max-gap", type=number(float, 0, low_open=True), default=2.5, metavar="SECONDS",
                        help="speed reports further apart leave the FDI periods between them not judged (default "
                             "%(default)g)")
    parser.add_argument("--check", action="store_true", help="only check the table: rates, gaps, missing channels")
    parser.add_argument("--fit", default=None, metavar="DIR",
                        help="the table is healthy: fit the bands on it into DIR (then judge with --thresholds DIR); "
                             "refused, with what it needs, on too little of it")
    parser.add_argument("--segment", type=number(int, 50), default=400, metavar="SECONDS",
                        help="with --fit: the length of a fitting run (default %(default)g, the shipped bands')")
    parser.add_argument("--out", default=None, metavar="DIR",
                        help="write telemetry.json, telemetry_samples.csv (one row per FDI sample and wheel) and "
                             "telemetry.png (residuals against their bands) there")


def main(args) -> int:
    from ..options import fdi_config
    from ...core.mission.vehicle import load_vehicle
    from ...tools.evaluation.telemetry_file import check, format_check, format_verdict, judge, read_table, write_files
    joints = [j.strip() for j in args.joints.split(",")] if args.joints else None
    vehicle = load_vehicle(args.vehicle)   # one line naming the field, before the table is read
    table = read_table(args.table, joints)
    checked = check(table, vehicle.wheel, max_gap=args.max_gap)
    print(format_check(table, checked))
    if args.check:
        return 0 if not checked["problems"] else 1
    fdi = fdi_config(args)
    if args.fit:
        from ...tools.evaluation.telemetry_file import fit
        bands = fit(table, args.fit, args.vehicle, fdi, args.false_alarm_rate, args.segment, max_gap=args.max_gap)
        print(f"bands fitted on {bands.pop('segments')} segments of {args.segment:g} s, written to {args.fit}:")
        for observer, by_wheel in bands.items():
            print(f"  {observer}: " + ", ".join(f"{a} {c * 1e3:.4g} mN m" for a, c in by_wheel.items()))
        return 0
    if args.vehicle and not (args.models or args.thresholds) and _is_fdi_dir(args.vehicle):
        from dataclasses import replace
        fdi = replace(fdi, models=args.vehicle)   # a vehicle's FDI directory judges with its own FDI
    verdict = judge(table, args.vehicle, fdi, max_gap=args.max_gap)
    print(format_verdict(verdict))
    if args.out:
        for path in write_files(verdict, args.out):
            print(f"wrote {path}")
    return 0


def _is_fdi_dir(vehicle: str) -> bool:
    from pathlib import Path
    return Path(vehicle).is_dir()
