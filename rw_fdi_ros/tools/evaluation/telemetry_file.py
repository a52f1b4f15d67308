"""Anyone's wheel telemetry from a file, checked and judged by the FDI the nodes run (`rw-fdi telemetry`).

The table (CSV, or Parquet with pyarrow) has one row per report, the unit of each column in its header:

    time [s]                      (or [ns]) the report's stamp, rising
    <joint>.speed [rad/s]         (or [rpm]) the wheel's speed
    <joint>.command [V]           the torque command voltage, held until the next
    <joint>.torque [N m]          (or [mN m]; optional) its reaction torque, else from the speed
    <joint>.bus_voltage [V]       (optional) the bus at its driver, held until the next
    <joint>.temperature [C]       (or [K]; optional) its temperature, held until the next
    <joint>.fault [1]             (optional) ground truth: 1 from a fault's onset on, else 0

A channel may be empty in a row (speed and command at their own rates). The joints map to the vehicle's wheel
set in its order (``joints``: the table's names; default the table's order). The reports go through
core/fdi/wheel_reports.ReportSampler and the core loop's FdiPipeline: the wheel_telemetry node's and the FDI
nodes' code, so the verdict is the graph's.
"""
from __future__ import annotations

import csv
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...core.fdi.telemetry import HOUSEKEEPING_FIELDS
from ...core.fdi.wheel_reports import speed_noise

UNITS = {"time": {"s": 1e9, "ns": 1.0}, "speed": {"rad/s": 1.0, "rpm": 2 * np.pi / 60.0},
         "command": {"V": 1.0}, "torque": {"N m": 1.0, "mN m": 1e-3}, "fault": {"1": 1.0, "": 1.0},
         "bus_voltage": {"V": 1.0}, "temperature": {"C": 1.0, "K": 1.0}}
OFFSETS = {("temperature", "K"): -273.15}   # what a unit's zero is off by
HOUSEKEEPING = HOUSEKEEPING_FIELDS   # a wheel driver's, held until the next (wheel_reports.py)
HEADER = re.compile(r"^\s*(?:(?P<joint>[^.\[\]]+)\.)?(?P<quantity>[a-z_]+)\s*(?:\[(?P<unit>[^\]]*)\])?\s*$")


class TelemetryError(ValueError):
    """A table that cannot be read or judged: one line, naming the column or the row."""


@dataclass
class Telemetry:
    """A telemetry table in SI units: stamps (n,) [ns], per channel (n, N) with NaN where a row does not report it."""

    path: str
    joints: tuple
    stamps_ns: np.ndarray
    speed: np.ndarray
    command: np.ndarray
    torque: np.ndarray | None = None
    fault: np.ndarray | None = None
    units: dict = field(default_factory=dict)
    bus_voltage: np.ndarray | None = None   # [V]
    temperature: np.ndarray | None = None   # [C]


