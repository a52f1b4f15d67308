"""Whether the physics tells a current loss from a bus drop (core/identification/identifiability.py), against
closed forms."""
import numpy as np
import pytest

from rw_fdi_ros.core.physics import wheel as wm
from rw_fdi_ros.core.fdi.identification.identifiability import (TOLD_APART, drive_current, other_family_misfit,
                                                            told_apart)
from rw_fdi_ros.core.fdi.identification import DECISIVE

P = wm.WheelParams()


def test_at_one_operating_point_a_share_and_a_cap_are_the_same_wheel():
    # a saturated command at 25 rad/s: the bridge drives 0.95 A; a 0.7 share gives 0.665 A, and the bus whose
    # EMF limit is 0.665 A at that speed gives the same current, so nothing can tell them apart
    u, w, t = np.full(4, 5.0), np.full(4, 25.0), np.arange(4.0)
    share = 0.7
    assert drive_current("current_limiter", 5.0, 25.0, share) == pytest.approx(0.7 * P.driver_gain * 5.0)
    buses = np.arange(8.0, 1.5, -0.001)
    twin = buses[np.argmin(np.abs(wm.emf_current_limit(buses, 25.0, P) - share * P.driver_gain * 5.0))]
    assert drive_current("bus_voltage", u, w, twin) == pytest.approx(np.full(4, 0.665), abs=2e-4)
    assert other_family_misfit("current_limiter", u, w, t, np.full(4, share)) < DECISIVE
    assert not told_apart(other_family_misfit("bus_voltage", u, w, t, np.full(4, twin)))


def test_commands_that_vary_under_the_cap_tell_them_apart():
    # a bus drop caps every command above its EMF limit at one current; a share scales each command's current,
    # so commands of 1-5 V at one speed, up and down, give a cap (flat) against a line through zero (in order,
    # 1, 2, 3 ... V, a cap that ramps could follow a share's rise: the order is part of the evidence)
    u, w, t = np.array([1.0, 5.0, 2.0, 4.0, 3.0]), np.full(5, 25.0), np.arange(5.0)
    assert told_apart(other_family_misfit("bus_voltage", u, w, t, np.full(5, 5.0)))
    assert told_apart(other_family_misfit("current_limiter", u, w, t, np.full(5, 0.5)))


def test_told_apart_is_the_identifiers_margin_reached_in_95_percent_of_runs():
    # the margin ~ (sqrt(D) + z)^2: at D = TOLD_APART it is below DECISIVE only where z < -1.645
    z = np.random.default_rng(0).standard_normal(200_000)
    assert np.mean((np.sqrt(TOLD_APART) + z) ** 2 >= DECISIVE) == pytest.approx(0.95, abs=0.005)
    assert told_apart(TOLD_APART) and not told_apart(DECISIVE)


def test_the_misfit_grows_with_the_samples_that_show_it():
    u = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    few = other_family_misfit("bus_voltage", u[:2], np.full(2, 25.0), np.arange(2.0), np.full(2, 5.0))
    many = other_family_misfit("bus_voltage", u, np.full(5, 25.0), np.arange(5.0), np.full(5, 5.0))
    assert many > few


def test_no_samples_and_other_kinds():
    assert other_family_misfit("current_limiter", [], [], [], []) == float("inf")
    with pytest.raises(ValueError, match="not a drive fault"):
        drive_current("temperature", 1.0, 10.0, 100.0)


def _brute_force(kind, u, w, t, values, other_grid):
    """D by exhaustion: every beginning j and every ramp between two values of a fine grid."""
    from rw_fdi_ros.core.fdi.identification import SIGMA_FLOOR
    other = "bus_voltage" if kind == "current_limiter" else "current_limiter"
    truth = P.torque_constant * drive_current(kind, u, w, values)
    healthy = P.torque_constant * drive_current(other, u, w, 1.0 if other == "current_limiter" else 8.0)
    best = np.inf
    for j in range(u.size):
        s = (t[j:] - t[j]) / max(t[-1] - t[j], 1e-9)
        theta = other_grid[:, None, None] + (other_grid[None, :, None] - other_grid[:, None, None]) * s
        rss = ((P.torque_constant * drive_current(other, u[j:], w[j:], theta) - truth[j:]) ** 2).sum(-1).min()
        best = min(best, (((healthy[:j] - truth[:j]) ** 2).sum() + rss) / SIGMA_FLOOR**2)
    return best


