"""`rw-fdi telemetry`: anyone's wheel telemetry (CSV or Parquet) checked and judged by the FDI the nodes run."""
NAME = "telemetry"
HELP = ("a telemetry table of any wheels (CSV or Parquet: time, <joint>.speed, <joint>.command, optional torque and "
        "ground truth, units in the header) checked, then judged by the vehicle's FDI (docs/telemetry.md)")
PARENTS = ("fdi_files", "unit", "decision", "false_alarms", "jobs")   # --false-alarm-rate: with --fit, per segment


def add_arguments(parser) -> None:
    from ..options import COUNT, number
    parser.add_argument("table", nargs="+",
                        help="the table: 'time [s]', '<joint>.speed [rad/s|rpm]', '<joint>.command [V]', optionally "
                             "'<joint>.torque [N m|mN m]' and '<joint>.fault [1]'; several, or a directory of them: "
                             "one run each, judged and scored as a campaign")
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
    parser.add_argument("--train-runs", type=number(int, 0), default=None, metavar="N",
                        help="with --fit: segments that train the vehicle's Elman networks first (default: 0 where "
                             "the vehicle has networks, else 20)")
    parser.add_argument("--epochs", type=COUNT, default=None, metavar="N",
                        help="with --train-runs: training epochs (default 1000)")
    parser.add_argument("--out", default=None, metavar="DIR",
                        help="write telemetry.json, telemetry_samples.csv (one row per FDI sample and wheel) and "
                             "telemetry.png (residuals against their bands) there")


def main(args) -> int:
    from ..options import fdi_config
    from ...core.mission.vehicle import load_vehicle
    from ...tools.evaluation.telemetry_campaign import table_paths
    from ...tools.evaluation.telemetry_file import check, format_check, format_verdict, judge, read_table, write_files
    joints = [j.strip() for j in args.joints.split(",")] if args.joints else None
    vehicle = load_vehicle(args.vehicle)   # one line naming the field, before the table is read
    paths = table_paths(args.table)
    fdi = fdi_config(args).with_vehicle_dir(args.vehicle)
    if len(paths) > 1 and not (args.fit or args.check):
        return _campaign(args, paths, joints, vehicle, fdi)
    tables = [read_table(p, joints) for p in paths]
    problems = 0
    for table in tables:
        checked = check(table, vehicle.wheel, max_gap=args.max_gap)
        problems += len(checked["problems"])
        if len(tables) == 1 or checked["problems"]:
            print(format_check(table, checked))
    if args.check:
        if len(tables) > 1:
            print(f"{len(tables)} tables checked, {problems} problems")
        return 0 if not problems else 1
    if args.fit:
        from ...tools.evaluation.telemetry_file import fit
        bands = fit(tables, args.fit, args.vehicle, fdi, args.false_alarm_rate, args.segment, max_gap=args.max_gap,
                    train_runs=args.train_runs, epochs=args.epochs)
        trained, written = bands.pop("trained_on"), bands.pop("written_to")
        print((f"networks trained on {trained} segments of {args.segment:g} s; " if trained else "")
              + f"bands fitted on {bands.pop('segments')} segments of {args.segment:g} s"
              + (f", each wheel's unit learnt over its first {fdi.unit_calibration:g} s" if fdi.unit_calibration
                 else "") + f", written to {written}:")
        for observer, by_wheel in bands.items():
            print(f"  {observer}: " + ", ".join(f"{a} {c * 1e3:.4g} mN m" for a, c in by_wheel.items()))
        if trained:
            print(f"the vehicle's FDI: --vehicle {args.fit}"
                  + (f" --unit-calibration {fdi.unit_calibration:g}" if fdi.unit_calibration else ""))
        else:
            print(f"judge with: --thresholds {args.fit}"
                  + (f" --unit-calibration {fdi.unit_calibration:g}" if fdi.unit_calibration else ""))
        return 0
    verdict = judge(tables[0], args.vehicle, fdi, max_gap=args.max_gap)
    print(format_verdict(verdict))
    if args.out:
        for path in write_files(verdict, args.out):
            print(f"wrote {path}")
    return 0


def _campaign(args, paths, joints, vehicle, fdi) -> int:
    """Many tables: each judged and scored against its ground truth, the rates with their 95 % intervals."""
    from tqdm import tqdm
    from ..options import executor
    from ...tools.evaluation.telemetry_campaign import format_summary, judge_campaign, summary, write_campaign
    fdi.for_vehicle(vehicle.name).loaded(1.0)   # a missing FDI is one line before any table is judged
    with tqdm(total=len(paths), desc="tables judged", unit="run", mininterval=1.0) as bar:
        rows = judge_campaign(paths, joints, args.vehicle, fdi, args.max_gap, executor(args), bar.update)
    s = summary(rows)
    print(format_summary(s))
    if args.out:
        for path in write_campaign(rows, s, args.out):
            print(f"wrote {path}")
    return 0

