"""The orbit environment of a run: the field the magnetometer reads and the torques the body feels.

A scenario's ``environment:`` mapping puts the spacecraft in orbit (orbit.py); without it a run has
no orbit and no field, as the thesis' runs (eq. 2.34's random disturbance only). In orbit, beside
eq. 2.34, two secular disturbance torques act on the body, both from the physics, not drawn:

- gravity gradient (Wertz, Spacecraft Attitude Determination and Control, eq. 17-39; Hughes ch. 8):
  tau_gg = 3 mu / |r|^5 (r_b x I r_b), with r_b the position in body axes and I the inertia;
- the spacecraft's residual magnetic dipole m_res (harness loops, magnetised parts): tau = m_res x b_b,

and the magnetorquers' torque tau_mtb = m x b_b (magnetorquers.py). An inertially pointing body meets
the gravity gradient at twice the orbit rate with a mean of -3/2 n^2 (o x I o) (o the orbit normal) and
a dipole field whose orbit mean is not zero: both build wheel momentum up over hours.

[choice] Attitude frame: the thesis' per-axis angles (phi, theta, psi) about x, y, z, read as 3-2-1
Euler angles from the inertial frame, C_bi = R1(phi) R2(theta) R3(psi); the kinematics stays the
thesis' d(angle)/dt = body rate. Set points are inertial (an inertially pointing spacecraft).

[choice] Position and field are evaluated every ENVIRONMENT_STEP seconds over the run and interpolated
linearly between (the field turns by 0.6 deg of orbit in 10 s; a 1 s grid changes a 24-h run's wheel
momentum by < 1e-4 N m s); the torques are held over each control period like eq. 2.34's.
"""
from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone

import numpy as np

from .geomagnetic import field_inertial
from .orbit import MU_EARTH, CircularOrbit, TleOrbit, sidereal_angle
from .spacecraft import cross, inertia_times

ENVIRONMENT_STEP = 10.0
DEFAULT_EPOCH = datetime(2026, 1, 1, tzinfo=timezone.utc)
# [choice] the residual dipole [A m^2]: 0.5 per axis, 0.87 A m^2 in all, gives the thesis' worst-case
# magnetic disturbance (eq. 2.32, 4.5e-5 N m) at the 52 uT the field reaches near the poles at 700 km
DEFAULT_RESIDUAL_DIPOLE = (0.5, 0.5, 0.5)
# [choice] magnetometer noise, 1 sigma per axis [T] (a fluxgate's tens of nT), and its sample period [s]:
# the dumping law runs on each reading and the rods hold its dipole until the next
MAGNETOMETER_NOISE = 50e-9
MAGNETOMETER_PERIOD = 1.0


def magnetometer_steps(control_period: float) -> int:
    """Control steps per magnetometer reading: a reading (and the rods' answer) on every step k with
    k % this == 0. ValueError when the control period does not divide MAGNETOMETER_PERIOD.

    Parameters
    ----------
    control_period : float
        Control period [s].

    Returns
    -------
    int
        Steps per reading (at least 1).
    """
    steps = max(int(round(MAGNETOMETER_PERIOD / control_period)), 1)
    if abs(steps * control_period - MAGNETOMETER_PERIOD) > 1e-9:
        raise ValueError(f"in orbit the control period must divide the magnetometer's {MAGNETOMETER_PERIOD:g} s, "
                         f"got {control_period:g} s")
    return steps


@dataclass(frozen=True)
class OrbitEnvironment:
    """A scenario's ``environment:``: the orbit, the epoch its t = 0 is, the residual dipole."""

    orbit: CircularOrbit | TleOrbit = CircularOrbit()
    epoch: datetime | None = None    # None: the TLE's own epoch, else DEFAULT_EPOCH
    residual_dipole: tuple | None = None   # [A m^2]; None: the vehicle's (vehicle.Vehicle.residual_dipole)

    def start(self) -> datetime:
        """The run's start (UTC): ``epoch``, else the element set's own epoch, else DEFAULT_EPOCH.

        Returns
        -------
        datetime.datetime
            The start.
        """
        if self.epoch is not None:
            return self.epoch
        return self.orbit.epoch() if isinstance(self.orbit, TleOrbit) else DEFAULT_EPOCH

    def track(self, duration: float, field_model: str = "igrf") -> "Track":
        """Position and field every ENVIRONMENT_STEP seconds over [0, duration].

        Parameters
        ----------
        duration : float
            The run's duration [s].
        field_model : str
            The geomagnetic field model.

        Returns
        -------
        Track
            Times [s], inertial position [m] and field [T].
        """
        times = np.arange(0.0, float(duration) + 2 * ENVIRONMENT_STEP, ENVIRONMENT_STEP)
        epoch = self.start()
        position = self.orbit.position(times, epoch)
        field = field_inertial(position, sidereal_angle(epoch, times), epoch, field_model)
        return Track(times, position, field)


@dataclass
class Track:
    """One run's orbit: grid times (n,) [s], inertial position (n, 3) [m] and field (n, 3) [T]."""

    times: np.ndarray
    position: np.ndarray
    field: np.ndarray



