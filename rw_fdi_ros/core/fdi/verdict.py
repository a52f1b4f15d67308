"""The isolation logic of one observer over the N wheels of a set, sample by sample (evaluation.md).

The isolation node and the offline tools (screen, evaluation, calibration
checks) both step :class:`ObserverChannel`, so a verdict computed offline is
the node's verdict.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .detection import AlarmRule
from .threshold_file import ThresholdCurves
from ..physics.wheel_set import AXIS_WHEELS

# The observer whose alarms make the wheel's /diagnostics status and start fault identification, per
# FDI method. Speed-aware: the nominal wheel model (the physics observer). Its error does not depend on
# the manoeuvres a network was trained on: in operations (set-point changes at random times, hours of
# slews and holds) it raised no false alarm where the Elman network raised 1.5 % (400-s runs) and 2 in
# 6 two-hour runs, and it blamed no healthy wheel for a bus drop that tumbles its axis where the Elman
# blamed one in 68 % (tools/benches/operations_bench.py, tuning seeds; docs/fdi.md "Operations"). The thesis method
# has no model observer: its Elman network decides, as in the thesis.
DECISION_OBSERVERS = {"speed_aware": "model", "thesis": "elman"}


# The operating envelope's wheel speeds [rad/s]: the verdict is judged for |speed| <= this and STALE beyond.
# Validated in operations from 0 (speeds through zero) to 45 rad/s (docs/fdi.md "Operations"); above 47.3 rad/s
# the nominal wheel cannot hold its speed even at the 5 V command limit (friction exceeds the motor's
# torque, core/physics/wheel.py), so a wheel there is not in any state the FDI was built for.
WHEEL_SPEED_ENVELOPE = 45.0


def speed_envelope(params=None) -> float:
    """The operating envelope's speed [rad/s] of a wheel type: the thesis' type's share of its top speed,
    WHEEL_SPEED_ENVELOPE / Omega_top = 45 / 47.3 (core/physics/wheel.top_speed), of this type's Omega_top; the thesis'
    type (None, or any of its EMF-limit choices: the envelope is the wheel's, not the plant choice's) gets
    WHEEL_SPEED_ENVELOPE itself.

    Parameters
    ----------
    params : WheelParams, optional
        The wheel type; None: the thesis' (Table 2.2).

    Returns
    -------
    float
        The largest |speed| judged [rad/s].
    """
    from dataclasses import replace
    from ..physics.wheel import WheelParams, top_speed
    if params is None:
        return WHEEL_SPEED_ENVELOPE
    thesis = replace(WheelParams(), emf_limit=params.emf_limit)
    return WHEEL_SPEED_ENVELOPE if params == thesis else WHEEL_SPEED_ENVELOPE * top_speed(params) / top_speed(thesis)


def in_envelope(wheel_speed, envelope: float = WHEEL_SPEED_ENVELOPE) -> np.ndarray:
    """Per wheel: whether its FDI sample's speed [rad/s] lies in the operating envelope.

    Parameters
    ----------
    wheel_speed : float or array_like
        Wheel speed [rad/s], e.g. (N,).
    envelope : float
        The largest |speed| judged [rad/s] (:func:`speed_envelope` of the wheel type).

    Returns
    -------
    ndarray of bool
        |speed| <= ``envelope``, ``wheel_speed``'s shape.
    """
    return np.abs(np.asarray(wheel_speed, float)) <= envelope


def decision_observer(method: str) -> str:
    """The observer that decides /diagnostics for FDI ``method``.

    Parameters
    ----------
    method : str
        ``speed_aware`` or ``thesis``; ValueError otherwise.

    Returns
    -------
    str
        The observer slot (``model`` or ``elman``).
    """
    try:
        return DECISION_OBSERVERS[method]
    except KeyError:
        raise ValueError(f"fdi_method must be one of {', '.join(DECISION_OBSERVERS)}, got {method!r}") from None


@dataclass(frozen=True)
class DecisionRule:
    """What makes /diagnostics: one observer's alarms, or a vote, a wheel alarmed where at least ``votes`` of
    ``observers`` alarm it. ``lead`` (the first observer) gives the residual and threshold the verdict shows.

    A vote's alarm on a wheel comes up at the sample its ``votes``-th observer alarms and goes down when
    fewer than ``votes`` do; its first alarm time is the ``votes``-th earliest first alarm among those
    alarming. A single observer's rows pass unchanged."""

    observers: tuple
    votes: int = 1

    def __post_init__(self):
        if not 1 <= self.votes <= len(self.observers) or len(set(self.observers)) != len(self.observers):
            raise ValueError(f"a decision takes 1 to {len(self.observers)} votes of distinct observers, got "
                             f"{self.votes} of {self.observers}")

    @property
    def lead(self) -> str:
        return self.observers[0]

    @property
    def phrase(self) -> str:
        """Who decides, as /diagnostics names it: 'model observer', or '2 of 3 observers' for a vote."""
        if len(self.observers) == 1:
            return f"{self.lead} observer"
        return f"{self.votes} of {len(self.observers)} observers"

    @property
    def label(self) -> str:
        """How a configuration and the command line write it: 'model', or '2of3'."""
        return self.lead if len(self.observers) == 1 else f"{self.votes}of{len(self.observers)}"

    def combine(self, rows_of: dict) -> dict:
        """wheel -> (residual, threshold, alarm, first alarm or None) of the decision, from ``rows_of``:
        observer -> its :meth:`ObserverChannel.update` rows (every one of ``observers``).

        Parameters
        ----------
        rows_of : dict
            observer -> its ObserverChannel rows.

        Returns
        -------
        dict
            wheel -> (residual [N m], threshold [N m], alarm, first alarm [s] or None).
        """
        lead = rows_of[self.lead]
        if len(self.observers) == 1:
            return lead
        out = {}
        for a, (r, threshold, _, _) in lead.items():
            firsts = sorted(rows_of[o][a][3] for o in self.observers if rows_of[o][a][2])
            alarm = len(firsts) >= self.votes
            out[a] = (r, threshold, alarm, firsts[self.votes - 1] if alarm else None)
        return out


