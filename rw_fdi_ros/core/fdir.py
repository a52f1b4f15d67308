"""FDIR: what the spacecraft does with a wheel the FDI has confirmed faulty (thesis chapter 1, 2.3).

Detection and isolation exist so that "the redundant one will be excited
in case any of the other three wheels fails". :class:`Reconfiguration`
is that decision, made the way flight FDIR makes it:

* only on a confirmed failure: the latched verdict of /diagnostics (the
  decision observer's alarm after its persistence, isolation.LatchedVerdict),
  or an operator's command; never on a single residual;
* the wheel is given up: taken out of use for good (the allocation gives it
  0 V from then on) and a standby wheel brought in, the first whose
  addition keeps the wheels in use spanning the body;
* with no standby left, the wheel is still taken out if the others span
  the body (a pyramid loses one of four); if they do not, it is kept in
  use and the decision says why: a faulty wheel that still gives some
  torque is better than an axis without control, and the spacecraft never
  commands a wheel it has given up on;
* where the wheels left could not hold the spacecraft's angular momentum
  without it (:func:`momentum_shortfall`), the wheel is *held*: relieved
  of attitude control (the standby wheel comes in all the same) and
  commanded only to keep its speed (allocation.hold_command), a momentum
  store. A wheel given up spins down by its friction and its momentum goes
  to the others; a held one keeps what its fault lets it keep (a 4 V bus:
  up to 6 rad/s, wheel.bus_fault_visible_above; a current loss or a hotter
  bearing: all of it), so the wheels in use only take the rest.

Every decision is a :class:`Decision` (time, wheel, action, reason), which
the graph publishes and records.

:class:`DecisionDelay`: a decision made on the FDI sample stamped t acts on
the commands from t + ``DECISION_DELAY`` on: one FDI period for the verdict to
travel (flight software applies FDIR in the next cycle). The graph's
allocation node and the core loop apply it at the same step, so they
command the same wheels.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .allocation import distribution
from .isolation import WHEEL_SPEED_ENVELOPE
from .wheel import WheelParams
from .wheel_set import WheelSet

DECISION_DELAY = 1.0   # [s] from the FDI sample a decision is made on to the first command it shapes
# [rad/s] the speed a wheel can hold and still be judged: the FDI's envelope, just under the 47.3 rad/s at which
# friction takes the whole 5 V command (isolation.WHEEL_SPEED_ENVELOPE); what a reconfiguration may ask
HOLDABLE_SPEED = WHEEL_SPEED_ENVELOPE
ACTIONS = ("out_of_use", "in_use", "kept_in_use", "held")


def confirmed_reason(first_alarm: float) -> str:
    """Why a wheel is given up on the FDI's confirmed verdict (the same words in the graph and the loop)."""
    return f"confirmed faulty by the FDI (alarm since {first_alarm:g} s)"


@dataclass(frozen=True)
class Decision:
    """One reconfiguration decision: ``wheel`` goes ``action`` at sim time ``time`` [s] because ``reason``."""

    time: float
    wheel: str
    action: str
    reason: str

    def message(self) -> str:
        what = {"out_of_use": "taken out of use", "in_use": "brought into use",
                "kept_in_use": "kept in use", "held": "held at its speed"}[self.action]
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
    """
    u = distribution(wheels.matrix, wheels.mask(in_use))
    return u @ (wheels.matrix @ np.asarray(wheel_speed, float) + np.asarray(body_momentum, float) / wheel_inertia)


def momentum_shortfall(wheels: WheelSet, in_use, wheel_speed, body_momentum=(0.0, 0.0, 0.0),
                       holdable: float = HOLDABLE_SPEED) -> str | None:
    """Why the wheels ``in_use`` cannot hold the spacecraft's momentum (one line), or None when they can."""
    need = held_speeds(wheels, in_use, wheel_speed, body_momentum)
    worst = int(np.argmax(np.abs(need)))
    if abs(need[worst]) <= holdable:
        return None
    return (f"wheel {wheels.names[worst]} would have to spin at {abs(need[worst]):.1f} rad/s to hold the stored "
            f"momentum (holds {holdable:g})")