def read_table(path, joints=None) -> Telemetry:
    """The table at ``path`` (module docstring), its joints in the order ``joints`` gives (default: the table's).

    Parameters
    ----------
    path : str or Path
        A CSV file, or a Parquet file (.parquet, with pyarrow).
    joints : sequence of str, optional
        The table's joint names in the wheel set's order.

    Returns
    -------
    Telemetry
        The table, converted to SI units.
    """
    path = Path(path)
    if not path.is_file():
        raise TelemetryError(f"{path}: no such file")
    names, rows = _columns(path)
    columns, units, order = {}, {}, []
    for i, name in enumerate(names):
        m = HEADER.match(name)
        if not m or m["quantity"] not in UNITS or (m["quantity"] == "time") == bool(m["joint"]):
            raise TelemetryError(f"{path}: column {name!r} is not 'time [s]' or '<joint>.{'|'.join(list(UNITS)[1:])} "
                                 "[unit]'")
        quantity, unit = m["quantity"], (m["unit"] or "").strip()
        if unit not in UNITS[quantity]:
            raise TelemetryError(f"{path}: column {name!r}: unit [{unit}] is not one of "
                                 f"{', '.join(f'[{u}]' for u in UNITS[quantity] if u)}")
        key = (m["joint"], quantity)
        columns[key] = rows[:, i] * UNITS[quantity][unit] + OFFSETS.get((quantity, unit), 0.0)
        units[name] = unit
        if m["joint"] and m["joint"] not in order:
            order.append(m["joint"])
    if (None, "time") not in columns:
        raise TelemetryError(f"{path}: no 'time [s]' column")
    joints = tuple(joints or order)
    for joint in joints:
        for quantity in ("speed", "command"):
            if (joint, quantity) not in columns:
                raise TelemetryError(f"{path}: no '{joint}.{quantity}' column (joints: {', '.join(order)})")
    time = columns[(None, "time")]
    if not np.isfinite(time).all() or (np.diff(time) < 0).any():
        bad = int(np.argmax(~np.isfinite(time) | np.r_[False, np.diff(time) < 0]))
        raise TelemetryError(f"{path}: row {bad + 2}: time is not rising")

    def stacked(quantity):
        present = [(j, quantity) in columns for j in joints]
        if not any(present):
            return None
        return np.stack([columns.get((j, quantity), np.full(len(time), np.nan)) for j in joints], axis=1)
    return Telemetry(str(path), joints, np.round(time).astype(np.int64), stacked("speed"), stacked("command"),
                     stacked("torque"), stacked("fault"), units, stacked("bus_voltage"), stacked("temperature"))


def _columns(path: Path) -> tuple:
    """(header names, (n, k) float array with NaN for empty cells) of a CSV or Parquet table."""
    if path.suffix.lower() == ".parquet":
        from ...extras import require
        table = require("pyarrow.parquet", "parquet").read_table(path)   # one line naming the extra without it
        if table.num_rows == 0:
            raise TelemetryError(f"{path}: a header and no rows")
        columns = []
        for c in table.column_names:
            try:
                columns.append(table.column(c).to_numpy(zero_copy_only=False).astype(float))
            except (ValueError, TypeError):
                raise TelemetryError(f"{path}: column {c!r} is not numbers") from None
        return list(table.column_names), np.column_stack(columns)
    with open(path, newline="", encoding="utf-8-sig") as fh:   # a spreadsheet's byte-order mark is no column
        reader = csv.reader(fh)
        names = next(reader, None)
        if not names:
            raise TelemetryError(f"{path}: empty (a header row first)")
        rows = []
        for n, row in enumerate(reader, start=2):
            if len(row) != len(names):
                raise TelemetryError(f"{path}: row {n} has {len(row)} cells, the header {len(names)}")
            try:
                rows.append([float(x) if x.strip() else np.nan for x in row])
            except ValueError:
                raise TelemetryError(f"{path}: row {n}: a cell is not a number") from None
    if not rows:
        raise TelemetryError(f"{path}: a header and no rows")
    return names, np.array(rows, float)