def decision_of(text: str, method: str, observers=None) -> DecisionRule:
    """The DecisionRule a configuration names: '' (the method's decision observer), an observer's name, or a
    vote 'KofN' over the method's N observers (``observers``: those, default core/fdi/detection.observers_of).
    ValueError naming what it accepts.

    Parameters
    ----------
    text : str
        '', an observer's name, or 'KofN'.
    method : str
        The FDI method.
    observers : sequence of str, optional
        The method's observers.

    Returns
    -------
    DecisionRule
        The rule.
    """
    from .detection import observers_of
    available = tuple(observers or observers_of(method))
    text = (text or "").strip()
    if not text:
        return DecisionRule((decision_observer(method),))
    if text in available:
        return DecisionRule((text,))
    votes, sep, count = text.partition("of")
    if sep and votes.isdigit() and count.isdigit() and int(count) == len(available) and 1 <= int(votes) <= int(count):
        lead = decision_observer(method)   # its residual is what the verdict shows
        return DecisionRule((lead, *(o for o in available if o != lead)), int(votes))
    raise ValueError(f"decision must be one of {', '.join(available)} or a vote KofN of the {len(available)} "
                     f"observers (e.g. 2of{len(available)}), got {text!r}")


def stamp_seconds(stamp_ns: int) -> float:
    """Sim time [s] of a stamp; exact for whole seconds.

    Parameters
    ----------
    stamp_ns : int
        Stamp [ns].

    Returns
    -------
    float
        Time [s].
    """
    return stamp_ns // 10**9 + (stamp_ns % 10**9) * 1e-9


