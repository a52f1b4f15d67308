"""The redundant wheel: wheel sets, minimum-norm allocation, the N-wheel plant and the FDIR decision."""
from types import SimpleNamespace

import numpy as np
import pytest

from rw_fdi_ros.core.fdi.pipeline import LoadedFdi
from rw_fdi_ros.core.control.allocation import TorqueAllocator, distribution, limited
from rw_fdi_ros.core.flight import Fdir
from rw_fdi_ros.core.closed_loop import simulate
from rw_fdi_ros.core.fdi.threshold_file import ThresholdCurves
from rw_fdi_ros.core.fdir import (SATURATED_S, DecisionDelay, DeliveryLog, Reconfiguration, held_speeds,
                                  momentum_shortfall, slew_excursion)
from rw_fdi_ros.core.physics.plant import Plant
from rw_fdi_ros.core.mission.scenario import Fault, Scenario, ScenarioError, parse_scenario
from rw_fdi_ros.core.physics.wheel import WheelParams
from rw_fdi_ros.core.fdi.elman import network_wheel
from rw_fdi_ros.core.physics.wheel_set import AXIS_WHEELS, WHEEL_SETS, WheelSet, fitted_for
from rw_fdi_ros.paths import fdi_dir

SKEW = WHEEL_SETS["orthogonal_skew"]
PYRAMID = WHEEL_SETS["pyramid"]


def test_wheel_sets_span_the_body_with_any_three_wheels():
    for ws in (SKEW, PYRAMID):
        for lost in ws.names:
            assert ws.spans([n for n in ws.names if n != lost])
    assert not SKEW.spans(["x", "y"])
    # the pyramid's elevation gives the same capability about every axis: G G^T = (4/3) I
    np.testing.assert_allclose(PYRAMID.matrix @ PYRAMID.matrix.T, 4.0 / 3.0 * np.eye(3), atol=1e-12)
    with pytest.raises(ValueError, match="span"):
        WheelSet("flat", ("a", "b", "c"), ((1, 0, 0), (0, 1, 0), (1, 0, 0)))


def test_a_run_draws_each_active_wheels_speed_and_three_axis_speeds_spread_minimum_norm():
    """The pyramid's draw spread the thesis' three axis speeds minimum-norm, which left p3 and p4 near zero
    (medians -4 rad/s) and crossing it in a third of the runs: a run draws each active wheel's speed."""
    sc = parse_scenario("{name: p, vehicle: microsat_pyramid, duration: 10, seed: 5}")
    speeds = Plant(sc).wheel_speed[0]
    assert speeds.shape == (4,) and np.all((speeds >= 20.0) & (speeds <= 30.0))
    axis = np.array([25.0, 20.0, 30.0])   # a scenario's three: their momentum, the minimum-norm speeds
    spread = PYRAMID.initial_speeds(axis)
    np.testing.assert_allclose(PYRAMID.matrix @ spread, axis, atol=1e-12)
    np.testing.assert_allclose(spread, np.linalg.pinv(PYRAMID.matrix) @ axis, atol=1e-12)
    np.testing.assert_array_equal(SKEW.initial_speeds(axis), [25.0, 20.0, 30.0, 0.0])   # s at rest
    given = parse_scenario("{name: g, vehicle: microsat_pyramid, initial: {wheel_speed: [1, 2, 3, 4]}}")
    np.testing.assert_array_equal(Plant(given).wheel_speed[0], [1.0, 2.0, 3.0, 4.0])
    with pytest.raises(ScenarioError, match=r"initial.wheel_speed: expected a list of 3 numbers \(x, y, z\) or 4 "
                                            r"\(every wheel in use\)"):
        parse_scenario("{name: b, vehicle: microsat_pyramid, initial: {wheel_speed: [1, 2]}}")


def test_a_wheel_without_a_design_of_its_own_takes_its_types_by_one_rule():
    """The redundant s runs x's network and the widest of the three threshold curves; x, y, z their own."""
    assert fitted_for("y", AXIS_WHEELS) == ("y",) and fitted_for("s", AXIS_WHEELS) == AXIS_WHEELS
    assert network_wheel("s") == "x" and network_wheel("z") == "z"
    curves = ThresholdCurves("model", {"x": np.array([1.0, 2.0]), "y": np.array([3.0, 1.0]), "z": np.array([0.5])})
    assert [curves.at("s", k) for k in (0, 1, 9)] == [3.0, 2.0, 2.0] and curves.at("y", 9) == 1.0


