"""Three magnetorquers along the body axes and the momentum-dumping law that commands them.

The rods make a dipole m [A m^2] (one component each, at most ``dipole_limit``); in the field b the
body feels tau = m x b (environment.py). Only the part of a wanted torque across b can be made.

The law (the cross-product law; Basilisk's mtbMomentumManagementSimple with torque2Dipole):

    h   = sum_i J g_i Omega_i          momentum of the wheels in use, body axes
    tau = -k h                         the external torque that would dump it
    m   = (b x tau) / |b|^2            the dipole whose torque m x b is tau's part across b

and m scaled down as a whole when a rod would exceed its limit (its direction kept, so the torque
stays across b and opposed to h). [choice] Hysteresis: a run dumps from the moment a wheel in use
passes ``start_speed`` until the net momentum |h| is below J ``stop_speed`` (what one wheel holds at
that speed; with three orthogonal wheels every one is then below it); between dumps the rods are
off, so the wheels drift with the secular torques, and are pulled back, now and then through zero.
Wheels given up are not dumped: their momentum is not the controller's to move (a held wheel keeps
it). The law runs on each magnetometer reading (environment.MAGNETOMETER_PERIOD); the dipole is held
between.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .spacecraft import cross


@dataclass(frozen=True)
class MomentumDumping:
    """The rods and the law's settings (a scenario's ``magnetorquers:`` mapping)."""

    dipole_limit: float = 15.0     # [A m^2] per rod (a 100-kg class spacecraft's rods)
    gain: float = 2e-3             # k [1/s]: a wheel at 35 rad/s (0.27 N m s) asks 5e-4 N m, the rods' most
    # [rad/s] start: 10 rad/s inside the FDI's envelope (isolation.WHEEL_SPEED_ENVELOPE, 45 rad/s) and
    # 12 below the speed the nominal wheel cannot hold even at the 5 V limit (47.3 rad/s, friction)
    start_speed: float = 35.0
    stop_speed: float = 5.0        # [rad/s] |h| / J: "back to zero" (thesis ch. 1), short of it
    enabled: bool = True           # false: rods idle (a run without dumping, for comparison)


def wheel_momentum(wheel_speed, wheel_inertia, spin_axes, in_use) -> np.ndarray:
    """h = sum over the wheels in use of J g_i Omega_i [N m s]: speeds (B, N), inertia J scalar or (B, N),
    spin axes G (3, N), in_use (B, N) bool; shape (B, 3).

    Parameters
    ----------
    wheel_speed : array_like, shape (B, N)
        Wheel speeds Omega [rad/s]: runs, wheels.
    wheel_inertia : float or array_like, shape (B, N)
        J [kg m^2].
    spin_axes : array_like, shape (3, N)
        G, body frame.
    in_use : array_like of bool, shape (B, N)
        The wheels whose momentum counts.

    Returns
    -------
    ndarray, shape (B, 3)
        h [N m s], body frame.
    """
    stored = np.where(in_use, np.asarray(wheel_inertia) * np.asarray(wheel_speed, float), 0.0)
    return stored @ np.asarray(spin_axes).T


def cross_product_dipole(field, torque) -> np.ndarray:
    """m = (b x tau) / |b|^2 [A m^2]: the dipole whose torque m x b is tau's component across b.

    Parameters
    ----------
    field : array_like, shape (..., 3)
        Magnetic field b [T], body frame.
    torque : array_like, shape (..., 3)
        Wanted torque tau [N m], body frame.

    Returns
    -------
    ndarray, shape (..., 3)
        m [A m^2]; 0 where the field is 0.
    """
    b = np.asarray(field, float)
    norm2 = np.sum(b * b, axis=-1, keepdims=True)
    return cross(b, np.asarray(torque, float)) / np.where(norm2 > 0.0, norm2, np.inf)


def saturate(dipole, limit) -> np.ndarray:
    """``dipole`` (..., 3) scaled down as a whole so that no rod exceeds ``limit`` (scalar or (..., 1));
    its direction kept.

    Parameters
    ----------
    dipole : array_like, shape (..., 3)
        m [A m^2], one component per rod.
    limit : float or array_like, shape (..., 1)
        Largest dipole per rod [A m^2].

    Returns
    -------
    ndarray, shape (..., 3)
        The dipole [A m^2], scaled by one factor <= 1 per vector.
    """
    m = np.asarray(dipole, float)
    peak = np.max(np.abs(m), axis=-1, keepdims=True)
    return m * np.minimum(1.0, limit / np.where(peak > 0.0, peak, np.inf))


class Dumper:
    """The law for a batch of runs, each with its settings (None: no rods): whether each dumps
    (hysteresis) and the dipole it commands."""

    def __init__(self, settings):
        on = [s if s is not None and s.enabled else None for s in settings]
        self.enabled = np.array([s is not None for s in on])
        off = MomentumDumping()
        self.gain, self.limit, self.start, self.stop = (np.array([getattr(s or off, k) for s in on], float)
                                                        for k in ("gain", "dipole_limit", "start_speed", "stop_speed"))
        self.dumping = np.zeros(len(on), bool)

    def update(self, field, wheel_speed, in_use, wheel_inertia, spin_axes) -> np.ndarray:
        """The dipole (B, 3) [A m^2] for the magnetometer's ``field`` (B, 3) [T] and the wheels' state.

        Parameters
        ----------
        field : array_like
            (B, 3) magnetometer reading [T].
        wheel_speed : array_like
            (B, N) wheel speeds Omega [rad/s].
        in_use : array_like
            (B, N) bool: the wheels in use.
        wheel_inertia : array_like
            Wheel inertia J [kg m^2] (scalar or per wheel).
        spin_axes : array_like
            (3, N) the wheels' spin axes.

        Returns
        -------
        numpy.ndarray
            (B, 3) dipole [A m^2].
        """
        fastest = np.max(np.where(in_use, np.abs(wheel_speed), 0.0), axis=-1)
        h = wheel_momentum(wheel_speed, wheel_inertia, spin_axes, in_use)
        # on when a wheel nears saturation; off when the net momentum is what one wheel holds at the stop
        # speed: speed the wheels hold in their null space (four in use) is not the rods' to dump
        left = np.linalg.norm(h, axis=-1) / np.max(np.asarray(wheel_inertia, float))
        self.dumping = self.enabled & np.where(self.dumping, left >= self.stop, fastest > self.start)
        m = saturate(cross_product_dipole(field, -self.gain[:, None] * h), self.limit[:, None])
        return np.where(self.dumping[:, None], m, 0.0)


class DumpLog:
    """The dumps of a run, fed the rods' dipole sample by sample in time order: intervals [(start, end)] [s]
    from the first to the last sample with a dipole not zero (one pass, no series kept)."""

    def __init__(self):
        self.intervals = []
        self._open = None

    def add(self, time: float, dipole):
        """Log one sample's dipole: a non-zero one opens or extends a dump, a zero one closes it.

        Parameters
        ----------
        time : float
            Sim time [s].
        dipole : array_like
            The dipole [A m^2].
        """
        if np.any(np.asarray(dipole) != 0.0):
            self._open = [self._open[0] if self._open else float(time), float(time)]
        elif self._open is not None:
            self.intervals.append(tuple(self._open))
            self._open = None

    def done(self) -> list:
        """The intervals, a dump still on at the end closed at its last sample.

        Returns
        -------
        list of tuple
            (start [s], end [s]) of each dump.
        """
        return self.intervals + ([tuple(self._open)] if self._open else [])