def check(table: Telemetry, wheel, fdi_period: float = 1.0, max_gap: float = 2.5) -> dict:
    """What a user should know before the FDI judges the table: per channel its reports, median rate, largest gap
    and implausible values (beyond twice the wheel's top speed, past its command range, not finite).

    Parameters
    ----------
    table : Telemetry
        The table.
    wheel : WheelParams
        The vehicle's wheel type.
    fdi_period : float
        [s] the FDI's period: a channel reported more slowly cannot be judged.
    max_gap : float
        [s] the gap past which the FDI periods are not judged.

    Returns
    -------
    dict
        duration [s], rows, and per joint and quantity its figures and problems.
    """
    from ...core.physics.wheel import top_speed
    limits = {"speed": 2.0 * top_speed(wheel), "command": wheel.command_limit * 1.001, "torque": np.inf,
              "fault": 1.0, "bus_voltage": 2.0 * wheel.bus_voltage, "temperature": 300.0}
    t = table.stamps_ns * 1e-9
    out = {"duration_s": float(t[-1] - t[0]), "rows": int(t.size), "channels": {}, "problems": [], "notes": []}
    partial = int(np.sum(np.isnan(table.speed).any(axis=1) & ~np.isnan(table.speed).all(axis=1)))
    if partial:
        out["problems"].append(f"{partial} rows give the speeds of some wheels only: a speed row must give every "
                               "wheel's (those rows are not read)")
    for quantity in ("speed", "command", "torque", "fault", *HOUSEKEEPING):
        values = getattr(table, quantity)
        if values is None:
            continue
        for i, joint in enumerate(table.joints):
            v = values[:, i]
            at = t[~np.isnan(v)]
            gaps = np.diff(at)
            figures = {"reports": int(at.size), "rate_hz": float(1.0 / np.median(gaps)) if gaps.size else 0.0,
                       "largest_gap_s": float(gaps.max()) if gaps.size else float("inf"),
                       "implausible": int(np.sum(~np.isnan(v) & ~(np.abs(v) <= limits[quantity])))}
            out["channels"][f"{joint}.{quantity}"] = figures
            name = f"{joint}.{quantity}"
            if not at.size:
                out["problems"].append(f"{name}: never reported")
            elif quantity in ("speed", "command") and figures["rate_hz"] < 1.0 / fdi_period:
                out["problems"].append(f"{name}: {figures['rate_hz']:.2g} Hz, below the FDI's {1 / fdi_period:g} Hz")
            if quantity == "speed":
                figures["noise"] = speed_noise(at, v[~np.isnan(v)])
                if figures["noise"] is not None and figures["noise"] > 2.0 * wheel.speed_noise + 1e-4:
                    out["notes"].append(f"{name}: noise ~{figures['noise']:.2g} rad/s where the vehicle's wheel has "
                                        f"speed_noise {wheel.speed_noise:g} rad/s: the torque the FDI derives from "
                                        "the speeds carries it (set wheel.speed_noise, docs/vehicles.md)")
            if quantity == "speed" and figures["largest_gap_s"] > max_gap and at.size:
                out["problems"].append(f"{name}: a gap of {figures['largest_gap_s']:.3g} s (past {max_gap:g} s: "
                                       "those periods are not judged)")
            if figures["implausible"]:
                out["problems"].append(f"{name}: {figures['implausible']} values beyond {limits[quantity]:.4g} or "
                                       "not finite")
    return out