def test_allocation_is_the_minimum_norm_solution_and_gives_unused_wheels_nothing():
    rng = np.random.default_rng(0)
    for ws, in_use in ((SKEW, ("y", "z", "s")), (SKEW, ("x", "y", "z", "s")), (PYRAMID, PYRAMID.names),
                       (PYRAMID, ("p1", "p2", "p4"))):
        d = distribution(ws.matrix, ws.mask(in_use))
        v = rng.normal(size=3)
        u = d @ v
        np.testing.assert_allclose(ws.matrix @ u, v, atol=1e-12)          # the demanded body torque
        assert np.all(u[~ws.mask(in_use)] == 0.0)                          # nothing to a wheel out of use
        g = ws.matrix[:, ws.mask(in_use)]
        np.testing.assert_allclose(u[ws.mask(in_use)], np.linalg.pinv(g) @ v, atol=1e-12)   # minimum norm
    # three orthogonal wheels in use: the identity, exactly (the thesis' loop is unchanged)
    a = TorqueAllocator(SKEW, 2)
    v = rng.uniform(-5, 5, (2, 3))
    assert np.array_equal(a.wheel_commands(v), np.concatenate([v, np.zeros((2, 1))], axis=1))


def test_the_voltage_limit_scales_the_command_and_keeps_its_direction():
    a = TorqueAllocator(SKEW, 1)
    a.use(("y", "z", "s"))
    u = a.wheel_commands([[4.0, 0.0, 0.0]])[0]     # the skew wheel alone gives x: it needs 4 sqrt(3) V
    assert np.abs(u).max() == pytest.approx(5.0)
    body = SKEW.matrix @ u
    np.testing.assert_allclose(body / np.linalg.norm(body), [1.0, 0.0, 0.0], atol=1e-12)
    assert np.array_equal(limited([[1.0, -2.0]], 5.0), [[1.0, -2.0]])


def test_the_friction_feedforward_cancels_every_wheels_friction_in_closed_form():
    """u_ff = m u_f(Omega) + D G (c u_f(Omega)): each wheel in use its own holding voltage; a coasting wheel's
    friction given back along its spin axis by the wheels in use (x, y, z orthogonal: D is the identity on
    them, so each adds u_f(Omega_s) / sqrt(3)); a held wheel is left to its own hold command."""
    from rw_fdi_ros.core.control.allocation import friction_feedforward
    from rw_fdi_ros.core.physics.wheel import holding_tcv
    speed = np.array([[30.0, -12.0, 0.4, 25.0]])
    hold = holding_tcv(speed, 23.0)
    a = TorqueAllocator(SKEW, 1, feedforward=True)
    at_rest = speed * [1.0, 1.0, 1.0, 0.0]   # s standing by at rest: no friction to give back
    np.testing.assert_allclose(a.friction_commands(at_rest), [[*hold[0, :3], 0.0]], rtol=1e-12)
    expected = hold[0, :3] + hold[0, 3] / np.sqrt(3.0)
    np.testing.assert_allclose(a.friction_commands(speed)[0, :3], expected, rtol=1e-12)
    # the body torque of the commands is what the coasting wheel's own motor would give at u_f (-G_d k_t G u)
    np.testing.assert_allclose(SKEW.matrix @ (a.friction_commands(speed)[0] - [*hold[0, :3], 0.0]),
                               SKEW.matrix[:, 3] * hold[0, 3], atol=1e-15)
    a.use(("x", "y", "s"), held={"z": 0.4})   # z held: neither in use nor coasting
    u = friction_feedforward(speed, a.in_use, ~a.in_use & ~a.held, a._dist, SKEW.matrix)
    np.testing.assert_allclose(a.friction_commands(speed), u, rtol=1e-12)
    assert u[0, 2] == 0.0 and u[0, 3] == pytest.approx(hold[0, 3])
    # without the option nothing changes: the thesis' loop
    assert np.array_equal(TorqueAllocator(SKEW, 1).friction_commands(speed), np.zeros((1, 4)))


def test_a_light_body_keeps_its_pointing_as_a_given_up_wheel_coasts_to_rest_with_the_feedforward():
    """The CubeSat, +150 C on y (the recovery bench's tuning seed 85,300,003): y given up coasts down on its
    friction and stops, and z crosses zero speed as s takes the momentum. Without the feed-forward each step
    costs 0.3 deg while the integrators catch up; with it the pointing stays within 0.2 deg from 60 s after the
    onset."""
    from dataclasses import replace
    from rw_fdi_ros.fdi_config import FdiConfig
    from rw_fdi_ros.tools.benches.recovery_bench import SEED_BASES, cell_scenarios, cells_of
    index, cell = next((i, c) for i, c in cells_of("cubesat_6u")
                       if c.name == "temperature +150 C, wheels 200-300 rad/s")
    scenario = next(s for s in cell_scenarios(cell, 14, index, SEED_BASES["tuning"], "cubesat_6u")
                    if s.seed == 85_300_003)
    assert scenario.vehicle.controller.friction_feedforward
    _, curves = FdiConfig().for_vehicle("cubesat_6u").load()
    worst = {}
    for feedforward in (True, False):
        vehicle = replace(scenario.vehicle, controller=replace(scenario.vehicle.controller,
                                                               friction_feedforward=feedforward))
        traj = simulate(replace(scenario, vehicle=vehicle), fdir=Fdir(LoadedFdi(curves)))
        assert [(d.wheel, d.action) for d in traj.decisions[0]][:1] == [("y", "out_of_use")]
        after = traj.time >= scenario.faults[0].onset + 60.0
        worst[feedforward] = float(np.degrees(np.abs(traj.error[after, 0])).max())
        assert abs(traj.wheel_speed[-1, 0, 1]) < 1.0   # y came to rest
    assert worst[True] < 0.2 < worst[False], worst


