"""A real wheel's reports at their own rate on the FDI's control grid (core/fdi/wheel_reports.py), against closed
forms: a wheel spun up at a constant rate has r = -J a, whatever the report rate, jitter or drops."""
import numpy as np
import pytest

from rw_fdi_ros.core.fdi.telemetry import TelemetrySampler
from rw_fdi_ros.core.fdi.wheel_reports import ControlGrid, ReportSampler, report_samples
from rw_fdi_ros.core.physics.wheel import WheelParams

J, A, W0 = 0.0077, 0.3, 20.0   # [kg m^2], [rad/s^2], [rad/s]


def speed_at(t):
    return np.array([W0 + A * t, -W0 - 2 * A * t])   # two wheels, one the other way at twice the rate


def feed(grid, stamps, command_every=0.1, torque=False):
    """Commands every ``command_every`` s (u = 1 + t, held), speed reports at ``stamps`` [s]; the grid rows."""
    rows, next_command = [], 0.0
    for s in stamps:
        while next_command <= s:
            rows += grid.add_command(int(round(next_command * 1e9)), [1.0 + next_command, -1.0])
            next_command += command_every
        r = -J * np.array([A, -2 * A]) if torque else None
        rows += grid.add_speed(int(round(s * 1e9)), speed_at(s), r)
    return rows + grid.flush()


@pytest.mark.parametrize("rate", [1.2, 10.0, 37.0, 200.0])
def test_a_constant_spin_up_gives_r_equal_minus_j_a_at_any_report_rate_with_jitter_and_drops(rate):
    rng = np.random.default_rng(4)
    stamps = np.arange(0.0, 20.0, 1.0 / rate) + rng.uniform(0.0, 0.3 / rate, int(np.ceil(20.0 * rate)))
    keep = rng.random(stamps.size) > 0.2   # a fifth of the reports lost
    rows = feed(ControlGrid(0.1, J), np.sort(stamps[keep]))   # the default gap: the FDI rate passes
    t = np.array([row[0] for row in rows]) * 1e-9
    assert np.allclose(np.diff(t), 0.1) and t[-1] > 19.0            # every grid point, none twice
    # Omega linear between reports, the step's mean speed (r the step's mean torque)
    assert np.allclose([row[3] for row in rows], [speed_at(x - 0.05) for x in t])
    assert np.allclose([row[2] for row in rows], -J * np.array([A, -2 * A]), rtol=1e-6)
    # the command in force over the step ending at t_k: the last one stamped before it
    assert np.allclose([row[1][0] for row in rows], 1.0 + np.round(t - 0.1, 9))


def test_a_reported_torque_is_taken_as_reported_with_the_speed_at_the_grid_point():
    rows = feed(ControlGrid(0.1, J), np.arange(0.0, 3.0, 0.05), torque=True)
    assert len(rows) == 29 and np.allclose([row[2] for row in rows], -J * np.array([A, -2 * A]))
    assert np.allclose([row[3] for row in rows], [speed_at(row[0] * 1e-9) for row in rows])


def test_a_gap_longer_than_max_gap_leaves_its_grid_points_unknown_then_resumes():
    stamps = np.r_[np.arange(0.0, 2.0, 0.05), np.arange(3.0, 5.0, 0.05)]   # nothing in (1.95, 3.0)
    rows = feed(ControlGrid(0.1, J, max_gap=0.5), stamps)
    by_t = {round(row[0] * 1e-9, 1): row for row in rows}
    assert all(np.isnan(by_t[x][2]).all() and np.isnan(by_t[x][3]).all() for x in (2.0, 2.5, 3.0))
    assert np.isnan(by_t[3.1][2]).all()   # the first point after it has no step behind it for r: unknown too
    assert np.allclose(by_t[3.2][2], -J * np.array([A, -2 * A]))
    times = [row[0] for row in rows]
    assert times == sorted(set(times)) and np.allclose(np.diff(times), 1e8)   # every point once, none skipped


