"""`rw-fdi telemetry`: a table of anyone's wheel telemetry checked and judged by the FDI the nodes run (issue 57).
The table is the speed-mode driver's of test_wheel_telemetry_graph.py (not our plant), written as a user would:
speed in rpm at 25 Hz with jitter and lost rows, commands at 10 Hz, ground truth beside."""
import csv
import subprocess
import sys

import numpy as np
import pytest

from foreign_wheels import JOINTS, stream
from rw_fdi_ros.core.physics.wheel import WheelParams
from rw_fdi_ros.fdi_config import FdiConfig
from rw_fdi_ros.tools.evaluation.telemetry_file import TelemetryError, check, fit, judge, read_table

ONSET = 150.0


def write_table(path, drop=(), duration=300.0, onset=ONSET, bus=None, housekeeping=False):
    """The driver's run as a CSV (speed in rpm), without the speed rows whose time falls in ``drop`` (lo, hi); with
    ``bus`` its fault a bus drop; with ``housekeeping`` each wheel's bus [V] and temperature [K] every 2 s."""
    speeds, commands = stream(duration, onset, 0.5, bus=bus)
    rows = {}
    for t in np.arange(0.0, duration, 2.0) if housekeeping else ():
        volts = [8.0 if i != 1 or t < onset or bus is None else bus for i in range(4)]
        rows.setdefault(round(t + 0.013, 6), {})["housekeeping"] = volts + [296.15] * 4
    for t, w in speeds:
        if not (drop and drop[0] <= t <= drop[1]):
            rows.setdefault(round(t, 6), {})["speed"] = w * 60.0 / (2.0 * np.pi)
    for t, u in commands:
        rows.setdefault(round(t, 6), {})["command"] = u
    with open(path, "w", newline="") as fh:
        out = csv.writer(fh)
        kept = [*(f"{j}.bus_voltage [V]" for j in JOINTS), *(f"{j}.temperature [K]" for j in JOINTS)]
        out.writerow(["time [s]", *(f"{j}.speed [rpm]" for j in JOINTS), *(f"{j}.command [V]" for j in JOINTS),
                      *(f"{j}.fault [1]" for j in JOINTS), *(kept if housekeeping else ())])
        for t in sorted(rows):
            r = rows[t]
            empty = [""] * 4
            out.writerow([t, *r.get("speed", empty), *r.get("command", empty),
                          *(int(t >= onset and i == 1) for i in range(4)),
                          *(r.get("housekeeping", empty * 2) if housekeeping else ())])
    return path


@pytest.fixture(scope="module")
def table_file(tmp_path_factory):
    return write_table(tmp_path_factory.mktemp("telemetry") / "wheels.csv")


def test_the_half_current_wheel_is_named_from_a_users_table_and_no_other(table_file):
    verdict = judge(read_table(table_file))
    wheels = verdict["wheels"]
    assert [a for a, w in wheels.items() if w["first_alarm_s"] is not None] == ["y"]
    assert ONSET < wheels["y"]["first_alarm_s"] <= ONSET + 30.0 and wheels["y"]["truth_onset_s"] == ONSET
    assert wheels["y"]["kind"] == "current_limiter", wheels["y"]
    # every FDI sample judged but the first, whose period the reports began inside (the first report was lost)
    assert verdict["not_judged_s"] in ([], [1.0]) and len(verdict["samples"]) >= 4 * 295


def test_a_wheels_reported_bus_and_temperature_hold_its_identification(tmp_path):
    """A table with each wheel's bus voltage and temperature (in kelvin, every 2 s): the bus drop of wheel y is
    named a bus drop at the voltage its bus reports; the half-current wheel beside a nominal bus a current loss."""
    table = read_table(write_table(tmp_path / "bus.csv", bus=4.0, housekeeping=True))
    assert np.allclose(table.temperature[np.isfinite(table.temperature)], 23.0)
    assert "rw2.bus_voltage" in check(table, WheelParams())["channels"]
    wheels = judge(table)["wheels"]
    assert [a for a, w in wheels.items() if w["first_alarm_s"] is not None] == ["y"]
    assert wheels["y"]["kind"] == "bus_voltage", wheels["y"]
    assert wheels["y"]["identification"].startswith("bus voltage 4.0"), wheels["y"]
    loss = judge(read_table(write_table(tmp_path / "loss.csv", housekeeping=True)))["wheels"]
    assert loss["y"]["kind"] == "current_limiter", loss["y"]


