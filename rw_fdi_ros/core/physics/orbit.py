"""Where the spacecraft is: a circular orbit (the thesis' MakSat by default) or a TLE through SGP4.

Positions are inertial (ECI, x to the vernal equinox, z to the pole) in metres, as arrays (n, 3) over
times t [s] after the run's epoch. A TLE is propagated by SGP4 (the ``sgp4`` package) in its TEME frame,
taken as the ECI frame here: the two differ by the equinox' nutation, under 0.01 deg, far below what
the field or the gravity gradient resolve. The Earth turns under the orbit at a constant rate from the
Greenwich mean sidereal angle of the epoch (:func:`sidereal_angle`), which is what places the
geomagnetic field (geomagnetic.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone

import numpy as np

MU_EARTH = 3.986004418e14          # gravitational parameter [m^3/s^2] (WGS-84)
EARTH_RADIUS = 6378137.0           # equatorial radius [m] (WGS-84): altitude is above it
EARTH_ROTATION_RATE = 7.2921150e-5   # [rad/s], sidereal
J2000_JD = 2451545.0


class OrbitError(ValueError):
    """An orbit that cannot be flown; one line for the user."""


def julian_date(epoch: datetime) -> float:
    """Julian date (UTC taken as UT1: 1 s is 0.004 deg of Earth rotation) of ``epoch``.

    Parameters
    ----------
    epoch : datetime
        The instant; a naive datetime is taken as UTC.

    Returns
    -------
    float
        JD [days].
    """
    if epoch.tzinfo is None:
        epoch = epoch.replace(tzinfo=timezone.utc)
    return 2440587.5 + epoch.timestamp() / 86400.0


def sidereal_angle(epoch: datetime, t) -> np.ndarray:
    """Greenwich mean sidereal angle [rad] at ``t`` [s] after ``epoch``: the IAU 1982 expression to first
    order, theta = 280.46061837 deg + 360.98564736629 deg/day (JD - 2451545.0) (Vallado, eq. 3-45
    without its 1e-7 deg/century^2 terms).

    Parameters
    ----------
    epoch : datetime
        The run's t = 0 (naive: UTC).
    t : float or array_like
        Time after ``epoch`` [s], e.g. (n,).

    Returns
    -------
    float or ndarray
        theta in [0, 2 pi) [rad], ``t``'s shape.
    """
    days = julian_date(epoch) - J2000_JD + np.asarray(t, float) / 86400.0
    return np.deg2rad(np.mod(280.46061837 + 360.98564736629 * days, 360.0))


@dataclass(frozen=True)
class CircularOrbit:
    """A circular orbit of ``altitude_km`` above the equatorial radius, ``inclination_deg``, right
    ascension of the ascending node ``raan_deg`` and argument of latitude ``argument_of_latitude_deg``
    at the epoch. Default: the thesis' MakSat, 700 km sun-synchronous (98.2 deg), period 98.8 min."""

    altitude_km: float = 700.0
    inclination_deg: float = 98.2
    raan_deg: float = 0.0
    argument_of_latitude_deg: float = 0.0

    @property
    def radius(self) -> float:
        return EARTH_RADIUS + 1e3 * self.altitude_km

    @property
    def mean_motion(self) -> float:
        """n = sqrt(mu / a^3) [rad/s]."""
        return float(np.sqrt(MU_EARTH / self.radius ** 3))

    @property
    def period(self) -> float:
        return 2.0 * np.pi / self.mean_motion

    def position(self, t, epoch: datetime | None = None) -> np.ndarray:
        """r(t) = a R3(-Omega) R1(-i) (cos u, sin u, 0) with u = u0 + n t [m], shape (n, 3).

        Parameters
        ----------
        t : array_like
            (n,) time since the start [s].
        epoch : datetime.datetime or None
            Unused: a circular orbit starts at its elements.

        Returns
        -------
        numpy.ndarray
            (n, 3) inertial position [m].
        """
        u = np.deg2rad(self.argument_of_latitude_deg) + self.mean_motion * np.asarray(t, float)
        raan, inc = np.deg2rad(self.raan_deg), np.deg2rad(self.inclination_deg)
        cu, su = np.cos(u), np.sin(u)
        return self.radius * np.stack((np.cos(raan) * cu - np.sin(raan) * su * np.cos(inc),
                                       np.sin(raan) * cu + np.cos(raan) * su * np.cos(inc),
                                       su * np.sin(inc)), axis=-1)


@dataclass(frozen=True)
class TleOrbit:
    """A two-line element set propagated by SGP4 (TEME taken as ECI)."""

    line1: str
    line2: str

    def satellite(self):
        """The element set as SGP4 reads it (OrbitError, one line, when it does not).

        Returns
        -------
        sgp4.api.Satrec
            The satellite record.
        """
        from sgp4.api import Satrec
        try:
            sat = Satrec.twoline2rv(self.line1, self.line2)
        except (ValueError, IndexError) as exc:
            raise OrbitError(f"not a two-line element set ({exc})") from None
        if sat.error:
            raise OrbitError(f"SGP4 refuses this element set (error {sat.error})")
        return sat

    def epoch(self) -> datetime:
        """The element set's own epoch (UTC).

        Returns
        -------
        datetime.datetime
            The epoch.
        """
        from sgp4.conveniences import sat_epoch_datetime
        return sat_epoch_datetime(self.satellite())

    def position(self, t, epoch: datetime | None = None) -> np.ndarray:
        """SGP4 positions [m] at ``t`` [s] after ``epoch`` (default: the element set's).

        Parameters
        ----------
        t : array_like
            (n,) time since ``epoch`` [s].
        epoch : datetime.datetime or None
            The start (UTC).

        Returns
        -------
        numpy.ndarray
            (n, 3) inertial position [m].
        """
        sat = self.satellite()
        start = julian_date(epoch or self.epoch())
        t = np.atleast_1d(np.asarray(t, float))
        whole = np.floor(start) + np.zeros_like(t)
        errors, r, _ = sat.sgp4_array(whole, start - np.floor(start) + t / 86400.0)
        if np.any(errors):
            first = int(np.argmax(errors != 0))
            raise OrbitError(f"SGP4 fails {t[first]:g} s after the epoch (error {int(errors[first])}: "
                             "the orbit has decayed or the elements are too old)")
        return 1e3 * r
