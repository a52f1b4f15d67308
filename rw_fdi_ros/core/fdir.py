"""FDIR: what the spacecraft does with a wheel the FDI has confirmed faulty (thesis chapter 1, 2.3).

:class:`Reconfiguration` makes the decision the way flight FDIR makes it (the reasons, with their
figures: docs/fdir.md):

* only on a confirmed failure (the latched verdict of /diagnostics, isolation.LatchedVerdict) or an
  operator's command, never on a single residual;
* *given up*: taken out of use for good (0 V from then on) and the first standby wheel whose addition
  keeps the wheels in use spanning the body brought in; with none left, given up only if the others
  still span the body, else kept in use and the decision says why;
* *kept in use beside the spare* where the wheels left could not hold the stored momentum and still take
  the manoeuvres to come (:func:`momentum_shortfall`, :func:`slew_excursion`): all share the work by
  minimum norm and the controller's feedback takes up what the faulty wheel does not give;
* *held* where it gives under half its motor torque (:func:`delivered_share`) or no spare is left, with
  the same shortfall: relieved of attitude control and commanded only to keep its speed
  (allocation.hold_command), a momentum store.

After a reconfiguration the wheels are watched (:meth:`Reconfiguration.review`): a kept wheel is held
once it gives under half its torque, or said where no wheel is left to take its share, and a wheel in
use past the holdable speed or at the voltage limit is said (``at_limit``).

Every decision is a :class:`Decision` (time, wheel, action, reason), which the graph publishes and
records. :class:`DecisionDelay`: a decision on the FDI sample stamped t acts on the commands from
t + ``DECISION_DELAY`` on (flight software applies FDIR in the next cycle), in the graph's allocation
node and the core loop alike.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from .control.allocation import distribution
from .fdi.verdict import WHEEL_SPEED_ENVELOPE
from .physics.spacecraft import INERTIA
from .fdi.telemetry import model_reaction_torque
from .physics.wheel import WheelParams, torque_scale
from .physics.wheel_set import WheelSet

DECISION_DELAY = 1.0   # [s] from the FDI sample a decision is made on to the first command it shapes
# [rad/s] the speed a wheel can hold and still be judged: the FDI's envelope, just under the 47.3 rad/s at which
# friction takes the whole 5 V command (isolation.WHEEL_SPEED_ENVELOPE); what a reconfiguration may ask
HOLDABLE_SPEED = WHEEL_SPEED_ENVELOPE
ACTIONS = ("out_of_use", "in_use", "kept_in_use", "held", "at_limit")
# [rad/s] body rate per axis of Table 2.3's largest set-point change (5 deg) under the PID: its peak,
# 0.45-0.48 deg/s, measured on a step of 5 deg on every axis (the wheels' speeds then move by up to 22 rad/s)
SLEW_RATE = np.deg2rad(0.5)
# a wheel kept in use beside the spare must still give at least this share of its motor torque: one that gives
# less (a bus drop above the speed its bus can drive: it gives next to nothing and sheds its momentum) would
# leave the controllers a fifth of their gain about its axis, and is held instead
KEEPABLE_SHARE = 0.5
# a wheel held that gives under this share of its motor torque cannot keep even the speed it is held at (a bus drop
# above the speed its bus can drive brakes it: seed 801,772,787 went from 26.6 to 7.2 rad/s in 30 s): said
STARVED_SHARE = 0.05
DELIVERY_SAMPLES = 10   # control samples (one FDI period) the share is measured over before a decision
# [s] a wheel in use after a reconfiguration commanded at the voltage limit for this long gives all it can and is
# still short: the wheels in use cannot take the momentum (a slew's start saturates a command for seconds; a
# unit whose friction takes the whole 5 V under the holdable speed stays there for minutes)
SATURATED_S = 30.0


def confirmed_reason(first_alarm: float) -> str:
    """Why a wheel is given up on the FDI's confirmed verdict (the same words in the graph and the loop).

    Parameters
    ----------
    first_alarm : float
        Time of the wheel's first alarm [s].

    Returns
    -------
    str
        The reason, one line.
    """
    return f"confirmed faulty by the FDI (alarm since {first_alarm:g} s)"


@dataclass(frozen=True)
class Decision:
    """One reconfiguration decision: ``wheel`` goes ``action`` at sim time ``time`` [s] because ``reason``."""

    time: float
    wheel: str
    action: str
    reason: str

    def message(self) -> str:
        """One line a person reads: the wheel, what it does, when and why.

        Returns
        -------
        str
            The line.
        """
        what = {"out_of_use": "taken out of use", "in_use": "brought into use",
                "kept_in_use": "kept in use", "held": "held at its speed",
                "at_limit": "at its limit"}[self.action]
        return f"wheel {self.wheel} {what} at {self.time:g} s: {self.reason}"


def held_speeds(wheels: WheelSet, in_use, wheel_speed, body_momentum=(0.0, 0.0, 0.0),
                wheel_inertia: float = WheelParams().inertia) -> np.ndarray:
    """Speeds (N,) [rad/s] the wheels ``in_use`` settle at once they hold all the momentum the spacecraft
    has now (the wheels' at ``wheel_speed`` (N,) plus the body's I w), the others stopped and the body
    pointing: J G Omega' = J G Omega + I w. Three wheels in use have one answer; with more, this is the
    minimum-norm one, which the loop need not reach.

    Angular momentum is conserved: a wheel given up spins down by its friction and its momentum goes to
    the body, from which the controller moves it into the wheels in use. With three wheels in use there
    is one answer; a redundant wheel at 1/sqrt(3) to an axis must spin sqrt(3) times as fast as the
    axis wheel it replaces did.

    Parameters
    ----------
    wheels : WheelSet
        The wheel set.
    in_use : iterable of str
        Names of the wheels in use after the reconfiguration; they must span the body (else ValueError).
    wheel_speed : array_like, shape (N,)
        Wheel speeds Omega now [rad/s], in the set's order.
    body_momentum : array_like, shape (3,), optional
        The body's angular momentum I w [N m s], body frame.
    wheel_inertia : float, optional
        J [kg m^2].

    Returns
    -------
    ndarray, shape (N,)
        Omega' [rad/s]; 0 for the wheels not in use.
    """
    u = distribution(wheels.matrix, wheels.mask(in_use))
    return u @ (wheels.matrix @ np.asarray(wheel_speed, float) + np.asarray(body_momentum, float) / wheel_inertia)


def slew_excursion(wheels: WheelSet, in_use, slew_rate: float = SLEW_RATE, body_inertia=INERTIA,
                   wheel_inertia: float = WheelParams().inertia) -> np.ndarray:
    """How far (N,) [rad/s] each wheel ``in_use`` may have to move its speed for a slew at ``slew_rate``
    [rad/s] about any combination of axes: the body momentum I w of the slew, |w_a| <= slew_rate, spread
    by the minimum-norm distribution D of the wheels in use, at its largest over the box of rates,

        dOmega_i = sum_a |(D I)_ia| slew_rate / J       (= sum_a |D_ia| I_a slew_rate / J, I diagonal)

    A redundant wheel at 1/sqrt(3) to the axis it takes over moves sqrt(3) times as far as the axis wheel
    did: about 33 rad/s on the datasheet wheel for Table 2.3's 5-deg slews.

    Parameters
    ----------
    wheels : WheelSet
        The wheel set.
    in_use : iterable of str
        Names of the wheels in use; they must span the body (else ValueError).
    slew_rate : float, optional
        Largest body rate per axis [rad/s].
    body_inertia : array_like, shape (3,) or (3, 3), optional
        The body's inertia I [kg m^2]: its diagonal, or the matrix.
    wheel_inertia : float, optional
        J [kg m^2].

    Returns
    -------
    ndarray, shape (N,)
        dOmega [rad/s]; 0 for the wheels not in use.
    """
    d = distribution(wheels.matrix, wheels.mask(in_use))
    inertia = np.asarray(body_inertia, float)
    if inertia.ndim == 2:   # products of inertia: a rate about one axis stores momentum about the others too
        return np.abs(d @ inertia).sum(axis=1) * slew_rate / wheel_inertia
    return np.abs(d) @ (inertia * slew_rate) / wheel_inertia


def momentum_shortfall(wheels: WheelSet, in_use, wheel_speed, body_momentum=(0.0, 0.0, 0.0),
                       holdable: float = HOLDABLE_SPEED, slew_rate: float = SLEW_RATE, body_inertia=INERTIA,
                       wheel_inertia: float = WheelParams().inertia) -> str | None:
    """Why the wheels ``in_use`` cannot hold the spacecraft's momentum and still take a slew at ``slew_rate``
    (one line), or None when they can: every wheel within ``holdable`` at |held speed| + slew excursion.

    Parameters
    ----------
    wheels : WheelSet
        The wheel set.
    in_use : iterable of str
        Names of the wheels that would be in use; they must span the body (else ValueError).
    wheel_speed : array_like, shape (N,)
        Wheel speeds now [rad/s], in the set's order.
    body_momentum : array_like, shape (3,), optional
        The body's angular momentum I w [N m s], body frame.
    holdable : float, optional
        Largest speed a wheel in use may be asked to hold [rad/s].
    slew_rate : float, optional
        Body rate per axis of the slews to come [rad/s]; 0 for none.
    body_inertia : array_like, shape (3,) or (3, 3), optional
        The vehicle's inertia I [kg m^2] (its diagonal is what a slew about one axis asks).
    wheel_inertia : float, optional
        J [kg m^2].

    Returns
    -------
    str or None
        The reason, naming the worst wheel and its speeds [rad/s]; None when every wheel stays within ``holdable``.
    """
    need = np.abs(held_speeds(wheels, in_use, wheel_speed, body_momentum, wheel_inertia))
    reach = need + slew_excursion(wheels, in_use, slew_rate, body_inertia, wheel_inertia)
    worst = int(np.argmax(reach))
    if reach[worst] <= holdable:
        return None
    slew = f" and {reach[worst] - need[worst]:.0f} more for a slew" if slew_rate > 0 else ""
    return (f"wheel {wheels.names[worst]} would have to spin at {need[worst]:.1f} rad/s to hold the stored "
            f"momentum{slew} (holds {holdable:g})")


def delivered_share(tcv, wheel_speed, reaction_torque, params: WheelParams = WheelParams()) -> float:
    """The share a^ of its nominal motor torque a wheel gave over control samples (arrays (n,)): the command
    in force ``tcv`` [V] and the wheel's ``wheel_speed`` [rad/s] and ``reaction_torque`` [N m] it led to,

        a^ = sum tau_m (tau_f - r) / sum tau_m^2        (r = -(a tau_m - tau_f), the current-loss family)

    with tau_m, tau_f the nominal wheel's (telemetry.model_reaction_torque). NaN where the wheel was asked
    for next to no motor torque (nothing to measure it on).

    Parameters
    ----------
    tcv : array_like, shape (n,)
        Command in force at each control sample [V].
    wheel_speed : array_like, shape (n,)
        Wheel speed [rad/s].
    reaction_torque : array_like, shape (n,)
        Measured reaction torque r [N m].
    params : WheelParams
        The wheel type (its nominal model).

    Returns
    -------
    float
        a^ (dimensionless, 1 for a healthy wheel), or NaN.
    """
    model, tau_m, _ = model_reaction_torque(np.asarray(tcv, float), np.asarray(wheel_speed, float), params)
    tau_f = model + tau_m
    power = float(np.sum(tau_m * tau_m))
    # |tau_m| under 1e-4 N m on average (the Type A's; another type's scaled by its torque, wheel.torque_scale)
    if power < len(np.atleast_1d(tau_m)) * (1e-4 * torque_scale(params)) ** 2:
        return float("nan")
    return float(np.sum(tau_m * (tau_f - np.asarray(reaction_torque, float))) / power)


class DeliveryLog:
    """The last DELIVERY_SAMPLES control samples of a batch: the command in force and the wheel speed and
    reaction torque it led to, (B, N) each, for :func:`delivered_share` at a decision (the core loop and the
    wheel allocation node keep one alike); ``params``: the wheel type (its nominal model and command limit)."""

    def __init__(self, samples: int = DELIVERY_SAMPLES, params: WheelParams = WheelParams()):
        self.rows = deque(maxlen=samples)
        self.params = params

    def add(self, tcv, wheel_speed, reaction_torque):
        """Keep one control sample (the oldest one dropped once DELIVERY_SAMPLES are kept).

        Parameters
        ----------
        tcv : array_like
            (B, N) or (N,) commands in force u [V].
        wheel_speed : array_like
            (B, N) or (N,) wheel speeds Omega [rad/s].
        reaction_torque : array_like
            (B, N) or (N,) reaction torques r [N m].
        """
        self.rows.append(tuple(np.atleast_2d(np.asarray(x, float)) for x in (tcv, wheel_speed, reaction_torque)))

    def share(self, wheel_index: int, b: int = 0) -> float:
        """The share a^ of its nominal motor torque wheel ``wheel_index`` of run ``b`` gave over the samples kept.

        Parameters
        ----------
        wheel_index : int
            The wheel's index in the set.
        b : int
            The run's index in the batch.

        Returns
        -------
        float
            a^ (:func:`delivered_share`); NaN when no sample is kept.
        """
        if not self.rows:
            return float("nan")
        u, w, r = (np.array([row[k][b, wheel_index] for row in self.rows]) for k in range(3))
        return delivered_share(u, w, r, self.params)

    def saturated(self, wheel_index: int, b: int = 0, limit: float | None = None) -> bool:
        """Whether every command of the samples kept was at the voltage ``limit`` [V] (None: the wheel type's).

        Parameters
        ----------
        wheel_index : int
            The wheel's index in the set.
        b : int
            The run's index in the batch.
        limit : float or None
            The command limit [V]; None: the wheel type's.

        Returns
        -------
        bool
            False when no sample is kept.
        """
        limit = self.params.command_limit if limit is None else limit
        return bool(self.rows) and all(abs(row[0][b, wheel_index]) >= limit - 1e-9 for row in self.rows)

    def of(self, names, b: int = 0) -> "Delivered":
        """Run ``b``'s wheels by name (what :meth:`Reconfiguration.review` reads).

        Parameters
        ----------
        names : sequence of str
            The wheels of the set, in its order.
        b : int
            The run's index in the batch.

        Returns
        -------
        Delivered
            Run ``b``'s view of the log.
        """
        return Delivered(self, tuple(names), b)


@dataclass(frozen=True)
class Delivered:
    """What one run's wheels gave over the samples a DeliveryLog keeps (the last FDI period), by wheel name."""

    log: DeliveryLog
    names: tuple
    b: int = 0

    def share(self, wheel: str) -> float:
        """The share a^ of its nominal motor torque ``wheel`` gave (:meth:`DeliveryLog.share`).

        Parameters
        ----------
        wheel : str
            The wheel's name.

        Returns
        -------
        float
            a^; NaN when no sample is kept.
        """
        return self.log.share(self.names.index(wheel), self.b)

    def saturated(self, wheel: str) -> bool:
        """Whether every command of ``wheel`` kept was at the voltage limit (:meth:`DeliveryLog.saturated`).

        Parameters
        ----------
        wheel : str
            The wheel's name.

        Returns
        -------
        bool
            Saturated throughout.
        """
        return self.log.saturated(self.names.index(wheel), self.b)


class Reconfiguration:
    """Which wheels of ``wheels`` are in use, and the decisions that made it so."""

    def __init__(self, wheels: WheelSet, holdable: float = HOLDABLE_SPEED, slew_rate: float = SLEW_RATE,
                 body_inertia=INERTIA, wheel_inertia: float = WheelParams().inertia):
        self.wheels = wheels
        self.body_inertia = body_inertia     # [kg m^2] the vehicle's I, (3,) or (3, 3)
        self.wheel_inertia = wheel_inertia   # [kg m^2] J
        self.holdable = float(holdable)   # [rad/s] the speed a wheel in use may be asked to hold
        self.slew_rate = float(slew_rate)   # [rad/s] the body rate of the slews the wheels in use must take
        self.in_use = list(wheels.active)
        self.spares = list(wheels.standby)
        self.given_up = []
        self.kept = set()      # wheels confirmed faulty but kept (no replacement): said once
        self.beside = {}       # kept wheel -> the spare brought in beside it (watched: review)
        self.at_limit = set()  # wheels in use said at their limit after a reconfiguration: speed or torque (review)
        self.saturated_since = {}   # wheel in use -> since when [s] its command has been at the limit (review)
        self.held = {}         # wheel -> the speed [rad/s] it is held at (out of control, a momentum store)
        self.decisions = []

    def give_up(self, wheel: str, t: float, reason: str, wheel_speed=None, body_momentum=(0.0, 0.0, 0.0),
                force: bool = False, delivered: float = float("nan")) -> list:
        """Take ``wheel`` out of use (confirmed faulty, or an operator's command) and bring a standby
        wheel in; returns the new decisions (none when it is already given up or said kept).

        With the ``wheel_speed`` (N,) and ``body_momentum`` (3,) [N m s] now: when the wheels left could
        not hold the spacecraft's momentum (:func:`momentum_shortfall`), giving the wheel up would lose the
        pointing for certain: it is held instead (relieved of control, kept at its speed now; see the module
        docstring) and the standby wheel brought in, and the decision says why. ``force`` (an operator's
        command) gives it up all the same, a held wheel too, and says what that costs.

        Parameters
        ----------
        wheel : str
            The wheel's name.
        t : float
            Sim time of the decision [s].
        reason : str
            Why (the decision's words).
        wheel_speed : array_like or None
            (N,) wheel speeds Omega [rad/s] now; None: the momentum is not checked.
        body_momentum : array_like
            (3,) the body's angular momentum [N m s].
        force : bool
            An operator's command: given up whatever it costs.
        delivered : float
            The share a^ of its nominal motor torque the wheel gave lately (NaN: unknown).

        Returns
        -------
        list of Decision
            The new decisions.
        """
        self.wheels.index(wheel)   # ValueError naming the wheels for an unknown one
        if wheel in self.given_up or ((wheel in self.kept or wheel in self.held) and not force):
            return []
        spare = None
        if wheel in self.spares:   # a standby wheel that failed before it was needed
            self.spares.remove(wheel)
        elif wheel in self.in_use:
            rest = [w for w in self.in_use if w != wheel]
            spare = next((s for s in self.spares if self.wheels.spans(rest + [s])), None)
            if spare is None and not self.wheels.spans(rest):   # not even an operator can take its axis away
                return [] if wheel in self.kept else self._keep(wheel, t, f"{reason}; no wheel left to take over "
                                                                          "its torque")
            after = rest + ([spare] if spare is not None else [])
            short = None if wheel_speed is None else momentum_shortfall(self.wheels, after, wheel_speed,
                                                                         body_momentum, self.holdable,
                                                                         self.slew_rate, self.body_inertia,
                                                                         self.wheel_inertia)
            if short and spare is not None and not force and not delivered < KEEPABLE_SHARE:
                # the wheels left could not hold the momentum and still slew: the faulty wheel keeps its
                # momentum and a share of the work beside the spare (all of them in use, minimum norm)
                self.spares.remove(spare)
                self.in_use = self.in_use + [spare]
                self.kept.add(wheel)
                self.beside[wheel] = spare
                out = [Decision(t, wheel, "kept_in_use", f"{reason}; kept in use beside wheel {spare}: were it "
                                                         f"given up, {short}"),
                       Decision(t, spare, "in_use", f"shares the work of wheel {wheel}")]
                self.decisions += out
                return out
            self.in_use = after
            if spare is not None:
                self.spares.remove(spare)
            if short and not force:
                speed = float(wheel_speed[self.wheels.index(wheel)])
                self.held[wheel] = speed
                weak = (f"it gives {100 * max(delivered, 0.0):.0f} % of its torque, too little to keep in use"
                        + (", too little to hold that speed: it sheds momentum down to the speed its drive can hold, "
                           "which the wheels in use take" if delivered < STARVED_SHARE else "") + "; "
                        if spare is not None else "")
                out = [Decision(t, wheel, "held", f"{reason}; relieved of control and held at {speed:.1f} rad/s "
                                                  f"as a momentum store ({weak}were it given up, {short})")]
                return self._decided(out, spare, wheel, None)
            if short:
                short += ": pointing is lost until momentum is dumped"
            self.beside.pop(wheel, None)   # an operator's command on a wheel kept beside the spare
            self.given_up.append(wheel)
            return self._decided([Decision(t, wheel, "out_of_use", reason)], spare, wheel, short)
        self.held.pop(wheel, None)   # an operator overrules a wheel FDIR held
        self.beside.pop(wheel, None)
        self.given_up.append(wheel)
        return self._decided([Decision(t, wheel, "out_of_use", reason)], None, wheel, None)

    def review(self, t: float, wheel_speed, delivered: Delivered | None = None) -> list:
        """What the wheels do after a reconfiguration, watched at every sample; returns the new decisions.

        * A wheel kept in use beside a spare that now gives under KEEPABLE_SHARE of its motor torque
          (``delivered``: what the wheels gave over the last second, given on the FDI's stamps: once a
          period, on the samples of that period) is held. A fault that grows after
          the decision (a bus ramping down while the wheel spins above what its bus can drive) turns a wheel
          worth keeping into one that takes a share of the work it cannot give, leaving the controllers about
          its axis a fraction of their gain: it is held, as it would have been had it been that weak when
          confirmed (while the wheels left span the body). Where they do not (the spare beside it failed too,
          or it was kept for want of a wheel), it is said, once: the pointing is lost about its axis.
        * A wheel in use beyond ``holdable`` (``wheel_speed`` (N,) [rad/s]) once FDIR has acted, or commanded at
          the voltage limit for SATURATED_S (a unit whose friction takes the whole command below ``holdable``),
          is said, once: the wheels left cannot hold the momentum the reconfiguration left them (a held wheel
          that sheds what its fault does not let it keep), and the pointing is lost until momentum is dumped.

        Parameters
        ----------
        t : float
            Sim time [s].
        wheel_speed : array_like
            (N,) wheel speeds Omega [rad/s].
        delivered : Delivered or None
            What the wheels gave over the last samples; None: not known at this sample.

        Returns
        -------
        list of Decision
            The new decisions.
        """
        out = self._review_kept(t, wheel_speed, delivered) + self._review_speeds(t, wheel_speed) + \
            self._review_saturation(t, wheel_speed, delivered)
        self.decisions += out
        return out

    def _review_kept(self, t: float, wheel_speed, delivered) -> list:
        """:meth:`review`'s first rule: a wheel kept beside a spare that gives too little is held, or said."""
        out = []
        for wheel in [w for w in self.wheels.names if w in self.kept and w in self.in_use and delivered is not None]:
            given = delivered.share(wheel)
            if not given < KEEPABLE_SHARE:        # NaN: nothing asked of it
                continue
            rest = [w for w in self.in_use if w != wheel]
            if wheel in self.beside and self.wheels.spans(rest):
                del self.beside[wheel]
                self.kept.discard(wheel)
                self.in_use = rest
                speed = float(wheel_speed[self.wheels.index(wheel)])
                self.held[wheel] = speed
                out.append(Decision(t, wheel, "held", f"gives {100 * max(given, 0.0):.1f} % of its motor torque over "
                                                      f"the last second, under the {100 * KEEPABLE_SHARE:.0f} % a "
                                                      f"wheel kept in use must give; relieved of control and held at "
                                                      f"{speed:.1f} rad/s as a momentum store"))
            elif wheel not in self.at_limit:       # no wheel left to take its share: said, once
                self.at_limit.add(wheel)
                out.append(Decision(t, wheel, "at_limit", f"gives {100 * max(given, 0.0):.1f} % of its motor torque "
                                                          "over the last second and no wheel is left to take its "
                                                          "share: pointing is lost about its axis while its fault "
                                                          "lasts"))
        return out

    def _review_speeds(self, t: float, wheel_speed) -> list:
        """:meth:`review`'s second rule: once FDIR has acted, a wheel in use beyond ``holdable`` is said."""
        out = []
        if self.given_up or self.held or self.kept:
            for wheel in self.in_use:
                speed = float(wheel_speed[self.wheels.index(wheel)])
                if abs(speed) > self.holdable and wheel not in self.at_limit:
                    self.at_limit.add(wheel)
                    out.append(Decision(t, wheel, "at_limit", f"at {speed:.1f} rad/s, beyond the {self.holdable:g} "
                                                              "rad/s a wheel in use can hold with torque to spare: the "
                                                              "wheels in use cannot hold the momentum left them; "
                                                              "pointing is lost until momentum is dumped"))
        return out

    def _review_saturation(self, t: float, wheel_speed, delivered) -> list:
        """:meth:`review`'s third rule: a wheel in use commanded at the voltage limit for SATURATED_S is said."""
        out = []
        for wheel in self.in_use if delivered is not None else ():
            if not delivered.saturated(wheel):
                self.saturated_since.pop(wheel, None)
                continue
            since = self.saturated_since.setdefault(wheel, t)
            if t - since >= SATURATED_S and wheel not in self.at_limit:
                self.at_limit.add(wheel)
                speed = float(wheel_speed[self.wheels.index(wheel)])
                out.append(Decision(t, wheel, "at_limit", f"commanded at the voltage limit for {t - since:.0f} s at "
                                                          f"{speed:.1f} rad/s: it gives all it can, and the wheels "
                                                          "in use cannot hold the momentum left them; pointing is "
                                                          "lost until momentum is dumped"))
        return out

    def _decided(self, out: list, spare, wheel: str, short) -> list:
        if spare is not None:
            out.append(Decision(out[0].time, spare, "in_use",
                                f"replaces wheel {wheel}" + (f"; but {short}" if short else "")))
        self.decisions += out
        return out

    def _keep(self, wheel: str, t: float, reason: str) -> list:
        self.kept.add(wheel)
        kept = Decision(t, wheel, "kept_in_use", reason)
        self.decisions.append(kept)
        return [kept]

    @property
    def settled(self) -> set:
        """The wheels decided for good: given up, held, or kept with the reason said."""
        return set(self.given_up) | self.kept | set(self.held)

    def ordered_in_use(self) -> tuple:
        """The wheels in use in the set's order.

        Returns
        -------
        tuple of str
            The wheels' names.
        """
        return tuple(n for n in self.wheels.names if n in self.in_use)


class DecisionDelay:
    """Decisions made on FDI stamps, applied from ``delay`` seconds later (see the module docstring)."""

    def __init__(self, delay: float = DECISION_DELAY):
        self.delay = float(delay)
        self.pending = []      # (apply from [s], what)
        self.requested = set()  # what was put, ever (a confirmed failure is decided once)

    def put(self, made_at: float, what):
        """Put ``what`` to be applied ``delay`` seconds after ``made_at``.

        Parameters
        ----------
        made_at : float
            Sim time the decision was made [s].
        what : object
            The decision (the caller's form: a (wheel, reason) pair, an operator's command).
        """
        self.pending.append((made_at + self.delay, what))

    def confirm(self, confirmed: dict, made_at: float, settled=()):
        """Put each wheel of ``confirmed`` (wheel -> first alarm [s], in the set's order) that is not
        ``settled`` and was not put before: a confirmed failure is decided once, the earliest alarm first
        (ties in the set's order). The core loop and the wheel allocation node both call this.

        Parameters
        ----------
        confirmed : dict
            wheel -> first alarm [s], in the set's order.
        made_at : float
            Sim time of the FDI stamp [s].
        settled : collection of str
            Wheels already decided on.
        """
        for wheel, first in sorted(confirmed.items(), key=lambda c: c[1]):
            if wheel not in settled and wheel not in self.requested:
                self.requested.add(wheel)
                self.put(made_at, (wheel, confirmed_reason(first)))

    def due(self, t: float) -> list:
        """What is due at sim time ``t`` (in the order it was put), removed from the pending.

        Parameters
        ----------
        t : float
            Sim time [s].

        Returns
        -------
        list
            What was put, now due.
        """
        due = [w for at, w in self.pending if at <= t + 1e-9]
        self.pending = [(at, w) for at, w in self.pending if at > t + 1e-9]
        return due
