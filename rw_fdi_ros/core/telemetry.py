"""Wheel telemetry at the control rate -> FDI samples, with what the speed-aware observers need.

Every real reaction wheel reports its speed (a tachometer); with it, two things
the thesis' observers had to guess become known:

* the torque a healthy wheel gives for the measured command and speed, the
  nominal Bialke model (Fig. 2.2 at Table 2.3's bus 8 V, limiter 1, 23 C):
      r_model = -(k_t I_m(u, Omega) - tau_v(23 C) Omega - tau_c tanh(Omega / w_c))
* the commutation ripple's phase up to a constant: N theta with
  theta = integral of Omega dt (trapezoid over the control samples). The ripple
  in the sampled reaction torque is (B/2) g tau_m sin(N theta + phi); at wheel
  speeds near k 2 pi / (N T_c) (1.745 rad/s apart at 36 poles and 0.1 s) it
  aliases to almost zero frequency and no moving average removes it. The mean
  phasor p = mean(tau_m e^{i N theta}) bounds what it can add to any window mean:
      |mean(ripple)| <= (B/2) g_max |mean(p)|       for a constant gain up to g_max
  (detection.ripple_reach widens it to any gain that changes monotonically in the window)

:class:`TelemetrySampler` feeds on the control-rate signals and returns one
:class:`FdiSample` per FDI period (means over (t - T, t], core/sampling.py).
The observer nodes and the offline tools both use it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import wheel as wm
from .sampling import FdiSampler


def model_reaction_torque(tcv, wheel_speed, params: wm.WheelParams = wm.WheelParams()):
    """Reaction torque [N m] of a healthy wheel for command ``tcv`` at speed ``wheel_speed`` (no ripple)."""
    nominal = wm.NOMINAL
    tau_m = params.torque_constant * wm.motor_current(tcv, wheel_speed, nominal.bus_voltage, 1.0, params)
    return -(tau_m - wm.friction_torque(wheel_speed, nominal.temperature, params)), tau_m


@dataclass
class FdiSample:
    """One FDI sample of three wheels; every field (3,) and a mean over the FDI period."""

    stamp_ns: int
    tcv: np.ndarray              # [V]
    reaction_torque: np.ndarray  # [N m]
    wheel_speed: np.ndarray | None = None     # [rad/s]
    model_torque: np.ndarray | None = None    # nominal wheel model's reaction torque [N m]
    ripple_phasor: np.ndarray | None = None   # mean of tau_m e^{i N theta} (complex) [N m]
    # fault identification (identification.py), when the sampler is asked for it:
    motor_torque: np.ndarray | None = None     # nominal tau_m(u, Omega; 8 V) [N m]
    friction_torque: np.ndarray | None = None  # nominal tau_f(Omega; 23 C) [N m]
    bus_motor_torque: np.ndarray | None = None  # (3, bus grid) tau_m(u, Omega; V) [N m]


class TelemetrySampler:
    """Control-rate (tcv, reaction torque[, wheel speed]) in, an :class:`FdiSample` on every FDI stamp.

    Without wheel speed (the thesis' observers) it is :class:`FdiSampler` on (tcv, torque).
    """

    def __init__(self, period: float = 1.0, mode: str = "mean", params: wm.WheelParams = wm.WheelParams(),
                 identification: bool = False):
        self.params = params
        self.identification = identification   # also the terms fault identification fits
        self.sampler = FdiSampler(period, mode)
        self.mode = mode
        self.theta = None        # wheel angle since the first sample [rad]
        self.last = None         # (stamp_ns, wheel speed) of the previous sample

    def add(self, stamp_ns: int, tcv, reaction_torque, wheel_speed=None) -> FdiSample | None:
        if wheel_speed is None:
            row = self.sampler.add(stamp_ns, tcv, reaction_torque)
            return None if row is None else FdiSample(row[0], row[1][0], row[1][1])
        speed = np.asarray(wheel_speed, float)
        return self._sample(stamp_ns, self._signals(tcv, reaction_torque, speed, self._advance(stamp_ns, speed)))

    def add_series(self, stamps_ns, tcv, reaction_torque, wheel_speed=None) -> list:
        """:meth:`add` over a whole series (time first), the same numbers: the wheel angle and the
        sums advance sample by sample, the model terms (elementwise) are computed for all at once."""
        if wheel_speed is None:
            rows = (self.add(int(s), u, r) for s, u, r in zip(stamps_ns, tcv, reaction_torque))
            return [row for row in rows if row is not None]
        speed = np.asarray(wheel_speed, float)
        theta = np.array([self._advance(int(s), w) for s, w in zip(stamps_ns, speed)]).reshape(speed.shape)
        signals = self._signals(np.asarray(tcv, float), np.asarray(reaction_torque, float), speed, theta)
        rows = (self._sample(int(s), [x[k] for x in signals]) for k, s in enumerate(stamps_ns))
        return [row for row in rows if row is not None]

    def _advance(self, stamp_ns: int, speed):
        """Wheel angle theta at this sample: trapezoid integral of the measured speed."""
        if self.last is None:
            self.theta = np.zeros_like(speed)
        else:
            dt = (stamp_ns - self.last[0]) * 1e-9
            self.theta = self.theta + 0.5 * (self.last[1] + speed) * dt
        self.last = (stamp_ns, speed)
        return self.theta

    def _signals(self, tcv, reaction_torque, speed, theta) -> list:
        """What is averaged over the FDI period, per control sample (any leading shape)."""
        if self.mode != "mean":
            raise ValueError("speed-aware FDI needs fdi_sampling 'mean' (the ripple bound is a mean)")
        model, tau_m = model_reaction_torque(tcv, speed, self.params)
        phasor = tau_m * np.exp(1j * self.params.poles * theta)
        out = [tcv, reaction_torque, speed, model, phasor]
        if self.identification:
            from .identification import bus_motor_torque
            out += [tau_m, model + tau_m, bus_motor_torque(tcv, speed, self.params)]
        return out

    def _sample(self, stamp_ns: int, signals) -> FdiSample | None:
        row = self.sampler.add(stamp_ns, *signals)
        return None if row is None else FdiSample(row[0], *row[1])


def sample_telemetry(stamps_ns, tcv, reaction_torque, wheel_speed=None, period: float = 1.0, mode: str = "mean",
                     params: wm.WheelParams = wm.WheelParams(), identification: bool = False):
    """Whole control-rate series (time first) -> list of FdiSample, through :class:`TelemetrySampler`."""
    return TelemetrySampler(period, mode, params, identification).add_series(stamps_ns, tcv, reaction_torque,
                                                                             wheel_speed)
