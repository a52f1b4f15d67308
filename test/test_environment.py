"""The orbit environment (core/physics/orbit.py, geomagnetic.py, environment.py) against closed-form answers."""
from datetime import datetime, timezone

import numpy as np
import pytest

from rw_fdi_ros.core.physics.environment import (ENVIRONMENT_STEP, Environments, OrbitEnvironment, body_from_inertial,
                                         gravity_gradient_torque)
from rw_fdi_ros.core.physics.geomagnetic import field_inertial
from rw_fdi_ros.core.physics.orbit import MU_EARTH, CircularOrbit, OrbitError, TleOrbit, sidereal_angle
from rw_fdi_ros.core.physics.spacecraft import INERTIA

# an ISS element set (2008, the sgp4 package's documentation example)
ISS = ("1 25544U 98067A   08264.51782528 -.00002182  00000-0 -11606-4 0  2927",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.72125391563537")
EPOCH = datetime(2025, 1, 1, tzinfo=timezone.utc)   # a date of IGRF-14's table: no interpolation


def test_the_thesis_orbit_has_its_period_and_radius():
    orbit = CircularOrbit()
    assert orbit.period / 60.0 == pytest.approx(98.8, abs=0.05)   # thesis 3.1: 98.8 minutes at 700 km
    t = np.linspace(0.0, orbit.period, 50)
    r = orbit.position(t)
    assert np.allclose(np.linalg.norm(r, axis=1), orbit.radius)
    assert np.allclose(r[0], [orbit.radius, 0.0, 0.0]) and np.allclose(r[-1], r[0], atol=1e-3)
    normal = np.cross(r[0], r[5])
    # the orbit normal is inclined by 98.2 deg from the pole
    assert np.degrees(np.arccos(normal[2] / np.linalg.norm(normal))) == pytest.approx(98.2)


def test_a_tle_is_propagated_by_sgp4():
    orbit = TleOrbit(*ISS)
    assert orbit.epoch().year == 2008
    r = orbit.position(np.arange(0.0, 5600.0, 600.0))
    altitude_km = np.linalg.norm(r, axis=1) / 1e3 - 6378.137
    assert np.all((330.0 < altitude_km) & (altitude_km < 370.0))
    with pytest.raises(OrbitError):
        TleOrbit("1 nonsense", "2 nonsense").satellite()


def test_the_sidereal_angle_of_j2000():
    j2000 = datetime(2000, 1, 1, 12, tzinfo=timezone.utc)
    assert np.degrees(sidereal_angle(j2000, 0.0)) == pytest.approx(280.46061837)
    # one sidereal day later the Earth has turned once
    assert np.degrees(sidereal_angle(j2000, 86164.0905)) == pytest.approx(280.46061837, abs=1e-3)


def test_the_tilted_dipole_is_the_closed_form_dipole():
    """The degree-1 terms are the field of a centred dipole along m = (g11, h11, g10) (its potential
    a (a/r)^2 (m . r^) with B = -grad V): B = (a/r)^3 (3 (m . r^) r^ - m), so 2 |m| (a/r)^3 along m^ at either
    end of the axis and -|m| (a/r)^3 m^ across it; at the geographic north pole the field points down."""
    from ppigrf.ppigrf import read_shc
    g, h = read_shc()
    date = EPOCH.replace(tzinfo=None)
    m = np.array([g.loc[date, (1, 1)], h.loc[date, (1, 1)], g.loc[date, (1, 0)]]) * 1e-9
    axis = m / np.linalg.norm(m)
    across = np.cross(axis, [1.0, 0.0, 0.0])
    across /= np.linalg.norm(across)
    r, a = 7078.137e3, 6371.2e3
    points = np.array([r * axis, -r * axis, r * across, [0.0, 0.0, r]])
    field = field_inertial(points, np.zeros(4), EPOCH, "tilted_dipole")
    scale = (a / r) ** 3
    np.testing.assert_allclose(field[0], 2 * scale * m, rtol=1e-9)
    np.testing.assert_allclose(field[1], 2 * scale * m, rtol=1e-9)
    np.testing.assert_allclose(field[2], -scale * m, rtol=1e-9)
    np.testing.assert_allclose(field[3], scale * (3 * m[2] * np.array([0.0, 0.0, 1.0]) - m), rtol=1e-6, atol=1e-12)
    assert field[3][2] < 0.0


def test_the_field_turns_with_the_earth_and_igrf_stays_near_the_dipole():
    orbit = CircularOrbit()
    t = np.arange(0.0, orbit.period, 60.0)
    r = orbit.position(t)
    igrf = field_inertial(r, sidereal_angle(EPOCH, t), EPOCH, "igrf")
    dipole = field_inertial(r, sidereal_angle(EPOCH, t), EPOCH, "tilted_dipole")
    strength = np.linalg.norm(igrf, axis=1)
    assert 15e-6 < strength.min() and strength.max() < 50e-6       # 700 km: about 18-48 uT
    assert np.median(np.linalg.norm(igrf - dipole, axis=1) / strength) < 0.25
    # the same Earth-fixed point after the Earth turned by 0.2 rad: in inertial axes the field turned with it
    one = field_inertial(r[:1], np.array([0.3]), EPOCH)
    turned = field_inertial(_turn(r[:1], 0.2), np.array([0.5]), EPOCH)
    assert np.allclose(turned, _turn(one, 0.2), rtol=1e-9, atol=1e-15)


def _turn(v, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack((c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]), axis=-1)


def test_gravity_gradient_closed_form():
    inertia = np.array(INERTIA)
    r = 7.0e6
    assert np.allclose(gravity_gradient_torque([[r, 0.0, 0.0]], inertia), 0.0)   # along a principal axis
    c = s = np.sqrt(0.5)
    torque = gravity_gradient_torque([[r * c, r * s, 0.0]], inertia)[0]
    assert torque == pytest.approx([0.0, 0.0, 3 * MU_EARTH / r ** 3 * c * s * (inertia[1] - inertia[0])])


def test_the_orbit_mean_gravity_gradient_is_the_textbook_secular_torque():
    """Held inertially, the gravity gradient averages over an orbit to -3/2 n^2 (o x I o), o the orbit
    normal: what drifts the wheels."""
    orbit = CircularOrbit()
    t = np.arange(0.0, orbit.period, 1.0)
    torque = gravity_gradient_torque(orbit.position(t), INERTIA).mean(axis=0)
    normal = np.cross(orbit.position(0.0), orbit.position(1.0))
    o = normal / np.linalg.norm(normal)
    assert torque == pytest.approx(-1.5 * orbit.mean_motion ** 2 * np.cross(o, INERTIA * o), rel=1e-3, abs=1e-12)


def test_the_attitude_rotation():
    rng = np.random.default_rng(0)
    angles = rng.uniform(-np.pi, np.pi, (20, 3))
    c = body_from_inertial(angles)
    assert np.allclose(c @ np.swapaxes(c, 1, 2), np.eye(3)) and np.allclose(np.linalg.det(c), 1.0)
    small = np.array([1e-4, -2e-4, 3e-4])
    skew = np.array([[0, -small[2], small[1]], [small[2], 0, -small[0]], [-small[1], small[0], 0]])
    assert np.allclose(body_from_inertial(small), np.eye(3) - skew, atol=1e-7)   # C = I - [theta x]
    yaw = body_from_inertial(np.array([0.0, 0.0, np.pi / 2]))
    assert np.allclose(yaw @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0])   # a vector along x is at -y after +90 deg yaw