@pytest.mark.parametrize("kind, values, u, w", [
    ("bus_voltage", [4.9553] * 3, [3.42, 4.92, 5.0], [24.58, 23.59, 22.71]),     # a step, the speed falling
    ("current_limiter", [0.8571] * 4, [2.45, 2.67, 2.81, 2.89], [29.91, 29.75, 29.7, 29.72]),
    ("bus_voltage", [7.0, 6.0, 5.0, 4.5], [1.0, 5.0, 2.0, 5.0], [20.0, 20.5, 21.0, 21.5]),   # a ramp
])
def test_the_search_finds_what_exhaustion_finds(kind, values, u, w):
    u, w, values = np.array(u), np.array(w), np.array(values)
    t = np.arange(u.size, dtype=float)
    grid = np.linspace(0.0, 1.0, 1001) if kind == "bus_voltage" else np.linspace(1.5, 8.0, 1301)
    brute = _brute_force(kind, u, w, t, values, grid)
    found = other_family_misfit(kind, u, w, t, values)
    # every value the search returns is some ramp's own misfit, so never below the true least one: at most
    # exhaustion's on a fine grid, it is the least
    assert found <= brute + 1e-6 * max(brute, 1.0)


def test_control_steps_are_compared_as_the_fdi_samples_they_make():
    # ten equal steps a period are the one sample they average to
    u, w, t = np.array([1.0, 5.0, 2.0, 4.0]), np.array([25.0, 25.5, 26.0, 26.5]), np.arange(1.0, 5.0)
    per_sample = other_family_misfit("bus_voltage", u, w, t, np.full(4, 5.0))
    steps = other_family_misfit("bus_voltage", np.repeat(u, 10), np.repeat(w, 10),
                                np.arange(0.1, 4.05, 0.1), np.full(40, 5.0), period=1.0)
    assert steps == pytest.approx(per_sample, rel=1e-3)
    # periods whose commands average 3 V alike, one swinging 1-5 V, the next held at 3 V: a share gives the
    # two the same mean torque, a cap clips the swinging one's 5-V steps only, which its mean shows
    swing = np.tile(np.concatenate([np.tile([1.0, 5.0], 5), np.full(10, 3.0)]), 2)
    inside = other_family_misfit("bus_voltage", swing, np.full(40, 25.0), np.arange(0.1, 4.05, 0.1),
                                 np.full(40, 5.0), period=1.0)
    at_means = other_family_misfit("bus_voltage", np.full(4, 3.0), np.full(4, 25.0), np.arange(1.0, 5.0),
                                   np.full(4, 5.0))
    assert at_means < 1.0 and told_apart(inside)


def test_a_latent_bus_drop_is_a_current_loss_beginning_where_the_command_rises():
    # a bus at 5.2 V caps nothing at 1.4 V and 25 rad/s; the command rises to 5 V at 2.3 s, inside an FDI sample,
    # and from then on the cap gives 0.28 A: a current loss beginning at that control step, share 0.28 / 0.95,
    # gives every step the same current, so nothing tells them apart (onsets on a sample's edge only: D = 459)
    t = np.round(np.arange(0.1, 6.05, 0.1), 6)
    u, w, bus = np.where(t > 2.3 + 1e-9, 5.0, 1.4), np.full(t.size, 25.0), np.full(t.size, 5.2)
    assert drive_current("bus_voltage", 1.4, 25.0, 5.2) == drive_current("bus_voltage", 1.4, 25.0, 8.0)
    assert other_family_misfit("bus_voltage", u, w, t, bus, period=1.0) < 1.0
    # a command that moves under the cap after it (3 V for a sample) tells them apart again
    u[(t > 4.0) & (t <= 5.0)] = 3.0
    assert told_apart(other_family_misfit("bus_voltage", u, w, t, bus, period=1.0))