class Reconfiguration:
    """Which wheels of ``wheels`` are in use, and the decisions that made it so."""

    def __init__(self, wheels: WheelSet, holdable: float = HOLDABLE_SPEED):
        self.wheels = wheels
        self.holdable = float(holdable)   # [rad/s] the speed a wheel in use may be asked to hold
        self.in_use = list(wheels.active)
        self.spares = list(wheels.standby)
        self.given_up = []
        self.kept = set()      # wheels confirmed faulty but kept (no replacement): said once
        self.held = {}         # wheel -> the speed [rad/s] it is held at (out of control, a momentum store)
        self.decisions = []

    def give_up(self, wheel: str, t: float, reason: str, wheel_speed=None, body_momentum=(0.0, 0.0, 0.0),
                force: bool = False) -> list:
        """Take ``wheel`` out of use (confirmed faulty, or an operator's command) and bring a standby
        wheel in; returns the new decisions (none when it is already given up or said kept).

        With the ``wheel_speed`` (N,) and ``body_momentum`` (3,) [N m s] now: when the wheels left could
        not hold the spacecraft's momentum (:func:`momentum_shortfall`), giving the wheel up would lose the
        pointing for certain: it is held instead (relieved of control, kept at its speed now; see the module
        docstring) and the standby wheel brought in, and the decision says why. ``force`` (an operator's
        command) gives it up all the same, a held wheel too, and says what that costs."""
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
                                                                         body_momentum, self.holdable)
            self.in_use = after
            if spare is not None:
                self.spares.remove(spare)
            if short and not force:
                speed = float(wheel_speed[self.wheels.index(wheel)])
                self.held[wheel] = speed
                out = [Decision(t, wheel, "held", f"{reason}; relieved of control and held at {speed:.1f} rad/s "
                                                  f"as a momentum store: were it given up, {short}")]
                return self._decided(out, spare, wheel, None)
            if short:
                short += ": pointing is lost until momentum is dumped"
            self.given_up.append(wheel)
            return self._decided([Decision(t, wheel, "out_of_use", reason)], spare, wheel, short)
        self.held.pop(wheel, None)   # an operator overrules a wheel FDIR held
        self.given_up.append(wheel)
        return self._decided([Decision(t, wheel, "out_of_use", reason)], None, wheel, None)

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
        """The wheels in use in the set's order."""
        return tuple(n for n in self.wheels.names if n in self.in_use)


class DecisionDelay:
    """Decisions made on FDI stamps, applied from ``delay`` seconds later (see the module docstring)."""

    def __init__(self, delay: float = DECISION_DELAY):
        self.delay = float(delay)
        self.pending = []      # (apply from [s], what)
        self.requested = set()  # what was put, ever (a confirmed failure is decided once)

    def put(self, made_at: float, what):
        self.pending.append((made_at + self.delay, what))

    def confirm(self, confirmed: dict, made_at: float, settled=()):
        """Put each wheel of ``confirmed`` (wheel -> first alarm [s], in the set's order) that is not
        ``settled`` and was not put before: a confirmed failure is decided once, the earliest alarm first
        (ties in the set's order). The core loop and the wheel allocation node both call this."""
        for wheel, first in sorted(confirmed.items(), key=lambda c: c[1]):
            if wheel not in settled and wheel not in self.requested:
                self.requested.add(wheel)
                self.put(made_at, (wheel, confirmed_reason(first)))

    def due(self, t: float) -> list:
        """What is due at sim time ``t`` (in the order it was put), removed from the pending."""
        due = [w for at, w in self.pending if at <= t + 1e-9]
        self.pending = [(at, w) for at, w in self.pending if at > t + 1e-9]
        return due