def test_the_check_sees_the_rates_and_a_gap_and_the_fdi_does_not_judge_across_it(tmp_path):
    table = read_table(write_table(tmp_path / "gap.csv", drop=(40.0, 45.0), duration=80.0))
    checked = check(table, WheelParams())
    speed = checked["channels"]["rw1.speed"]
    assert 23.0 < speed["rate_hz"] < 27.0 and 5.0 < speed["largest_gap_s"] < 5.5
    assert checked["channels"]["rw1.command"]["rate_hz"] == pytest.approx(10.0)
    assert any("rw1.speed: a gap of 5" in p for p in checked["problems"])
    assert 42.0 in judge(table)["not_judged_s"]


@pytest.mark.parametrize("header, row, message", [
    ("time [min],rw1.speed [rad/s],rw1.command [V]", "0,1,1", "unit [min] is not one of [s], [ns]"),
    ("time [s],rw1.speed [rad/s]", "0,1", "no 'rw1.command' column"),
    ("time [s],rw1.velocity [rad/s],rw1.command [V]", "0,1,1", "column 'rw1.velocity [rad/s]' is not"),
    ("time [s],rw1.speed [rad/s],rw1.command [V]", "0,x,1", "row 2: a cell is not a number"),
    ("time [s],rw1.speed [rad/s],rw1.command [V]", "1,1,1\n0,1,1", "row 3: time is not rising"),
])
def test_a_bad_table_is_one_line_and_a_non_zero_exit(tmp_path, header, row, message):
    path = tmp_path / "bad.csv"
    path.write_text(f"{header}\n{row}\n")
    with pytest.raises(TelemetryError, match=message.replace("[", r"\[").replace("]", r"\]")):
        read_table(path)
    done = subprocess.run([sys.executable, "-m", "rw_fdi_ros.cli", "telemetry", str(path)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr


def test_the_command_line_writes_the_verdict_the_rows_and_the_figure(table_file, tmp_path):
    done = subprocess.run([sys.executable, "-m", "rw_fdi_ros.cli", "telemetry", str(table_file), "--out",
                           str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-800:]
    assert "wheel y (rw2): faulty from" in done.stdout and "[truth: fault from 150 s;" in done.stdout
    assert "wheel x (rw1): no alarm [truth: healthy]" in done.stdout
    rows = list(csv.DictReader(open(tmp_path / "telemetry_samples.csv")))
    assert {r["wheel"] for r in rows} == {"x", "y", "z", "s"}
    assert (tmp_path / "telemetry.png").stat().st_size > 10_000


def test_bands_fitted_on_a_users_healthy_telemetry_judge_it_and_too_little_is_refused(table_file, tmp_path):
    """--fit: 1100 s of healthy telemetry cut into 100-s fitting runs (10, what a 1 % rate on three wheels
    needs); the bands written are the FDI's files, and with them the faulty run is judged as before."""
    healthy = read_table(write_table(tmp_path / "healthy.csv", duration=1100.0, onset=1e9))
    with pytest.raises(TelemetryError, match=r"make 2 fitting runs of 400 s; .* needs 60 \(6.7 h\)"):
        fit(healthy, tmp_path / "refused", false_alarm_rate=0.001)
    assert not (tmp_path / "refused").exists()   # refused before anything is written
    bands = fit(healthy, tmp_path / "bands", false_alarm_rate=0.01, segment=100.0)
    assert bands["segments"] == 10 and set(bands["model"]) == {"x", "y", "z"}
    assert all(0.0 < c < 1e-4 for c in bands["model"].values())
    verdict = judge(read_table(table_file), fdi=FdiConfig(thresholds=str(tmp_path / "bands")))
    assert [a for a, w in verdict["wheels"].items() if w["first_alarm_s"] is not None] == ["y"]
    assert verdict["samples"][0]["threshold"] != judge(read_table(table_file))["samples"][0]["threshold"]
