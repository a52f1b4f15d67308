"""A wheel set: N reaction wheels of one type, each with a spin axis in the body frame.

The thesis' spacecraft (chapter 1, 2.3) carries four wheels, three active
and one redundant that "will be excited in case any of the other three
wheels fails". With three orthogonal wheels, losing one leaves its axis
without control, so the redundant wheel must not be parallel to any of them:

* ``orthogonal_skew`` (default): wheels x, y, z along the body axes and a
  standby wheel s along (1, 1, 1)/sqrt(3). Any three of the four span the
  body, so any single failure is recoverable.
* ``pyramid``: four wheels whose spin axes lie on a cone of half-angle
  90 deg - ``PYRAMID_ELEVATION`` about body z, 90 deg apart in azimuth, all
  four in use (the minimum-norm allocation spreads the torque over them);
  any three span the body.
* ``orthogonal``: the thesis' three active wheels alone, no redundancy.

The spin-axis matrix G (3 x N, column i = g_i) maps wheel torques to body
torque; allocation.py inverts it over the wheels in use.

A standby wheel is unpowered and at rest until the allocation first
commands it: its driver is off and its bearing's static friction (tau_c =
2 mN m, far above the micro-N m torques a body at rest transmits) holds it
to the body, so it turns with the body as part of its locked inertia
(spacecraft.INERTIA). The plant releases it at its first non-zero command.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# [choice] the pyramid's spin axes rise 35.26 deg above the x-y plane (tan e = 1/sqrt(2)): then
# G G^T = (4/3) I, the same torque capability about every body axis with all four wheels in use
PYRAMID_ELEVATION = float(np.degrees(np.arctan(1.0 / np.sqrt(2.0))))
# the wheels along the body axes, the thesis' three: what the learned models and thresholds are fitted for
AXIS_WHEELS = ("x", "y", "z")


def fitted_for(wheel: str, fitted) -> tuple:
    """Whose fitted design (a network, a threshold curve) a wheel takes, the one rule for every per-wheel file.

    Parameters
    ----------
    wheel : str
        The wheel's name in its set.
    fitted : iterable of str
        The wheels a design was fitted for, in their order (AXIS_WHEELS for the shipped files).

    Returns
    -------
    tuple of str
        ``(wheel,)`` where it has its own; else every fitted wheel, as all wheels of a set are of one type
        (a redundant wheel off the body axes). A network takes the first of them (x's, trained on the middle
        of the three inertias, 17 kg m^2), a threshold the widest.
    """
    fitted = tuple(fitted)
    return (wheel,) if wheel in fitted else fitted


@dataclass(frozen=True)
class WheelSet:
    """``names[i]`` spins about ``spin_axes[i]`` (unit, body frame); ``standby`` wheels wait unpowered."""

    name: str
    names: tuple
    spin_axes: tuple          # N unit 3-vectors, as tuples (hashable, exact)
    standby: tuple = ()       # names of the redundant wheels, out of use until brought in

    def __post_init__(self):
        axes = np.asarray(self.spin_axes, float)
        if axes.shape != (len(self.names), 3) or len(set(self.names)) != len(self.names):
            raise ValueError(f"wheel set {self.name}: one spin axis (3 numbers) per distinct wheel name")
        if not np.allclose(np.linalg.norm(axes, axis=1), 1.0, atol=1e-12):
            raise ValueError(f"wheel set {self.name}: spin axes must be unit vectors")
        if set(self.standby) - set(self.names):
            raise ValueError(f"wheel set {self.name}: standby wheels must be among {self.names}")
        if np.linalg.matrix_rank(self.matrix[:, self.mask(self.active)]) < 3:
            raise ValueError(f"wheel set {self.name}: its active wheels do not span the three body axes")

    @property
    def count(self) -> int:
        return len(self.names)

    @property
    def matrix(self) -> np.ndarray:
        """G (3, N): column i is wheel i's spin axis g_i; body torque of wheel torques tau is G tau."""
        return np.asarray(self.spin_axes, float).T

    @property
    def active(self) -> tuple:
        """The wheels in use at launch (all but the standby ones)."""
        return tuple(n for n in self.names if n not in self.standby)

    def index(self, name: str) -> int:
        """The index of wheel ``name`` in the set (ValueError naming the set's wheels otherwise).

        Parameters
        ----------
        name : str
            The wheel's name.

        Returns
        -------
        int
            Its index.
        """
        if name not in self.names:
            raise ValueError(f"wheel must be one of {', '.join(self.names)}, got {name!r}")
        return self.names.index(name)

    def mask(self, names) -> np.ndarray:
        """(N,) bool: which of the set's wheels are in ``names``.

        Parameters
        ----------
        names : iterable of str
            Wheel names.

        Returns
        -------
        numpy.ndarray
            (N,) bool.
        """
        names = set(names)
        return np.array([n in names for n in self.names])

    def spans(self, names) -> bool:
        """Whether the wheels ``names`` together can give a torque about every body axis (rank 3).

        Parameters
        ----------
        names : iterable of str
            Wheel names.

        Returns
        -------
        bool
            Whether they span the body axes.
        """
        return bool(np.linalg.matrix_rank(self.matrix[:, self.mask(names)]) == 3)

    def initial_speeds(self, speeds) -> np.ndarray:
        """Wheel speeds (..., N), 0 on standby, of ``speeds``: one per active wheel (what a run draws), or
        (..., 3) body-axis wheel speeds whose momentum the active wheels store, h = J G Omega with the
        minimum-norm Omega (a scenario's three where more wheels are active). Runs draw per wheel: the
        minimum-norm spread started two of a pyramid's wheels near zero speed, where they crossed it.

        Parameters
        ----------
        speeds : array_like
            (..., A) speeds of the A active wheels, or (..., 3) body-axis wheel speeds [rad/s].

        Returns
        -------
        numpy.ndarray
            (..., N) wheel speeds Omega [rad/s].
        """
        speeds = np.asarray(speeds, float)
        active = self.mask(self.active)
        g = self.matrix[:, active]
        out = np.zeros(speeds.shape[:-1] + (self.count,))
        if speeds.shape[-1] == len(self.active):
            out[..., active] = speeds
        else:
            out[..., active] = speeds @ np.linalg.pinv(g).T
        return out


