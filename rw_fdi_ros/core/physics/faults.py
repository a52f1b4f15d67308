"""The fault vocabulary: the kinds of wheel fault, their nominal values, one fault, and the operating point
they make of a wheel at a time.

Shared by the plant (which acts on the operating point) and the scenario (which schedules the faults), so
the physics does not import the scenario.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .wheel import NOMINAL, WheelParams, nominal_point
from .wheel_set import DEFAULT_WHEEL_SET, WHEEL_SETS, WheelSet, fault_wheel

FAULT_KINDS = ("bus_voltage", "current_limiter", "temperature", "ripple_gain")
NOMINAL_VALUES = {k: getattr(NOMINAL, k) for k in FAULT_KINDS}   # the thesis wheel's (8 V bus)


def nominal_values(params: WheelParams | None = None) -> dict:
    """Each fault kind's healthy value on the wheel type ``params`` (its own bus voltage; None: the thesis').

    Parameters
    ----------
    params : WheelParams or None
        The wheel type.

    Returns
    -------
    dict
        FAULT_KINDS -> value (V, share, C, multiplier).
    """
    return NOMINAL_VALUES if params is None else {k: getattr(nominal_point(params), k) for k in FAULT_KINDS}


@dataclass(frozen=True)
class Fault:
    """One fault on one wheel: from ``onset`` the field ``kind`` moves to ``value``.

    ``ramp`` > 0 moves it linearly from nominal to ``value`` over that many seconds.
    """

    kind: str
    wheel: int
    onset: float
    value: float
    ramp: float = 0.0

    def value_at(self, t, nominal: dict = NOMINAL_VALUES):
        """The faulted quantity's value at ``t``: nominal before the onset, ramping to ``value`` over ``ramp``.

        Parameters
        ----------
        t : float
            Sim time [s].
        nominal : dict, optional
            The healthy values (:func:`nominal_values` of the wheel type; default the thesis wheel's).

        Returns
        -------
        float
            The value (the kind's unit).
        """
        nominal = nominal[self.kind]
        if t < self.onset:
            return nominal
        if self.ramp > 0.0:
            share = min((t - self.onset) / self.ramp, 1.0)
            return nominal + share * (self.value - nominal)
        return self.value

    def as_dict(self, wheel_names=None) -> dict:
        """``wheel_names``: the run's wheel set's names (default: the default set's, x y z s).

        Parameters
        ----------
        wheel_names : sequence of str or None
            The run's wheel set's names.

        Returns
        -------
        dict
            'kind', 'wheel' (by name), 'onset' [s], 'value', 'ramp' [s].
        """
        names = wheel_names or WHEEL_SETS[DEFAULT_WHEEL_SET].names
        return {"kind": self.kind, "wheel": names[self.wheel], "onset": self.onset,
                "value": self.value, "ramp": self.ramp}


def drawn_fault(kind: str, value: float, seed: int, wheels: WheelSet, onset_range: tuple,
                ramp: float = 0.0) -> "Fault":
    """A run's fault drawn from its seed: on a wheel in use (:func:`wheel_set.fault_wheel`) at an onset uniform
    in ``onset_range``, to 0.1 s; what every bench and `defaults --vehicle`'s check fly.

    Parameters
    ----------
    kind : str
        The fault kind.
    value : float
        Its size (the kind's unit).
    seed : int
        The run's seed.
    wheels : WheelSet
        The run's wheel set.
    onset_range : tuple of float
        (earliest, latest) onset [s].
    ramp : float, optional
        Ramp time [s].

    Returns
    -------
    Fault
        The fault.
    """
    onset = float(np.round(np.random.default_rng(seed).uniform(*onset_range), 1))
    return Fault(kind, fault_wheel(seed, wheels), onset, value, ramp)


def operating_point_at(faults, t, count: int = 3, nominal: dict = NOMINAL_VALUES):
    """Per-wheel operating point of ``count`` wheels at time t: dict kind -> array (count,), thesis
    Table 2.3 when healthy.

    Parameters
    ----------
    faults : iterable of Fault
        One run's faults.
    t : float
        Time [s].
    count : int, optional
        Wheels in the run, N.
    nominal : dict, optional
        The healthy values (:func:`nominal_values`).

    Returns
    -------
    dict of str to ndarray
        FAULT_KINDS -> (N,): ``bus_voltage`` [V], ``current_limiter`` (share), ``temperature`` [C],
        ``ripple_gain`` (multiplier).
    """
    return {k: v[0] for k, v in operating_points([faults], t, count, nominal).items()}


def operating_points(fault_lists, t, count: int = 3, nominal: dict = NOMINAL_VALUES):
    """:func:`operating_point_at` of a batch of runs (one fault list each): dict kind -> array (B, count).

    Parameters
    ----------
    fault_lists : list of iterable of Fault
        Each run's faults, B of them.
    t : float
        Time [s].
    count : int, optional
        Wheels per run, N.
    nominal : dict, optional
        The healthy values (:func:`nominal_values`).

    Returns
    -------
    dict of str to ndarray
        FAULT_KINDS -> (B, N), in the units of :func:`operating_point_at`.
    """
    op = {k: np.full((len(fault_lists), count), nominal[k], dtype=float) for k in FAULT_KINDS}
    for b, faults in enumerate(fault_lists):
        # by onset, and only those begun: a later fault of one kind on one wheel takes over from its onset,
        # it does not undo an earlier one before then
        for f in sorted(faults, key=lambda f: f.onset):
            if t >= f.onset:
                op[f.kind][b, f.wheel] = f.value_at(t, nominal)
    return op