def _scenario(seconds=60.0, faults=(), wheel_set="orthogonal_skew", seed=3):
    return Scenario("t", duration=seconds, seed=seed, faults=tuple(faults), plant={"wheel_set": wheel_set})


def test_a_standby_wheel_changes_nothing_until_it_is_used():
    """The x, y, z wheels and the body run bit for bit as the three-wheel set's while s waits."""
    faults = [Fault("current_limiter", 0, 20.0, 0.6), Fault("temperature", 2, 30.0, 80.0)]
    runs = {ws: simulate([_scenario(faults=faults, wheel_set=ws), _scenario(seed=4, wheel_set=ws)])
            for ws in ("orthogonal", "orthogonal_skew")}
    three, four = runs["orthogonal"], runs["orthogonal_skew"]
    assert np.array_equal(three.attitude, four.attitude)
    for key in ("wheel_speed", "tcv", "reaction_torque", "fault_effect"):
        assert np.array_equal(getattr(three, key), getattr(four, key)[..., :3]), key
        assert np.all(getattr(four, key)[..., 3] == 0.0), key


def test_angular_momentum_is_conserved_with_the_skew_wheel_spinning():
    """No external torque: |I w + J G Omega| holds whatever the four wheels are commanded (Euler)."""
    plant = Plant(_scenario(), disturbance=False, wheels=SKEW)
    j = plant.wheel.inertia
    def momentum():
        return np.linalg.norm(plant.inertia * plant.body_rate[0] + j * SKEW.matrix @ plant.wheel_speed[0])
    h0 = momentum()
    rng = np.random.default_rng(1)
    for _ in range(300):
        plant.step(rng.uniform(-5, 5, (1, 4)))
    assert not plant.locked.any()
    assert abs(plant.wheel_speed[0, 3]) > 1.0          # s was released and spun
    assert momentum() == pytest.approx(h0, rel=1e-9)


def test_a_locked_standby_wheel_is_released_by_its_first_command():
    plant = Plant(_scenario(), wheels=SKEW)
    assert plant.locked[0].tolist() == [False, False, False, True]
    plant.step([[1.0, 1.0, 1.0, 0.0]])
    assert plant.locked[0, 3] and plant.wheel_speed[0, 3] == 0.0
    plant.step([[1.0, 1.0, 1.0, 0.5]])
    assert not plant.locked[0, 3] and plant.wheel_speed[0, 3] > 0.0


def test_reconfiguration_brings_the_standby_in_once_and_keeps_a_wheel_it_cannot_replace():
    r = Reconfiguration(SKEW)
    first = r.give_up("x", 10.0, "confirmed")
    assert [(d.wheel, d.action) for d in first] == [("x", "out_of_use"), ("s", "in_use")]
    assert r.ordered_in_use() == ("y", "z", "s") and r.give_up("x", 11.0, "again") == []
    kept = r.give_up("y", 20.0, "confirmed")   # y, z, s: without y nothing gives torque about y
    assert [(d.wheel, d.action) for d in kept] == [("y", "kept_in_use")]
    assert r.ordered_in_use() == ("y", "z", "s")
    p = Reconfiguration(PYRAMID)   # no standby: one of four can go, the other three still span
    assert [d.action for d in p.give_up("p1", 1.0, "c")] == ["out_of_use"] and len(p.in_use) == 3
    with pytest.raises(ValueError, match="one of"):
        r.give_up("w", 1.0, "typo")


def test_the_momentum_a_replacement_must_hold():
    """x out, s in: s carries the x momentum at 1/sqrt(3), so it spins sqrt(3) times as fast."""
    speeds = np.array([20.0, 25.0, 24.0, 0.0])
    need = held_speeds(SKEW, ("y", "z", "s"), speeds)
    np.testing.assert_allclose(need, [0.0, 5.0, 4.0, 20.0 * np.sqrt(3.0)], atol=1e-12)
    assert momentum_shortfall(SKEW, ("y", "z", "s"), speeds, slew_rate=0.0) is None
    assert "47.6 rad/s" in momentum_shortfall(SKEW, ("y", "z", "s"), [27.5, 25.0, 24.0, 0.0], slew_rate=0.0)


