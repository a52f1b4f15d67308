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
      |mean(ripple)| <= (B/2) g_max |mean(p)|       (see detection.SignedResidual)

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


class TelemetrySampler:
    """Control-rate (tcv, reaction torque[, wheel speed]) in, an :class:`FdiSample` on every FDI stamp.

    Without wheel speed (the thesis' observers) it is :class:`FdiSampler` on (tcv, torque).
    """

    def __init__(self, period: float = 1.0, mode: str = "mean", params: wm.WheelParams = wm.WheelParams()):
        self.params = params
        self.sampler = FdiSampler(period, mode)
        self.mode = mode
        self.theta = None        # wheel angle since the first sample [rad]
        self.last = None         # (stamp_ns, wheel speed) of the previous sample

    def add(self, stamp_ns: int, tcv, reaction_torque, wheel_speed=None) -> FdiSample | None:
        if wheel_speed is None:
            row = self.sampler.add(stamp_ns, tcv, reaction_torque)
            return None if row is None else FdiSample(row[0], row[1][0], row[1][1])
        if self.mode != "mean":
            raise ValueError("speed-aware FDI needs fdi_sampling 'mean' (the ripple bound is a mean)")
        speed = np.asarray(wheel_speed, float)
        if self.last is None:
            self.theta = np.zeros_like(speed)
        else:
            dt = (stamp_ns - self.last[0]) * 1e-9
            self.theta = self.theta + 0.5 * (self.last[1] + speed) * dt
        self.last = (stamp_ns, speed)
        model, tau_m = model_reaction_torque(tcv, speed, self.params)
        phasor = tau_m * np.exp(1j * self.params.poles * self.theta)
        row = self.sampler.add(stamp_ns, tcv, reaction_torque, speed, model, phasor)
        if row is None:
            return None
        u, r, w, m, p = row[1]
        return FdiSample(row[0], u, r, w, m, p)


def sample_telemetry(stamps_ns, tcv, reaction_torque, wheel_speed=None, period: float = 1.0, mode: str = "mean",
                     params: wm.WheelParams = wm.WheelParams()):
    """Whole control-rate series (time first) -> list of FdiSample, through :class:`TelemetrySampler`."""
    sampler = TelemetrySampler(period, mode, params)
    speeds = wheel_speed if wheel_speed is not None else [None] * len(stamps_ns)
    rows = (sampler.add(int(s), u, r, w) for s, u, r, w in zip(stamps_ns, tcv, reaction_torque, speeds))
    return [row for row in rows if row is not None]