def test_the_fdi_sample_of_a_gap_is_not_finite_and_the_next_ones_are():
    """Through the plant's own TelemetrySampler: the period of the gap cannot be judged, the rest can (the ripple's
    phase restarts after the gap instead of staying NaN)."""
    stamps = np.r_[np.arange(0.0, 2.0, 0.05), np.arange(3.0, 8.0, 0.05)]
    sampler = TelemetrySampler(1.0, "mean", WheelParams(), identification=True)
    samples = [s for row in feed(ControlGrid(0.1, J, max_gap=0.5), stamps) if (s := sampler.add(*row)) is not None]
    by_t = {s.stamp_ns // 10**9: s for s in samples}
    assert not np.isfinite(by_t[3].reaction_torque).any()
    for k in (5, 6, 7):
        s = by_t[k]
        assert np.isfinite(s.ripple_phasor).all() and np.isfinite(s.bus_motor_torque).all()
        assert np.allclose(s.reaction_torque, -J * np.array([A, -2 * A]))
        assert np.allclose(s.wheel_speed, speed_at(k - 0.5), atol=1e-9)   # the mean of the steps' mean speeds


def test_late_and_repeated_reports_are_dropped():
    grid = ControlGrid(0.1, J)
    grid.add_command(0, [1.0, 1.0])
    assert grid.add_speed(0, speed_at(0.0)) == []
    assert grid.add_speed(200_000_000, speed_at(0.2)) == []   # waits for the commands up to it
    first = grid.add_command(200_000_000, [1.0, 1.0])
    assert [row[0] for row in first] == [100_000_000, 200_000_000]
    assert grid.add_speed(150_000_000, speed_at(0.15)) == [] and grid.add_speed(200_000_000, speed_at(0.2)) == []
    assert grid.flush() == []


def test_the_rows_do_not_depend_on_which_stream_arrives_first():
    """The commands of the last second arrive after its speed reports (another topic, another path): the same
    rows as in order, each speed report waiting for the commands before it."""
    stamps = np.arange(0.0, 6.0, 0.04)
    commands = [(int(round(t * 1e9)), [1.0 + t, -1.0]) for t in np.arange(0.0, 6.0, 0.1)]
    in_order = feed(ControlGrid(0.1, J), stamps)
    grid, late = ControlGrid(0.1, J), []
    for k in range(6):   # each second: its speed reports first, then its commands
        for t in stamps[(stamps >= k) & (stamps < k + 1)]:
            late += grid.add_speed(int(round(t * 1e9)), speed_at(t))
        for stamp, u in commands:
            if k * 10**9 <= stamp < (k + 1) * 10**9:
                late += grid.add_command(stamp, u)
    late += grid.flush()
    assert [row[0] for row in late] == [row[0] for row in in_order]
    assert all(np.allclose(a[1], b[1]) and np.allclose(a[2], b[2]) for a, b in zip(late, in_order))


def test_a_plant_reporting_on_the_grid_gives_its_steps_with_the_command_in_force_and_no_sample_at_the_start():
    """Our plant's way in (and a simulator's): speed and torque at every grid point, then the command sent at it.
    Each row is the step's report with the command sent one step before (in force over the step), so the samples
    are TelemetrySampler's on those rows, bit for bit; the first report has no command in force: no sample at 0."""
    rng = np.random.default_rng(4)
    n, wheel = 41, WheelParams()
    stamps = np.arange(n) * 100_000_000
    speed, torque, sent = (rng.normal(s, 1.0, (n, 3)) for s in (30.0, 0.0, 1.0))
    samples = report_samples(stamps, sent, torque * 1e-3, speed, wheel, identification=True)
    direct = TelemetrySampler(1.0, "mean", wheel, identification=True)
    expected = [s for k in range(1, n) if (s := direct.add(int(stamps[k]), sent[k - 1], torque[k] * 1e-3, speed[k]))]
    assert [s.stamp_ns for s in samples] == [s.stamp_ns for s in expected] == [10**9 * k for k in range(1, 5)]
    for a, b in zip(samples, expected):
        for name in ("tcv", "reaction_torque", "wheel_speed", "model_torque", "ripple_phasor", "bus_motor_torque"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    # the same reports one at a time, as the wheel_telemetry node takes them off its two topics
    reports, streamed = ReportSampler(wheel, identification=True), []
    for k in range(n):
        assert reports.add_speed(int(stamps[k]), speed[k], torque[k] * 1e-3) == []   # it waits for its command
        streamed += [(k, s.stamp_ns) for s in reports.add_command(int(stamps[k]), sent[k])]
    assert streamed == [(10 * k, 10**9 * k) for k in range(1, 5)]   # each with the command sent at its stamp


def test_housekeeping_is_held_from_its_stamp_wheel_by_wheel_and_absent_without_a_report():
    """A driver's bus voltage and temperature are not averaged: each FDI sample carries the report in force at its
    stamp; a report naming one wheel (NaN for the other) leaves the other's as it was; a channel never reported is
    not in the samples."""
    def samples(housekeeping):
        reports = ReportSampler(WheelParams(), 1.0, 0.1, identification=False)
        out, pending = [], sorted(housekeeping)
        for s in np.arange(0.0, 6.0, 0.05):
            while pending and pending[0][0] <= s:
                t, bus, temperature = pending.pop(0)
                reports.add_housekeeping(int(round(t * 1e9)), bus, temperature)
            out += reports.add_command(int(round(s * 1e9)), [1.0, -1.0])
            out += reports.add_speed(int(round(s * 1e9)), speed_at(s))
        return {x.stamp_ns // 10**9: x for x in out + reports.flush()}
    nan = np.nan
    by_t = samples([(1.5, [8.0, 8.0], None), (2.5, [5.5, nan], [30.0, 31.0]), (4.0, [nan, 6.0], None)])
    assert by_t[1].bus_voltage is None and by_t[1].temperature is None   # none reported yet
    assert np.array_equal(by_t[2].bus_voltage, [8.0, 8.0]) and by_t[2].temperature is None
    assert np.array_equal(by_t[3].bus_voltage, [5.5, 8.0]) and np.array_equal(by_t[3].temperature, [30.0, 31.0])
    assert np.array_equal(by_t[4].bus_voltage, [5.5, 6.0]) and np.array_equal(by_t[5].temperature, [30.0, 31.0])
    quiet = samples([])
    assert quiet[3].bus_voltage is None and quiet[3].temperature is None   # a wheel that reports none: as before


def test_between_slow_reports_the_speed_bends_with_what_the_commands_explain():
    """A healthy wheel (its torque the nominal model's) commanded in steps at 10 Hz, its speed reported at 1 Hz half a
    second off the FDI's stamps: with the model the derived torque is the model's in every FDI sample (a slew's
    torque step between two reports no longer leaks into the speed at the stamp); the straight line between reports
    does not give it. The first period, which the reports began inside, is not judged."""
    from rw_fdi_ros.core.fdi.telemetry import model_reaction_torque
    wheel = WheelParams()
    h = 1e-3
    def command(t):
        return np.array([2.0 if (t % 20.0) < 3.0 else 0.3, -1.5 if (t % 7.0) < 2.0 else 0.5])
    omega, speeds = np.array([30.0, -25.0]), []
    for k in range(int(40.0 / h) + 1):
        t = k * h
        if abs((t - 0.5) - round(t - 0.5)) < h / 2:
            speeds.append((t, omega.copy()))
        u = command(np.floor(t * 10.0 + 1e-9) / 10.0 if k % 100 else round(t, 1))   # the last 0.1-s stamp's, held
        omega = omega - h * model_reaction_torque(u, omega, wheel)[0] / wheel.inertia
    def residuals(grid_model):
        reports = ReportSampler(wheel, 1.0, 0.1)
        if not grid_model:
            reports.grid.model = None
        out = []
        for t, w in speeds:
            for k in range(int(np.ceil((t - 1.0) * 10.0 - 1e-9)), int(np.ceil(t * 10.0 - 1e-9))):
                if k >= 0:   # the commands sent at 0.1-s stamps since the last report
                    out += reports.add_command(k * 10**8, command(k / 10.0))
            out += reports.add_speed(int(round(t * 1e9)), w)
        return out + reports.flush()
    bent, straight = residuals(True), residuals(False)
    assert not np.isfinite(bent[0].reaction_torque).any()   # the first period: reports from 0.5 s on
    error = np.array([s.reaction_torque - s.model_torque for s in bent[1:]])
    assert np.isfinite(error).all() and len(error) >= 37
    scale = np.abs([s.model_torque for s in bent[1:]]).max()
    assert np.abs(error).max() < 1e-3 * scale, np.abs(error).max()   # what is left: the simulator's Euler steps
    lines = np.array([s.reaction_torque - s.model_torque for s in straight[1:]])
    assert np.abs(lines).max() > 100 * np.abs(error).max()