def test_the_share_of_its_torque_a_wheel_gives_is_the_current_loss_family_fit():
    """a^ = sum tau_m (tau_f - r) / sum tau_m^2: exactly a for a wheel whose motor gives a tau_m (closed form),
    NaN where it was asked for no torque; the log keeps the last samples of each wheel of each run."""
    from rw_fdi_ros.core.fdir import DeliveryLog, delivered_share
    from rw_fdi_ros.core.fdi.telemetry import model_reaction_torque
    u, w = np.linspace(0.5, 3.0, 10), np.linspace(20.0, 21.0, 10)
    model, tau_m, _ = model_reaction_torque(u, w)
    tau_f = model + tau_m
    assert delivered_share(u, w, -(0.6 * tau_m - tau_f)) == pytest.approx(0.6, rel=1e-12)
    assert delivered_share(u, w, model) == pytest.approx(1.0, rel=1e-12)
    assert np.isnan(delivered_share(np.zeros(10), np.zeros(10), np.zeros(10)))
    log = DeliveryLog(3)
    for k in range(5):
        log.add([[u[k], 0.0], [u[k], u[k]]], [[w[k], 0.0], [w[k], w[k]]],
                [[model[k], 0.0], [-(0.3 * tau_m[k] - tau_f[k]), model[k]]])
    assert len(log.rows) == 3 and log.share(0, 0) == pytest.approx(1.0) and log.share(0, 1) == pytest.approx(0.3)
    assert np.isnan(log.share(1, 0)) and np.isnan(DeliveryLog().share(0))


def test_a_slew_moves_each_wheel_by_its_share_of_the_body_momentum():
    """dOmega_i = sum_a |D_ia| I_a w / J: the identity on three orthogonal wheels; s in for x moves by
    sqrt(3) times as much as x did, and y, z, which cancel its cross-axis torque, by more still."""
    rate, j = np.deg2rad(0.5), WheelParams().inertia
    np.testing.assert_allclose(slew_excursion(SKEW, ("x", "y", "z"), rate), [17 * rate / j, 15 * rate / j,
                                                                              22 * rate / j, 0.0], rtol=1e-12)
    moved = slew_excursion(SKEW, ("y", "z", "s"), rate)
    np.testing.assert_allclose(moved[3], np.sqrt(3.0) * 17 * rate / j, rtol=1e-12)
    np.testing.assert_allclose(moved[1:3], [(15 + 17) * rate / j, (22 + 17) * rate / j], rtol=1e-12)
    assert moved[0] == 0.0 and slew_excursion(SKEW, ("y", "z", "s"), 0.0).max() == 0.0
    assert "more for a slew" in momentum_shortfall(SKEW, ("y", "z", "s"), [20.0, 25.0, 24.0, 0.0])
    assert momentum_shortfall(SKEW, ("y", "z", "s"), [0.5, 0.5, 0.5, 0.0], slew_rate=np.deg2rad(0.1)) is None


def test_a_wheel_the_others_could_not_replace_is_kept_beside_the_spare_or_held():
    """The wheels left could not hold the momentum and slew: the confirmed wheel stays in use beside s (all
    four share the work), said why; with no spare left, a further one is held at its speed (a momentum
    store); an operator's command gives a wheel up all the same."""
    r = Reconfiguration(SKEW)
    kept = r.give_up("x", 5.0, "confirmed", [27.5, 25.0, 24.0, 0.0])
    assert [(d.wheel, d.action) for d in kept] == [("x", "kept_in_use"), ("s", "in_use")]
    assert "47.6 rad/s" in kept[0].reason and "beside wheel s" in kept[0].reason
    assert r.ordered_in_use() == ("x", "y", "z", "s") and "x" in r.settled and not r.spares
    assert r.give_up("x", 6.0, "confirmed", [27.5, 25.0, 24.0, 0.0]) == []       # decided once
    held = r.give_up("y", 8.0, "confirmed", [27.5, 25.0, 24.0, 30.0])
    assert [(d.wheel, d.action) for d in held] == [("y", "held")] and r.held == {"y": 25.0}
    assert r.ordered_in_use() == ("x", "z", "s")
    forced = Reconfiguration(SKEW).give_up("x", 5.0, "operator", [27.5, 25.0, 24.0, 0.0], force=True)
    assert [d.action for d in forced] == ["out_of_use", "in_use"] and "47.6 rad/s" in forced[1].reason
    assert "dumped" in forced[1].reason
    overruled = r.give_up("y", 9.0, "operator", [20.0, 25.0, 24.0, 10.0], force=True)   # a held wheel given up
    assert [(d.wheel, d.action) for d in overruled] == [("y", "out_of_use")] and not r.held and "y" in r.given_up
    d = DecisionDelay(1.0)
    d.put(10.0, "a")
    assert d.due(10.9) == [] and d.due(11.0) == ["a"] and d.due(12.0) == []