def judge(table: Telemetry, vehicle=None, fdi=None, control_period: float = 0.1, max_gap: float = 2.5) -> dict:
    """The FDI's verdict on the table: the core loop's FdiPipeline on the reports put on the control grid.

    Parameters
    ----------
    table : Telemetry
        The table, its joints in the vehicle's wheel set's order.
    vehicle : str, optional
        A shipped vehicle, a vehicle file or its FDI directory; None: the thesis' MakSat.
    fdi : FdiConfig, optional
        The FDI (None: the vehicle's shipped one).
    control_period : float
        [s] dt of the control grid.
    max_gap : float
        [s] speed reports further apart leave the periods between not judged.

    Returns
    -------
    dict
        ``samples``: one row per FDI sample and wheel (time, wheel, speed, residual, threshold, alarm, judged);
        ``wheels``: per wheel its first alarm [s] (None), its identification, its ground-truth onset; and
        ``not_judged_s``: FDI samples skipped for lack of reports.
    """
    from ...fdi_config import FdiConfig
    from ...core.fdi.pipeline import FdiPipeline
    from ...core.mission.vehicle import load_vehicle
    v = load_vehicle(vehicle)
    names = v.wheel_set.names
    if len(table.joints) != len(names):
        raise TelemetryError(f"{table.path}: {len(table.joints)} wheels ({', '.join(table.joints)}), the vehicle's "
                             f"wheel set {len(names)} ({', '.join(names)}): give --joints in its order")
    fdi_period = 1.0
    loaded = (fdi or FdiConfig()).with_vehicle_dir(vehicle).for_vehicle(v.name).loaded(fdi_period)
    pipeline = FdiPipeline(names, loaded, 1, fdi_period, identification=True, wheel=v.wheel,
                           control_period=control_period, max_gap=max_gap)
    samples, skipped = [], []
    for judged in feed(table, pipeline):
        t = judged.stamp_ns * 1e-9
        if judged.rows is None:   # an FDI stamp without a judged sample: a gap in the reports
            skipped.append(t)
            continue
        _, decided = judged.rows[0]
        for i, a in enumerate(names):
            residual, threshold = decided[a][0], decided[a][1]   # the decision's: its residual against its band
            samples.append({"time_s": t, "wheel": a, "speed": float(judged.sample.wheel_speed[0, i]),
                            "residual": float(residual), "threshold": float(threshold),
                            "alarm": bool(decided[a][2])})
    identified = pipeline.identified[0]
    truth = _onsets(table)
    wheels = {}
    for i, a in enumerate(names):
        first = next((s["time_s"] for s in samples if s["wheel"] == a and s["alarm"]), None)
        found = identified.get(a)
        wheels[a] = {"joint": table.joints[i], "first_alarm_s": first,
                     "identification": None if found is None else found.message(),
                     "kind": None if found is None else found.kind, "truth_onset_s": truth.get(i)}
    return {"samples": samples, "wheels": wheels, "not_judged_s": skipped, "scored": table.fault is not None,
            "decision": loaded.decision.label if loaded.decision else "model", "vehicle": v.name}


def _onsets(table: Telemetry) -> dict:
    """wheel index -> its ground-truth onset [s] (the first row with fault 1), where the table has the column."""
    if table.fault is None:
        return {}
    out = {}
    for i in range(table.fault.shape[1]):
        on = np.flatnonzero(table.fault[:, i] >= 0.5)
        out[i] = float(table.stamps_ns[on[0]] * 1e-9) if on.size else None
    return out


def format_check(table: Telemetry, checked: dict) -> str:
    """The check on one screen: the table's extent, each channel's rate and largest gap, then its problems."""
    lines = [f"{table.path}: {checked['rows']} rows over {checked['duration_s']:.1f} s, wheels "
             f"{', '.join(table.joints)}"]
    for name, f in checked["channels"].items():
        lines.append(f"  {name:24s} {f['reports']:7d} reports  {f['rate_hz']:7.2f} Hz  largest gap "
                     f"{f['largest_gap_s']:.3g} s" + (f"  noise ~{f['noise']:.2g} rad/s" if f.get("noise") is not None
                                                       else "  noise unknown" if "noise" in f else "")
                     + (f"  {f['implausible']} implausible" if f["implausible"] else ""))
    lines += [f"  problem: {p}" for p in checked["problems"]] or ["  no problem found"]
    lines += [f"  note: {n}" for n in checked.get("notes", ())]
    return "\n".join(lines)


def format_verdict(verdict: dict) -> str:
    """Each wheel's verdict, its first alarm and identification; scored where the table has ground truth."""
    lines = [f"FDI of vehicle {verdict['vehicle']} (decision {verdict['decision']}):"]
    for a, w in verdict["wheels"].items():
        said = (f"faulty from {w['first_alarm_s']:g} s" + (f"; {w['identification']}" if w["identification"] else "")
                if w["first_alarm_s"] is not None else "no alarm")
        truth = ""
        if "truth_onset_s" in w and w["truth_onset_s"] is not None:
            late = None if w["first_alarm_s"] is None else w["first_alarm_s"] - w["truth_onset_s"]
            truth = (f" [truth: fault from {w['truth_onset_s']:g} s; " +
                     ("missed]" if late is None else "alarm before the onset]" if late < 0 else f"{late:g} s later]"))
        elif verdict.get("scored"):
            truth = " [truth: healthy" + ("; a false alarm]" if w["first_alarm_s"] is not None else "]")
        lines.append(f"  wheel {a} ({w['joint']}): {said}{truth}")
    if verdict["not_judged_s"]:
        t = verdict["not_judged_s"]
        lines.append(f"  not judged: {len(t)} FDI samples without reports (first at {t[0]:g} s)")
    return "\n".join(lines)