def body_from_inertial(attitude) -> np.ndarray:
    """C_bi (..., 3, 3) of attitude angles (..., 3) read as 3-2-1 Euler angles: R1(phi) R2(theta) R3(psi).

    Parameters
    ----------
    attitude : array_like, shape (..., 3)
        (phi, theta, psi) [rad], e.g. (B, 3).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        C_bi: body components of an inertial vector v are C_bi v.
    """
    phi, theta, psi = (np.asarray(attitude, float)[..., i] for i in range(3))
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    return np.stack((np.stack((ct * cp, ct * sp, -st), -1),
                     np.stack((sf * st * cp - cf * sp, sf * st * sp + cf * cp, sf * ct), -1),
                     np.stack((cf * st * cp + sf * sp, cf * st * sp - sf * cp, cf * ct), -1)), -2)


def gravity_gradient_torque(position_body, inertia) -> np.ndarray:
    """tau_gg = 3 mu / |r|^5 (r x I r) [N m] for positions in body axes (..., 3) and an inertia, its
    diagonal (3,) or the matrix (3, 3) [kg m^2].

    Parameters
    ----------
    position_body : array_like, shape (..., 3)
        Position r from the Earth's centre [m], body axes, e.g. (B, 3).
    inertia : array_like, shape (3,) or (3, 3)
        Inertia I [kg m^2], body axes.

    Returns
    -------
    ndarray, shape (..., 3)
        tau_gg [N m], body axes.
    """
    r = np.asarray(position_body, float)
    return 3.0 * MU_EARTH / np.linalg.norm(r, axis=-1, keepdims=True) ** 5 * cross(r, inertia_times(inertia, r))


class Environments:
    """The environment of a batch of runs (None where a run has none), asked once per control period.
    The runs share one grid (one duration), so a step interpolates the whole batch at once."""

    def __init__(self, environments, seeds, duration: float, field_model: str = "igrf", residual_dipoles=None):
        self.environments = list(environments)
        self.seeds = [int(s) for s in seeds]
        self.tracks = [None if e is None else e.track(duration, field_model) for e in self.environments]
        self.active = np.array([e is not None for e in self.environments])
        times = next(t.times for t in self.tracks if t is not None)
        self.last = len(times) - 1
        # a run without an orbit: far away (no gravity gradient worth a bit) and no field
        self.position = np.array([t.position if t is not None else np.full((len(times), 3), 1e30)
                                  for t in self.tracks])
        self.field = np.array([t.field if t is not None else np.zeros((len(times), 3)) for t in self.tracks])
        # each run's own dipole, else its vehicle's (``residual_dipoles``), else the thesis' default
        vehicles = residual_dipoles or [DEFAULT_RESIDUAL_DIPOLE] * len(self.environments)
        self.residual = np.array([(0.0, 0.0, 0.0) if e is None else e.residual_dipole
                                  if e.residual_dipole is not None else v
                                  for e, v in zip(self.environments, vehicles)], float)

    def state(self, t: float, attitude):
        """(position, field) in body axes (B, 3) at ``t`` for the batch's attitudes (B, 3), linear between
        grid points (held past the last); a run without an orbit has no field.

        Parameters
        ----------
        t : float
            Sim time [s].
        attitude : array_like
            (B, 3) attitudes [rad].

        Returns
        -------
        tuple of numpy.ndarray
            (position [m], field [T]), (B, 3) each in body axes.
        """
        x = min(max(t / ENVIRONMENT_STEP, 0.0), float(self.last))
        i = min(int(x), self.last - 1)
        w = x - i
        r = (1 - w) * self.position[:, i] + w * self.position[:, i + 1]
        b = (1 - w) * self.field[:, i] + w * self.field[:, i + 1]
        c = body_from_inertial(attitude)
        return np.einsum("bij,bj->bi", c, r), np.einsum("bij,bj->bi", c, b)

    def torque(self, t: float, attitude, inertia, dipole) -> np.ndarray:
        """Gravity gradient + (residual dipole + magnetorquers' ``dipole``) x field [N m], (B, 3).

        Parameters
        ----------
        t : float
            Sim time [s].
        attitude : array_like
            (B, 3) attitudes [rad].
        inertia : array_like
            The body's inertia I [kg m^2].
        dipole : array_like
            (B, 3) the magnetorquers' dipole [A m^2].

        Returns
        -------
        numpy.ndarray
            (B, 3) torque [N m].
        """
        r_body, b_body = self.state(t, attitude)
        gg = np.where(self.active[:, None], gravity_gradient_torque(r_body, inertia), 0.0)
        return gg + cross(self.residual + dipole, b_body)

    def magnetometer(self, t: float, attitude, step: int) -> np.ndarray:
        """The field in body axes [T] as the magnetometer reads it at ``step``: plus N(0, MAGNETOMETER_NOISE)
        per axis from a stream keyed by the run's seed and the step (the same reading however often asked).

        Parameters
        ----------
        t : float
            Sim time [s].
        attitude : array_like
            (B, 3) attitudes [rad].
        step : int
            The control step's index.

        Returns
        -------
        numpy.ndarray
            (B, 3) reading [T] (0 for a run without an orbit).
        """
        _, b_body = self.state(t, attitude)
        noise = np.array([np.random.default_rng([s, 5, int(step)]).normal(0.0, MAGNETOMETER_NOISE, 3)
                          for s in self.seeds])
        return np.where(self.active[:, None], b_body + noise, 0.0)
