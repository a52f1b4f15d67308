"""Scenario files: shipped set, draws from Table 2.3, and one-line errors for bad input."""
import numpy as np
import pytest

from rw_fdi_ros.core.physics.faults import operating_point_at
from rw_fdi_ros.core.mission.scenario import ScenarioError, available_scenarios, load_scenario, parse_scenario

SHIPPED = {"fault_free", "bus_4v_x", "bus_5v5_x", "current_0p6_x", "temperature_150_x", "bus_x_current_z",
           "ripple_40_x"}


def test_shipped_scenarios_load():
    assert SHIPPED <= set(available_scenarios())
    for name in SHIPPED:
        s = load_scenario(name)
        assert s.duration == 400.0
    multi = load_scenario("bus_x_current_z")
    assert [(f.kind, f.wheel, f.onset) for f in multi.faults] == [("bus_voltage", 0, 200.0),
                                                                   ("current_limiter", 2, 250.0)]


def test_draws_inside_table_2_3_and_repeatable():
    s = load_scenario("fault_free")
    for seed in range(50):
        ic, steps = s.with_seed(seed).draws()
        assert np.all(np.abs(np.rad2deg(ic.attitude)) <= 180)
        assert np.all(np.abs(ic.body_rate) <= 1e-4)
        assert np.all((ic.wheel_speed >= 20) & (ic.wheel_speed <= 30))
        assert np.all(np.abs(np.rad2deg(steps[0][1])) <= 5)
    a, b = s.with_seed(3).draws()[0], s.with_seed(3).draws()[0]
    np.testing.assert_array_equal(a.attitude, b.attitude)


def test_operating_point_follows_fault_schedule_and_ramps():
    s = parse_scenario("faults:\n - {kind: current_limiter, wheel: y, onset: 100, value: 0.5, ramp: 50}\n")
    assert operating_point_at(s.faults, 99.9)["current_limiter"][1] == 1.0
    assert operating_point_at(s.faults, 125.0)["current_limiter"][1] == pytest.approx(0.75)
    assert operating_point_at(s.faults, 300.0)["current_limiter"].tolist() == [1.0, 0.5, 1.0]


def test_effective_text_records_the_seed():
    s = load_scenario("bus_5v5_x").with_seed(42)
    again = parse_scenario(s.effective_text())
    assert again.seed == 42 and again.faults == s.faults


@pytest.mark.parametrize("text, words", [
    ("faults: [{kind: bus_voltage, wheel: w, onset: 1, value: 5}]", "wheel must be one of"),
    ("faults: [{kind: voltage, wheel: x, onset: 1, value: 5}]", "kind: must be one of"),
    ("faults: [{kind: bus_voltage, wheel: x, value: 5}]", "missing 'onset'"),
    ("faults: [{kind: current_limiter, wheel: x, onset: 1, value: 2}]", "outside"),
    ("duration: -5", "outside"),
    ("duration: .nan", "finite number"),
    ("speed: 3", "unknown field"),
    ("faults: [1, 2", "not valid YAML"),
    ("- a\n- b", "YAML mapping"),
    ("setpoints: [{time: 1, change_deg: [1e12, 0, 0]}]", "change_deg[0]: 1000000000000.0 is outside [-180.0, 180.0]"),
    ("initial: {wheel_speed: [1e6, 0, 0]}", "initial.wheel_speed[0]: 1000000.0 is outside [-690.0, 690.0]"),
    ("initial: {body_rate: [0, 2.0, 0]}", "initial.body_rate[1]: 2.0 is outside [-1.0, 1.0]"),
    ("initial: {attitude_deg: [0, 0, -200]}", "initial.attitude_deg[2]: -200 is outside"),
])
def test_malformed_scenarios_give_one_line_errors(text, words):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, origin="bad.yaml")
    assert words in str(err.value) and "\n" not in str(err.value)


def test_unknown_scenario_name_lists_known_ones():
    with pytest.raises(ScenarioError, match="unknown scenario 'nope'.*fault_free"):
        load_scenario("nope")


def test_cli_output_into_a_closed_pipe_ends_quietly():
    """`rw-fdi scenarios | head -0`: no BrokenPipeError traceback, the shell's SIGPIPE status."""
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-m", "rw_fdi_ros.cli", "scenarios"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()   # the reader is gone before the first line is written
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err