def gave(share, saturated=()):
    """A stand-in for fdir.Delivered: the share each wheel gave, and which were commanded at the limit."""
    return SimpleNamespace(share=share, saturated=lambda w: w in saturated)


def test_a_kept_wheel_that_gives_too_little_is_held_and_a_wheel_past_its_limit_is_said():
    """After a reconfiguration the wheels are watched: x, kept beside s, is held once it gives under half its
    torque (a bus ramping down), not while it gives more or nothing is asked of it; a wheel in use past the
    holdable speed is said once, with the momentum as the reason; before any reconfiguration nothing is."""
    assert Reconfiguration(SKEW).review(1.0, [10.0, 10.0, 46.0, 0.0], gave(lambda w: 0.1)) == []
    r = Reconfiguration(SKEW)
    speeds = [27.5, 25.0, 24.0, 0.0]
    r.give_up("x", 5.0, "confirmed", speeds)
    assert r.beside == {"x": "s"}
    assert r.review(6.0, speeds, gave(lambda w: 0.8)) == []
    assert r.review(6.1, speeds, gave(lambda w: float("nan"))) == []
    held = r.review(7.0, speeds, gave(lambda w: 0.3))
    assert [(d.wheel, d.action) for d in held] == [("x", "held")] and "30.0 %" in held[0].reason
    assert r.held == {"x": 27.5} and r.ordered_in_use() == ("y", "z", "s") and "x" in r.settled and not r.kept
    assert r.review(7.1, speeds, gave(lambda w: 0.1)) == []
    said = r.review(8.0, [20.0, 25.0, 24.0, -45.5], gave(lambda w: 0.1))
    assert [(d.wheel, d.action) for d in said] == [("s", "at_limit")] and "dumped" in said[0].reason
    assert "at its limit" in said[0].message()
    assert r.review(8.1, [20.0, 25.0, 24.0, -46.0], gave(lambda w: 0.1)) == []   # said once
    assert r.review(8.2, [46.0, 25.0, 24.0, 0.0], gave(lambda w: 0.1)) == []     # a held wheel is not in use


def test_a_kept_wheel_that_gives_too_little_with_no_wheel_left_is_said_once():
    """x kept beside s, then y held (no spare left): x giving under half its torque cannot be held too (z and s
    alone do not span the body), so it is said, once, with the pointing lost about its axis as the reason."""
    r = Reconfiguration(SKEW)
    r.give_up("x", 5.0, "confirmed", [27.5, 25.0, 24.0, 0.0])
    r.give_up("y", 8.0, "confirmed", [27.5, 25.0, 24.0, 30.0])
    assert r.ordered_in_use() == ("x", "z", "s")
    assert r.review(9.0, [27.5, 25.0, 24.0, 30.0], gave(lambda w: 0.8)) == []
    said = r.review(10.0, [27.5, 25.0, 24.0, 30.0], gave(lambda w: 0.3 if w == "x" else 1.0))
    assert [(d.wheel, d.action) for d in said] == [("x", "at_limit")]
    assert "30.0 %" in said[0].reason and "no wheel is left" in said[0].reason and "pointing is lost" in said[0].reason
    assert r.ordered_in_use() == ("x", "z", "s") and r.review(11.0, [27.5, 25.0, 24.0, 30.0], gave(lambda w: 0.1)) == []