class ObserverChannel:
    """One observer's alarms: |residual_k| against threshold(k) + bound_k for P consecutive samples.

    ``update`` returns wheel -> (residual, threshold + bound, alarm, first alarm time or None).
    A non-finite residual or bound is not judged: the wheel's alarm state is held (NaN > threshold
    is False, it would clear an alarm) and the wheel is in ``unjudged`` until its next finite sample.
    """

    def __init__(self, observer: str, curves: ThresholdCurves, persistence: int | None = None, wheels=AXIS_WHEELS):
        self.observer = observer
        self.curves = curves
        self.persistence = persistence or curves.persistence
        self.wheels = tuple(wheels)   # the wheels judged, in the order of the residual vectors
        self.reset()

    def reset(self):
        """Forget every alarm: a new run starts."""
        self.rules = {a: AlarmRule(self.persistence) for a in self.wheels}
        self.beyond_horizon = False
        self.unjudged = set()   # wheels whose last sample could not be judged (non-finite input)

    def update(self, stamp_ns: int, residual, bound=None):
        """One FDI sample of this observer: each wheel's threshold c(k) + b and its persistence rule.

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp [ns].
        residual : array_like
            (N,) residuals [N m].
        bound : array_like or None
            (N,) ripple bounds b [N m] (None: 0).

        Returns
        -------
        dict
            wheel -> (residual [N m], threshold [N m], alarm, first alarm [s] or None).
        """
        t = stamp_seconds(stamp_ns)
        self.beyond_horizon = t > self.curves.horizon   # the curves cannot judge this moment (health)
        k = int(round(t / self.curves.sample_period))
        rows = {}
        bound = np.zeros(len(self.wheels)) if bound is None else bound
        for i, wheel in enumerate(self.wheels):
            rule, r, b = self.rules[wheel], float(residual[i]), float(bound[i])
            # never below 0: a calibrated band may be negative (the bound over-covers), and an exactly
            # zero residual with a zero bound (a standby wheel at rest, unpowered) agrees perfectly
            threshold = max(self.curves.at(wheel, k) + b, 0.0)
            if math.isfinite(r) and math.isfinite(b):
                self.unjudged.discard(wheel)
                rule.update(abs(r), threshold, t)
            else:
                self.unjudged.add(wheel)
            rows[wheel] = (r, threshold, rule.active, rule.first_alarm)
        return rows


class LatchedVerdict:
    """The verdict users read: a wheel the decision observer has alarmed is a confirmed failure and stays
    one until :meth:`reset` (flight FDIR latches a confirmed failure until commanded otherwise), whatever
    its residual does after (a manoeuvre, a fault the controller works around). Without ``latch`` the
    verdict is the observer's alarm itself (the thesis' behaviour).

    ``update`` takes and returns rows wheel -> (residual, threshold, alarm, first alarm or None) of
    :meth:`ObserverChannel.update`; a latched row keeps its first alarm time and has ``latched[wheel]``
    True while the observer's own alarm is down."""

    def __init__(self, latch: bool = True, wheels=AXIS_WHEELS):
        self.latch = latch
        self.wheels = tuple(wheels)
        self.reset()

    def reset(self, wheels=None):
        """Clear the confirmed failures of ``wheels`` (an operator's command): judged afresh from now on.

        Parameters
        ----------
        wheels : iterable of str or None
            The wheels; None: every wheel.
        """
        if not hasattr(self, "confirmed"):
            self.confirmed, self.latched = {}, {}
        for a in self.wheels if wheels is None else wheels:
            self.confirmed[a], self.latched[a] = None, False

    def update(self, rows: dict, judged=None) -> dict:
        """``judged``: wheel -> False for a wheel whose sample cannot be judged (outside the operating
        envelope): its verdict holds (a confirmed failure stays, none is confirmed from this sample).

        Parameters
        ----------
        rows : dict
            wheel -> (residual, threshold, alarm, first alarm or None) of the decision.
        judged : dict or None
            wheel -> whether its sample is judged (None: every wheel).

        Returns
        -------
        dict
            wheel -> (residual [N m], threshold [N m], alarm or held, confirmed or first alarm [s] or None).
        """
        out = {}
        for a, (r, threshold, alarm, first) in rows.items():
            if judged is not None and not judged[a]:
                alarm, first = False, None
            if alarm and self.confirmed[a] is None:
                self.confirmed[a] = first
            held = self.latch and self.confirmed[a] is not None
            self.latched[a] = held and not alarm
            out[a] = (r, threshold, bool(alarm or held), self.confirmed[a] if held else first)
        return out