def test_yaml_surprises_are_named_not_swallowed(tmp_path):
    """A key given twice, 1e12 (text to YAML 1.1) and a file that is not text each get a one-line answer."""
    with pytest.raises(ScenarioError, match=r"line 2 is not valid YAML \(duplicate key 'duration'\)"):
        parse_scenario("duration: 10\nduration: 20\nfaults: []\n", origin="dup.yaml")
    with pytest.raises(ScenarioError, match=r"duration: 1000000000000.0 is outside \[1.0, 1000000.0\]"):
        parse_scenario("duration: 1e12\nfaults: []\n")
    assert parse_scenario("duration: 2e2\nfaults: []\n").duration == 200.0
    junk = tmp_path / "junk.yaml"
    junk.write_bytes(bytes(range(128, 256)) * 1000)
    with pytest.raises(ScenarioError, match=f"{junk}: not a readable scenario file"):
        load_scenario(str(junk))


@pytest.mark.parametrize("command", [["run", "--scenario", "fault_free", "--no-fdi"],
                                     ["campaign", "--scenario", "fault_free", "--runs", "1"]])
def test_an_output_that_cannot_be_made_fails_before_anything_starts(tmp_path, command):
    import subprocess
    import sys
    import time
    from pathlib import Path
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    t0 = time.monotonic()
    out = subprocess.run([str(Path(sys.executable).parent / "rw-fdi"), *command, "--out", str(blocker / "bags")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and time.monotonic() - t0 < 10
    assert out.stderr.strip() == f"rw-fdi: error: --out {blocker / 'bags'}: cannot create it (Not a directory)"
    assert "running scenario" not in out.stdout


def test_operations_draw_manoeuvres_at_random_times_without_moving_the_rest_of_the_seed():
    ops = load_scenario("operations")
    assert ops.manoeuvres is not None and ops.duration == 400.0
    counts = []
    for seed in range(200):
        run = ops.with_seed(seed)
        times, values = run.setpoint_schedule()
        gaps = np.diff(times)
        assert times[0] == 0.0 and np.all((gaps >= 100.0) & (gaps <= 300.0)) and times[-1] < 400.0
        steps = np.rad2deg(np.diff(values, axis=0))
        assert np.all(np.abs(steps) <= 5.0 + 1e-9)
        counts.append(len(times))
        # the manoeuvres' own stream: the initial conditions and the t = 0 change are fault_free's
        ff = load_scenario("fault_free").with_seed(seed)
        assert np.allclose(run.draws()[0].wheel_speed, ff.draws()[0].wheel_speed)
        assert np.allclose(values[0], ff.setpoint_schedule()[1][0])
    assert set(counts) == {2, 3, 4}   # up to three set-point changes after the first
    hours = load_scenario("operations_hours")
    assert hours.duration == 7200.0 and len(hours.setpoint_schedule()[0]) > 8


@pytest.mark.parametrize("manoeuvres, message", [
    ("{interval_s: [300, 100]}", "low 300 above high 100"),
    ("{interval_s: [0, 10]}", "outside"),
    ("{size_deg: 5}", r"expected \[low, high\]"),
    ("{every: 3}", "a mapping of interval_s, size_deg and start_s"),
    ("[1, 2]", "a mapping of interval_s, size_deg and start_s")])
def test_bad_manoeuvres_are_one_line_errors(manoeuvres, message):
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(f"name: m\nmanoeuvres: {manoeuvres}\n", origin="m.yaml")


def test_a_report_path_taken_by_a_file_is_one_line(tmp_path):
    """`evaluate --report <an existing file>` ended in FileExistsError (issue 39); any other OSError a command
    meets is one line too (cli.main)."""
    from rw_fdi_ros.cli import main
    blocker = tmp_path / "report"
    blocker.write_text("")
    (tmp_path / "bags").mkdir()
    import contextlib
    import io
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["evaluate", "--bags", str(tmp_path / "bags"), "--report", str(blocker), "--engine", "core"])
    assert code == 2 and err.getvalue().strip() == f"rw-fdi: error: --report {blocker}: cannot create it (File exists)"


def test_a_second_fault_of_one_kind_on_one_wheel_takes_over_at_its_onset():
    """Bus 5 V from 100 s, then 4 V from 300 s, on x: 8 V before, 5 V between (the later fault did not undo
    the earlier before its onset), 4 V after; a ramp goes from the value in force."""
    from rw_fdi_ros.core.mission.scenario import Fault
    faults = [Fault("bus_voltage", 0, 300.0, 4.0), Fault("bus_voltage", 0, 100.0, 5.0)]
    assert [operating_point_at(faults, t, 4)["bus_voltage"][0] for t in (50.0, 200.0, 400.0)] == [8.0, 5.0, 4.0]
    assert operating_point_at(faults, 200.0, 4)["bus_voltage"][1:].tolist() == [8.0, 8.0, 8.0]