def test_a_wheel_in_use_commanded_at_the_limit_for_long_after_a_reconfiguration_is_said_once():
    """A wheel whose friction takes the whole 5 V under the holdable speed (a unit) gives all it can: after a
    reconfiguration, s at the limit for SATURATED_S of FDI stamps is said, once; a shorter saturation (a slew's
    start) is not, and the count starts again when the command comes off the limit."""
    r = Reconfiguration(SKEW)
    r.give_up("x", 5.0, "confirmed", [27.5, 25.0, 24.0, 0.0])
    speeds = [27.5, 25.0, 24.0, 40.4]
    at_limit = gave(lambda w: 1.0, saturated={"s"})
    assert all(r.review(t, speeds, at_limit) == [] for t in np.arange(10.0, 10.0 + SATURATED_S))
    assert r.review(40.5, speeds, gave(lambda w: 1.0)) == []                   # off the limit: counted afresh
    assert all(r.review(t, speeds, at_limit) == [] for t in np.arange(41.0, 41.0 + SATURATED_S))
    said = r.review(41.0 + SATURATED_S, speeds, at_limit)
    assert [(d.wheel, d.action) for d in said] == [("s", "at_limit")] and "40.4 rad/s" in said[0].reason
    assert "pointing is lost" in said[0].reason and r.review(100.0, speeds, at_limit) == []
    assert r.review(101.0, speeds, None) == []                                 # between FDI stamps: not judged
    log = DeliveryLog()
    for u in [[5.0, 1.0, 0.0, -5.0]] * 9 + [[5.0, 1.0, 0.0, -4.9]]:
        log.add(u, [30.0, 0.0, 0.0, 40.0], [0.0, 0.0, 0.0, 0.0])
    delivered = log.of(SKEW.names)
    assert delivered.saturated("x") and not delivered.saturated("y") and not delivered.saturated("s")


def test_the_loop_reconfigures_on_a_confirmed_failure_and_points_again():
    """40 % current loss on x at 150 s: the FDI confirms it; s could not take x's momentum and still slew, so
    x stays in use beside s (all four share the work) and the pointing error is back within 0.2 deg within
    60 s of the onset. With slews no faster than 0.05 deg/s the three left could take it all: x is given up,
    0 V from the decision on."""
    curves = ThresholdCurves.load(fdi_dir("speed_aware") / "thresholds_model.json", "model")
    scenario = _scenario(300.0, [Fault("current_limiter", 0, 150.0, 0.6)], seed=11)
    traj = simulate([scenario], fdir=Fdir(LoadedFdi({"model": curves})))
    decisions = traj.decisions[0]
    assert [(d.wheel, d.action) for d in decisions] == [("x", "kept_in_use"), ("s", "in_use")]
    assert 150.0 < decisions[0].time < 160.0 and "more for a slew" in decisions[0].reason
    assert traj.in_use[-1, 0].tolist() == [True, True, True, True]
    error = np.degrees(np.abs(traj.error[:, 0])).max(axis=1)
    assert error[traj.time >= 210.0].max() < 0.2
    gentle = simulate([scenario], fdir=Fdir(LoadedFdi({"model": curves}), slew_rate=np.deg2rad(0.05)))
    decisions = gentle.decisions[0]
    assert [(d.wheel, d.action) for d in decisions] == [("x", "out_of_use"), ("s", "in_use")]
    after = gentle.time > decisions[0].time   # a sample shows the command held over the step before it
    assert np.all(gentle.tcv[after, 0, 0] == 0.0)           # never a command to the wheel given up
    assert gentle.in_use[-1, 0].tolist() == [False, True, True, True]
    error = np.degrees(np.abs(gentle.error[:, 0])).max(axis=1)
    assert error[gentle.time >= 210.0].max() < 0.2


def test_a_scenario_names_the_wheels_of_its_set():
    s = parse_scenario("name: a\nplant: {wheel_set: orthogonal_skew}\nfaults:\n"
                       "  - {kind: temperature, wheel: s, onset: 5, value: 100}\n")
    assert s.faults[0].wheel == 3 and s.faults[0].as_dict(SKEW.names)["wheel"] == "s"
    default = parse_scenario("name: a\nfaults:\n  - {kind: temperature, wheel: s, onset: 5, value: 1}\n")
    assert default.faults[0].wheel == 3
    with pytest.raises(ScenarioError, match="one of x, y, z, got 's'"):   # the three-wheel set has no s
        parse_scenario("name: a\nplant: {wheel_set: orthogonal}\nfaults:\n"
                       "  - {kind: temperature, wheel: s, onset: 5, value: 100}\n")
    with pytest.raises(ScenarioError, match="wheel_set must be one of"):
        parse_scenario("name: a\nplant: {wheel_set: hexagon}\n")
    units = Scenario("u", seed=7, wheels={"variation": True})
    three, four = units.unit_scales(3), units.unit_scales(4)
    for name in three:   # the redundant wheel's unit is drawn apart: the three keep theirs
        assert np.array_equal(three[name], four[name][:3]) and four[name][3] != 1.0
    assert WheelParams().inertia == pytest.approx(0.0077)