def write_files(verdict: dict, out) -> list:
    """telemetry.json, telemetry_samples.csv and telemetry.png (each wheel's residual against its band) in ``out``."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "telemetry.json", out / "telemetry_samples.csv", out / "telemetry.png"]
    paths[0].write_text(json.dumps({k: v for k, v in verdict.items() if k != "samples"}, indent=1))
    keys = ["time_s", "wheel", "speed", "residual", "threshold", "alarm"]
    with open(paths[1], "w", newline="") as fh:
        writer = csv.DictWriter(fh, keys)
        writer.writeheader()
        writer.writerows(verdict["samples"])
    wheels = list(verdict["wheels"])
    fig, axes = plt.subplots(len(wheels), 1, figsize=(9, 1.8 * len(wheels)), sharex=True, squeeze=False)
    for ax, a in zip(axes[:, 0], wheels):
        rows = [s for s in verdict["samples"] if s["wheel"] == a]
        t = np.array([s["time_s"] for s in rows])
        ax.plot(t, [s["residual"] * 1e3 for s in rows], lw=0.8, label="residual")
        band = np.array([s["threshold"] * 1e3 for s in rows])
        ax.fill_between(t, -band, band, color="0.85", label="band")
        alarmed = np.array([s["alarm"] for s in rows], bool)
        if alarmed.any():
            ax.plot(t[alarmed], np.zeros(alarmed.sum()), "r|", ms=8, label="faulty")
        onset = verdict["wheels"][a].get("truth_onset_s")
        if onset is not None:
            ax.axvline(onset, color="k", ls="--", lw=0.8, label="truth onset")
        ax.set_ylabel(f"{a} [mN m]")
    axes[0, 0].legend(loc="upper left", fontsize=7, ncol=4)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"residuals against their bands, vehicle {verdict['vehicle']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(paths[2], dpi=110)
    plt.close(fig)
    return paths


def fit(tables, out, vehicle=None, fdi=None, false_alarm_rate: float | None = None, segment: float = 400.0,
        control_period: float = 0.1, max_gap: float = 2.5, train_runs: int | None = None,
        epochs: int | None = None) -> dict:
    """The FDI fitted on a user's healthy telemetry, written to ``out``: each table is cut into ``segment``-s
    pieces, each a fitting run of the per-run false-alarm rate (the shipped bands' 400-s runs). Where the
    vehicle has no networks of its own (or ``train_runs`` asks), the first ``train_runs`` pieces train a
    speed-aware Elman network per wheel, as `rw-fdi defaults` does on our plant, and ``out`` becomes the
    vehicle's whole FDI (its vehicle.yaml, networks and bands: ``--vehicle out``); the bands are fitted on the
    other pieces. Refused, with the amount it needs, on too little telemetry.

    Parameters
    ----------
    tables : Telemetry or list of Telemetry
        Healthy telemetry (one table per run), joints in the vehicle's wheel set's order.
    out : str or Path
        The FDI directory written (thresholds_<observer>.json; with training, networks and vehicle.yaml).
    vehicle : str, optional
        A shipped vehicle, a vehicle file or its FDI directory; None: the thesis' MakSat.
    fdi : FdiConfig, optional
        Whose networks the Elman observers run when none are trained (None: the vehicle's shipped FDI).
    false_alarm_rate : float, optional
        The designed per-segment false-alarm probability (None: the fitting's default, 0.001).
    segment : float
        [s] the length of a fitting run.
    train_runs : int, optional
        Pieces that train the networks (None: 0 where the vehicle has networks, else TRAIN_RUNS).
    epochs : int, optional
        Training epochs (None: the training's default).

    Returns
    -------
    dict
        observer -> wheel -> band c [N m]; ``segments`` fitted on, ``trained_on`` (pieces, 0: none) and
        ``written_to`` (the bands' directory: ``out``, or with ``fdi.unit_calibration`` its ``unit_calibrated``
        beside the networks, where FdiConfig looks for them).
    """
    from ...fdi_config import FdiConfig
    from ...core.fdi.detection import FALSE_ALARM_RATE
    from ...core.mission.scenario import vehicle_scenario
    from ...core.mission.vehicle import load_vehicle
    from ..design.offline import fit_thresholds, load_models
    from ..design.samples import samples_from_rows
    tables, out = ([tables] if isinstance(tables, Telemetry) else list(tables)), Path(out)
    v, rate = load_vehicle(vehicle), false_alarm_rate or FALSE_ALARM_RATE
    pieces, seconds = _fitting_pieces(tables, v.wheel, segment, control_period, max_gap)
    config = (fdi or FdiConfig()).with_vehicle_dir(vehicle).for_vehicle(v.name)
    calibration, train_runs = _fit_plan(config, segment, train_runs)
    _refuse_too_little(tables, len(pieces), seconds, segment, rate, len(v.wheel_set.active), train_runs)
    runs = [samples_from_rows(piece, seed=k, wheels=v.wheel_set.names, wheel_params=v.wheel)
            for k, piece in enumerate(pieces)]
    plant = vehicle_scenario(vehicle, duration=1.0).plant_choices().as_dict()
    if train_runs:   # the first pieces train the networks, the rest fit the bands
        runs = _train_networks(runs, train_runs, out, v, plant, rate, epochs)
        models, reference = load_models(out), "model_set.json"
    else:
        models, reference = load_models(config.models_dir), str(config.models_dir)
    bands_dir = out / "unit_calibrated" if calibration else out   # FdiConfig.thresholds_dir's layout
    bands = fit_thresholds(runs, models, bands_dir, model_ref=reference, false_alarm_rate=rate, plant=plant,
                           unit_calibration=calibration)
    return {**bands, "segments": len(runs), "trained_on": train_runs, "written_to": str(bands_dir)}


def _fit_plan(config, segment: float, train_runs: int | None) -> tuple:
    """(unit calibration [s], pieces to train on) of a fit: a calibration as long as a segment is refused, and a
    vehicle without networks of its own trains TRAIN_RUNS pieces unless told."""
    from ...core.fdi.elman import ModelError
    calibration = config.unit_calibration
    if calibration and calibration >= segment:
        raise TelemetryError(f"--unit-calibration {calibration:g} s is not shorter than the {segment:g}-s fitting "
                             "segments: give a longer --segment")
    if train_runs is None:
        try:
            config.load_models()
            train_runs = 0
        except ModelError:   # a vehicle nobody made an FDI for: its networks learn from this telemetry
            train_runs = TRAIN_RUNS
    return calibration, train_runs


def _train_networks(runs, train_runs: int, out: Path, vehicle, plant: dict, rate: float, epochs) -> list:
    """Train the vehicle's speed-aware Elman networks on the first ``train_runs`` runs into ``out`` beside its
    vehicle.yaml (the directory becomes its whole FDI); the runs left to fit the bands on."""
    import yaml
    from ...core.mission.vehicle import to_mapping
    from ..design.train import EPOCHS, train_models
    train, runs = runs[:train_runs], runs[train_runs:]
    train_models(train, out, mode="recall", epochs=epochs or EPOCHS, plant=plant, speed_aware=True,
                 calibration=train + runs, false_alarm_rate=rate)
    (out / "vehicle.yaml").write_text(yaml.safe_dump(to_mapping(vehicle), sort_keys=False))
    return runs


def _refuse_too_little(tables, pieces: int, seconds: int, segment: float, rate: float, wheels: int,
                       train_runs: int):
    """TelemetryError, with what it needs, where ``pieces`` fitting runs are too few for ``rate`` on ``wheels``
    wheels and ``train_runs`` more to train on."""
    from ...core.fdi.threshold_fit import fitting_runs_needed
    needed = fitting_runs_needed(rate, 0.5, wheels)
    if pieces < needed + train_runs:
        where = tables[0].path if len(tables) == 1 else f"{len(tables)} tables"
        training = f" and {train_runs} more to train the networks on" if train_runs else ""
        raise TelemetryError(f"{where}: {seconds} s of judged healthy telemetry make {pieces} fitting runs of "
                             f"{segment:g} s; a per-run false-alarm rate of {rate:g} on {wheels} "
                             f"wheels needs {needed}{training} ({(needed + train_runs) * segment / 3600:.1f} h), "
                             "or ask for a higher --false-alarm-rate")


def _fitting_pieces(tables, wheel, segment: float, control_period: float, max_gap: float) -> tuple:
    """(pieces of ``segment`` judged FDI samples, seconds of judged samples) of healthy tables, each table its own
    run (no piece spans two), the samples made as the wheel_telemetry node makes them."""
    from ...core.fdi.wheel_reports import ReportSampler
    n = int(segment)
    pieces, seconds = [], 0
    for table in tables:
        reports = ReportSampler(wheel, 1.0, control_period, max_gap)
        samples = [s for s in feed(table, reports) if np.isfinite(s.reaction_torque).all()]
        seconds += len(samples)
        pieces += [samples[i:i + n] for i in range(0, len(samples) - n + 1, n)]
    return pieces, seconds


TRAIN_RUNS = 20   # pieces a vehicle's networks learn from when it has none (rw-fdi defaults trains on 40 runs)


def feed(table: Telemetry, sink) -> list:
    """The table's reports into ``sink`` (core/fdi/wheel_reports.ReportSampler, core/fdi/pipeline.FdiPipeline) in
    the order two streams would bring them, as the wheel_telemetry node takes them; what the sink gives back."""
    # a command row may name some wheels only: each wheel holds its last command (the driver does)
    held = table.command.copy()
    for k in range(1, len(held)):
        held[k] = np.where(np.isnan(held[k]), held[k - 1], held[k])
    commands = [k for k in np.flatnonzero(~np.isnan(table.command).all(axis=1)) if np.isfinite(held[k]).all()]
    kept = {q: getattr(table, q) for q in HOUSEKEEPING if getattr(table, q) is not None}
    kept_rows = np.flatnonzero(np.any([~np.isnan(v).all(axis=1) for v in kept.values()], axis=0)) if kept else []
    out, c, h = [], 0, 0
    for k in np.flatnonzero(np.isfinite(table.speed).all(axis=1)):   # a speed row names every wheel (check)
        stamp = int(table.stamps_ns[k])
        while h < len(kept_rows) and table.stamps_ns[kept_rows[h]] <= stamp:
            sink.add_housekeeping(int(table.stamps_ns[kept_rows[h]]), **{q: v[kept_rows[h]] for q, v in kept.items()})
            h += 1
        while c < len(commands) and table.stamps_ns[commands[c]] <= stamp:
            out += sink.add_command(int(table.stamps_ns[commands[c]]), held[commands[c]])
            c += 1
        torque = None if table.torque is None or np.isnan(table.torque[k]).any() else table.torque[k]
        out += sink.add_speed(stamp, table.speed[k], torque)
    for k in commands[c:]:
        out += sink.add_command(int(table.stamps_ns[k]), held[k])
    return out + sink.flush()