_SKEW = tuple(float(v) for v in np.full(3, 1.0 / np.sqrt(3.0)))


def _pyramid(elevation_deg=PYRAMID_ELEVATION) -> tuple:
    e = np.radians(elevation_deg)
    return tuple((float(np.cos(e) * np.cos(a)), float(np.cos(e) * np.sin(a)), float(np.sin(e)))
                 for a in np.radians([0.0, 90.0, 180.0, 270.0]))


WHEEL_SETS = {
    "orthogonal_skew": WheelSet("orthogonal_skew", ("x", "y", "z", "s"),
                                ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), _SKEW), standby=("s",)),
    "pyramid": WheelSet("pyramid", ("p1", "p2", "p3", "p4"), _pyramid()),
    "orthogonal": WheelSet("orthogonal", ("x", "y", "z"), ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))),
}
DEFAULT_WHEEL_SET = "orthogonal_skew"
# every name a wheel of any set has (a bag reader asks for any set's per-wheel topics)
ALL_WHEEL_NAMES = tuple(sorted({n for ws in WHEEL_SETS.values() for n in ws.names}))


def joint_name(wheel: str) -> str:
    """The joint a wheel is named by on every ROS topic: reaction_wheel_<name>.

    Parameters
    ----------
    wheel : str
        The wheel's name in its set.

    Returns
    -------
    str
        The joint name.
    """
    return f"reaction_wheel_{wheel}"


def wheel_set(name: str) -> WheelSet:
    """The named wheel set; ValueError naming the known ones otherwise.

    Parameters
    ----------
    name : str
        A key of WHEEL_SETS (``orthogonal_skew``, ``pyramid``, ``orthogonal``).

    Returns
    -------
    WheelSet
        The set.
    """
    if name not in WHEEL_SETS:
        raise ValueError(f"wheel_set must be one of {', '.join(WHEEL_SETS)}, got {name!r}")
    return WHEEL_SETS[name]


def fault_wheel(seed: int, wheels: WheelSet = WHEEL_SETS[DEFAULT_WHEEL_SET]) -> int:
    """The wheel a bench run's fault goes on, drawn from its seed over the set's wheels in use (a standby wheel
    is at rest, unpowered: a fault there shows nothing until it is brought in, which only FDIR does).

    Parameters
    ----------
    seed : int
        The run's seed.
    wheels : WheelSet, optional
        The run's wheel set (default: the default set, x y z in use and s standing by).

    Returns
    -------
    int
        The wheel's index in ``wheels.names``: seed mod 3 on the default set.
    """
    return wheels.names.index(wheels.active[seed % len(wheels.active)])