def test_environments_of_a_batch():
    """A run without an orbit feels nothing and reads nothing; the magnetometer's noise is the same
    whenever it is asked for one step, and differs between steps."""
    env = Environments([OrbitEnvironment(epoch=EPOCH), None], [3, 4], 100.0)
    attitude = np.zeros((2, 3))
    torque = env.torque(15.0, attitude, INERTIA, np.zeros((2, 3)))
    assert np.all(torque[1] == 0.0) and np.all(torque[0] != 0.0)
    a, b = env.magnetometer(20.0, attitude, 200), env.magnetometer(20.0, attitude, 200)
    assert np.array_equal(a, b) and np.all(a[1] == 0.0)
    assert not np.array_equal(a, env.magnetometer(20.0, attitude, 210))
    _, truth = env.state(20.0, attitude)
    assert np.abs(a[0] - truth[0]).max() < 5 * 50e-9
    # between grid points the track is linear, past its end held
    track = env.tracks[0]
    _, mid = env.state(ENVIRONMENT_STEP * 1.5, attitude)
    assert np.allclose(mid[0], 0.5 * (track.field[1] + track.field[2]), rtol=1e-12, atol=0.0)
    _, late = env.state(1e6, attitude)
    assert np.array_equal(late[0], track.field[-1])


def test_a_point_over_a_pole_has_a_field():
    """ppigrf divides by sin(colatitude): exactly over a pole the field is taken 6 mm off it, not NaN."""
    field = field_inertial(np.array([[0.0, 0.0, 7.0e6], [0.0, 0.0, -7.0e6]]), np.zeros(2), EPOCH)
    # into the Earth over the north pole, out of it over the south: along -z at both
    assert np.all(np.isfinite(field)) and field[0, 2] < -30e-6 and field[1, 2] < -30e-6