def test_the_hold_command_cancels_friction_at_the_reference_and_pulls_back_to_it():
    """u = u_f(Omega_ref) + k (Omega_ref - Omega): at the reference the wheel's net torque is zero
    (closed form, eq. 2.15's friction), off it the command pulls it back, and it stays in +-5 V."""
    from rw_fdi_ros.core.control.allocation import HOLD_GAIN, hold_command
    from rw_fdi_ros.core.physics.wheel import friction_torque
    p = WheelParams()
    u = hold_command(30.0, 30.0)
    assert p.driver_gain * p.torque_constant * u == pytest.approx(float(friction_torque(30.0, 23.0, p)), rel=1e-12)
    assert hold_command(30.0, 29.0) == pytest.approx(u + HOLD_GAIN)
    assert hold_command(30.0, 0.0) == 5.0 and hold_command(-30.0, 0.0) == -5.0
    a = TorqueAllocator(SKEW, 1)
    a.use(("y", "z", "s"), held={"x": 30.0})
    out = a.wheel_commands([[1.0, 0.0, 0.0]], [[30.0, 0.0, 0.0, 0.0]])[0]
    assert out[0] == pytest.approx(u) and np.allclose(SKEW.matrix[:, 1:] @ out[1:], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="wheel speeds"):
        a.wheel_commands([[1.0, 0.0, 0.0]])


def test_a_wheel_whose_momentum_the_others_cannot_take_is_held_and_the_pointing_recovers():
    """Bus 5.5 V on x at 30 rad/s: giving x up would ask s for 52 rad/s and a slew more, and x gives under
    half its torque (its bus cannot drive it at this speed), too little to keep in use: x is held out of
    control and s comes in; x slows to the speed its bus can hold (wheel.bus_fault_visible_above: 23.5
    rad/s) and s takes only the momentum it sheds; the pointing is within 0.2 deg again within 60 s of the
    onset."""
    from rw_fdi_ros.core.physics.wheel import bus_fault_visible_above
    curves = ThresholdCurves.load(fdi_dir("speed_aware") / "thresholds_model.json", "model")
    scenario = Scenario("t", duration=400.0, seed=5, faults=(Fault("bus_voltage", 0, 150.0, 5.5),),
                        initial={"wheel_speed": (30.0, 25.0, 24.0)}, plant={"wheel_set": "orthogonal_skew"})
    traj = simulate([scenario], fdir=Fdir(LoadedFdi({"model": curves})))
    assert [(d.wheel, d.action) for d in traj.decisions[0]] == [("x", "held"), ("s", "in_use")]
    assert "% of its torque" in traj.decisions[0][0].reason
    assert traj.wheel_speed[-1, 0, 0] == pytest.approx(bus_fault_visible_above(5.5), abs=0.5)
    assert traj.in_use[-1, 0].tolist() == [False, True, True, True]
    after = traj.time > traj.decisions[0][0].time
    assert np.all(traj.tcv[after, 0, 0] > 0.0)           # held: commanded, never 0 V
    error = np.degrees(np.abs(traj.error[:, 0])).max(axis=1)
    assert error[traj.time >= 210.0].max() < 0.2


def test_a_benchs_fault_goes_on_a_wheel_in_use_of_its_set():
    """Counts are data: the wheel is drawn from the seed over the set's wheels in use (x, y, z of the default
    set, s standing by; all four of a pyramid), every one of them hit."""
    from rw_fdi_ros.tools.benches.kit import fault_wheel
    skew, pyramid = WHEEL_SETS["orthogonal_skew"], WHEEL_SETS["pyramid"]
    assert {skew.names[fault_wheel(s, skew)] for s in range(100)} == set(skew.active) == {"x", "y", "z"}
    assert {fault_wheel(s, pyramid) for s in range(100)} == {0, 1, 2, 3}


def test_a_held_wheel_whose_drive_gives_next_to_nothing_is_said_not_to_keep_its_speed():
    """Bus 4 V on x at 30 rad/s: held (its momentum does not fit the wheels left), giving under 5 % of its torque,
    it brakes to the speed its bus can drive; the decision says so rather than promise the speed it is held at."""
    curves = ThresholdCurves.load(fdi_dir("speed_aware") / "thresholds_model.json", "model")
    scenario = Scenario("t", duration=260.0, seed=5, faults=(Fault("bus_voltage", 0, 150.0, 4.0),),
                        initial={"wheel_speed": (30.0, 25.0, 24.0)}, plant={"wheel_set": "orthogonal_skew"})
    traj = simulate([scenario], fdir=Fdir(LoadedFdi({"model": curves})))
    held = traj.decisions[0][0]
    assert (held.wheel, held.action) == ("x", "held") and "too little to hold that speed" in held.reason
    speed_held = float(held.reason.split("held at ")[1].split(" rad/s")[0])
    assert traj.wheel_speed[-1, 0, 0] < 0.5 * speed_held   # it did not keep it


def test_one_observers_bands_with_a_unit_calibration_are_that_observer_learning_its_wheels():
    """Fdir(curves, calibration_samples=150), the form in-service scripts write, is the LoadedFdi of that one
    observer learning each wheel's unit over 150 samples; a LoadedFdi with it besides is refused."""
    curves = ThresholdCurves.load(fdi_dir("speed_aware") / "unit_calibrated" / "thresholds_model.json", "model")
    short = Fdir(curves, calibration_samples=150)
    assert short.fdi == LoadedFdi({"model": curves}, calibration_samples=150)
    with pytest.raises(ValueError, match="calibration_samples goes with one observer's bands"):
        Fdir(LoadedFdi({"model": curves}), calibration_samples=150)


def test_the_null_space_hold_turns_no_axis_and_returns_the_pyramids_null_speed_with_its_time_constant():
    """P_N = M - D G_u: symmetric, idempotent, G P_N = 0, none with three wheels in use; the hold's commands
    u_n = -k_n P_N (Omega - Omega_0) give no body torque, and J dOmega/dt = G_d k_t u_n returns the null-space
    speed to its hold as exp(-t / tau_n)."""
    from rw_fdi_ros.core.control.allocation import null_projector, null_space_gain
    from rw_fdi_ros.core.physics.wheel import WheelParams
    p = null_projector(PYRAMID.matrix, PYRAMID.mask(PYRAMID.names))
    np.testing.assert_allclose(p, p.T, atol=1e-15)
    np.testing.assert_allclose(p @ p, p, atol=1e-15)
    np.testing.assert_allclose(PYRAMID.matrix @ p, 0.0, atol=1e-15)
    assert np.linalg.matrix_rank(p) == 1
    assert null_projector(PYRAMID.matrix, PYRAMID.mask(("p1", "p2", "p4"))) is None
    assert null_projector(SKEW.matrix, SKEW.mask(("x", "y", "z"))) is None
    wheel = WheelParams()
    tau = 10.0
    a = TorqueAllocator(PYRAMID, 1, null_time_constant=tau)
    speed = np.array([[30.0, 20.0, 25.0, 28.0]])
    hold = p @ speed[0]
    assert np.array_equal(a.wheel_commands(np.zeros((1, 3)), speed), np.zeros((1, 4)))   # held where it starts
    kick = speed + 2.0 * p[0]   # 2 rad/s along the null space, nothing else
    dt, u = 0.01, None
    for _ in range(int(tau / dt)):
        u = a.wheel_commands(np.zeros((1, 3)), kick)
        np.testing.assert_allclose(PYRAMID.matrix @ u[0], 0.0, atol=1e-12)   # no body torque
        kick = kick + dt * wheel.driver_gain * wheel.torque_constant * u / wheel.inertia
    left = np.linalg.norm(p @ kick[0] - hold) / np.linalg.norm(2.0 * p[0])
    assert left == pytest.approx(np.exp(-1.0), rel=2e-3)
    assert null_space_gain(0.0) == 0.0
    off = TorqueAllocator(PYRAMID, 1, null_time_constant=0.0)   # no hold: minimum norm alone, no speeds needed
    v = np.array([[1.0, -2.0, 0.5]])
    assert not off.needs_speeds
    np.testing.assert_allclose(off.wheel_commands(v)[0], distribution(PYRAMID.matrix, PYRAMID.mask(PYRAMID.names))
                               @ v[0], rtol=0, atol=1e-15)


def test_a_pyramid_keeps_its_wheels_together_when_a_hot_wheels_friction_error_drives_them_apart():
    """Seed 10,600,003 (p4 +173 C at 134.7 s) on the microsatellite, friction fed forward: without the hold the
    null vector's speed grew until p2 reached its 5-V limit (p1 and p3 at 7-9 rad/s, p2 and p4 at 46-47); with
    it every wheel stays within a few rad/s of where it started and no command reaches the limit."""
    import dataclasses
    sc = parse_scenario("{name: p, vehicle: microsat_pyramid, duration: 600, seed: 10600003, faults: "
                        "[{kind: temperature, wheel: p4, onset: 134.7, value: 173}]}")
    assert sc.vehicle.controller.null_space_time_constant == 10.0
    runs = {}
    for tau in (0.0, 10.0):
        controller = dataclasses.replace(sc.vehicle.controller, null_space_time_constant=tau)
        runs[tau] = simulate([dataclasses.replace(sc, vehicle=dataclasses.replace(sc.vehicle, controller=controller))])
    apart = np.abs(runs[0.0].wheel_speed[-1, 0] - runs[0.0].wheel_speed[0, 0]).max()
    together = np.abs(runs[10.0].wheel_speed[-1, 0] - runs[10.0].wheel_speed[0, 0]).max()
    assert apart > 15.0 and together < 5.0, (apart, together)
    assert np.abs(runs[0.0].wheel_command[:, 0]).max() == pytest.approx(5.0)
    assert np.abs(runs[10.0].wheel_command[:, 0]).max() < 4.9
