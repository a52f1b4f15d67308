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
  (residuals.ripple_reach widens it to any gain that changes monotonically in the window)

:class:`TelemetrySampler` feeds on the control-rate signals and returns one
:class:`FdiSample` per FDI period (means over (t - T, t], core/fdi/sampling.py);
wheel_reports.ReportSampler feeds it the wheels' reports put on the control
grid, for the wheel_telemetry node, the core loop and the offline tools alike.
"""
from __future__ import annotations

import base64
import binascii
from dataclasses import dataclass, replace

import numpy as np

from ..physics import wheel as wm
from .sampling import FdiSampler


def model_reaction_torque(tcv, wheel_speed, params: wm.WheelParams = wm.WheelParams()):
    """Reaction torque [N m] of a healthy wheel for command ``tcv`` at speed ``wheel_speed`` (no ripple),
    its motor torque tau_m, and tau_m where the bridge does not clip the current (else 0: there a
    unit's driver gain does not show, calibration.py).

    Parameters
    ----------
    tcv : float or array_like
        Torque command voltage u [V], e.g. (n, N): samples, wheels.
    wheel_speed : float or array_like
        Measured wheel speed Omega [rad/s], broadcasting with ``tcv``.
    params : WheelParams
        The wheel type, at its nominal operating point (its own bus voltage, limiter 1, 23 C).

    Returns
    -------
    reaction : ndarray
        r_model [N m], the broadcast shape of the arguments.
    motor : ndarray
        tau_m [N m], same shape.
    free : ndarray
        tau_m where the bridge does not clip, else 0 [N m], same shape.
    """
    nominal = wm.nominal_point(params)   # Table 2.3 on the wheel type's own bus
    current, clipped = wm.bridge(tcv, wheel_speed, nominal.bus_voltage, params)
    tau_m = params.torque_constant * current
    free = np.where(clipped, 0.0, tau_m)
    return -(tau_m - wm.friction_torque(wheel_speed, nominal.temperature, params)), tau_m, free


class PeriodBusGrid:
    """The bus grid's period mean, tau_m(u_k, Omega_k; V) averaged over the K control samples of one FDI period at
    every V of the wheel type's grid (identification.bus_motor_torque), computed only where it is read: 651 values a
    wheel a sample cost more than the rest of the FDI telemetry together, and fault identification reads them only
    for an alarmed wheel and the samples kept before its alarm. Indexing fixes leading axes (a run of a batch, a
    wheel); ``np.asarray`` computes, summing the K samples in their order as FdiSampler's mean does. (The graph's
    wheel_telemetry node publishes every wheel's, so there it is computed at once.)

    Parameters
    ----------
    tcv, wheel_speed : ndarray, shape (K, ..., N)
        The period's control samples u [V] and Omega [rad/s].
    params : WheelParams
        The wheel type.
    """

    def __init__(self, tcv, wheel_speed, params: wm.WheelParams, index: tuple = ()):
        self.tcv, self.wheel_speed, self.params, self.index = tcv, wheel_speed, params, index

    @property
    def ndim(self) -> int:
        return self.tcv.ndim - len(self.index)   # the K axis gives way to the grid's

    @property
    def shape(self) -> tuple:
        from .identification import bus_voltage_grid
        return self.tcv.shape[1 + len(self.index):] + (len(bus_voltage_grid(self.params.bus_voltage)),)

    def __getitem__(self, key) -> "PeriodBusGrid":
        keys = key if isinstance(key, tuple) else (key,)
        if not all(isinstance(k, (int, np.integer)) for k in keys) or len(keys) > self.ndim - 1:
            raise TypeError(f"a PeriodBusGrid takes integer indices of its leading axes (a run, a wheel), not "
                            f"{key!r}: np.asarray it for the rest")
        return PeriodBusGrid(self.tcv, self.wheel_speed, self.params, self.index + tuple(int(k) for k in keys))

    def __array__(self, dtype=None, copy=None):
        from .identification import bus_motor_torque
        at = (slice(None),) + self.index
        grids = bus_motor_torque(self.tcv[at], self.wheel_speed[at], self.params)
        total = grids[0]
        for g in grids[1:]:
            total = total + g
        out = total / len(grids)
        return out if dtype is None else out.astype(dtype)


@dataclass
class FdiSample:
    """One FDI sample of the wheel set's wheels; every field (N,) and a mean over the FDI period."""

    stamp_ns: int
    tcv: np.ndarray              # [V]
    reaction_torque: np.ndarray  # [N m]
    wheel_speed: np.ndarray | None = None     # [rad/s]
    model_torque: np.ndarray | None = None    # nominal wheel model's reaction torque [N m]
    ripple_phasor: np.ndarray | None = None   # mean of tau_m e^{i N theta} (complex) [N m]
    # the nominal model's terms: calibration (calibration.py) and fault identification (identification/)
    motor_torque: np.ndarray | None = None     # nominal tau_m(u, Omega; 8 V) [N m]
    friction_torque: np.ndarray | None = None  # nominal tau_f(Omega; 23 C) [N m]
    free_motor_torque: np.ndarray | None = None  # nominal tau_m where the bridge does not clip, else 0 [N m]
    # fault identification only, when the sampler is asked for it:
    bus_motor_torque: np.ndarray | None = None  # (N, bus grid) tau_m(u, Omega; V) [N m] (or its PeriodBusGrid)
    # the control sample at the FDI stamp itself (the thesis' instantaneous sampling)
    tcv_instant: np.ndarray | None = None              # [V]
    reaction_torque_instant: np.ndarray | None = None  # [N m]
    # the wheel's housekeeping as last reported at the stamp, NaN where it never was (wheel_reports.ReportSampler):
    # fault identification holds its families to them (identification.held_to_reports)
    bus_voltage: np.ndarray | None = None   # [V]
    temperature: np.ndarray | None = None   # [C]

    def sampled(self, mode: str) -> "FdiSample":
        """This sample as the observers of FDI sampling ``mode`` see it: ``instant`` puts the values at
        the stamp in place of the period means of tcv and reaction torque (core/fdi/sampling.py).

        Parameters
        ----------
        mode : str
            'mean' or 'instant'.

        Returns
        -------
        FdiSample
            The sample.
        """
        if mode == "mean" or self.tcv_instant is None:
            return self
        return replace(self, tcv=self.tcv_instant, reaction_torque=self.reaction_torque_instant)


# What one wheel's FDI telemetry report carries (channel -> FdiSample field); the ripple phasor goes as
# its real and imaginary parts. The report carries the doubles themselves (graph/convert.py: a JointState
# of named channels), not a rounding of them. The identification's bus-voltage grid (651 values per wheel,
# identification.BUS_VOLTAGE_GRID) goes beside it, as a binary table of float64.
REPORT_FIELDS = (("tcv", "tcv"), ("reaction_torque", "reaction_torque"), ("wheel_speed", "wheel_speed"),
                 ("model_reaction_torque", "model_torque"), ("motor_torque", "motor_torque"),
                 ("friction_torque", "friction_torque"), ("free_motor_torque", "free_motor_torque"),
                 ("tcv_instant", "tcv_instant"),
                 ("reaction_torque_instant", "reaction_torque_instant"),
                 ("bus_voltage", "bus_voltage"), ("temperature", "temperature"))


HOUSEKEEPING_FIELDS = ("bus_voltage", "temperature")   # reported by some drivers, from their first report on
IDENTIFICATION_FIELDS = ("bus_motor_torque",)   # what only fault identification reads (costly: 651 per wheel)
# bags recorded before the report was numeric carry the grid in the text report, as base64 of its
# little-endian float64 bytes (read, never written)
BUS_GRID_KEY = "bus_motor_torque_f64le_base64"


def report_columns(sample: FdiSample) -> dict:
    """channel -> (N,) values of the wheel set: the scalar part of ``sample`` the FDI telemetry report carries.

    Parameters
    ----------
    sample : FdiSample
        One FDI sample of the wheel set.

    Returns
    -------
    dict of str to ndarray, shape (N,) each
        REPORT_FIELDS channels (those present in ``sample``), then the ripple phasor's parts
        (``ripple_phasor_re``, ``ripple_phasor_im``).
    """
    out = {key: np.asarray(getattr(sample, name), float) for key, name in REPORT_FIELDS
           if getattr(sample, name) is not None}
    if sample.ripple_phasor is not None:
        out["ripple_phasor_re"] = np.asarray(sample.ripple_phasor.real, float)
        out["ripple_phasor_im"] = np.asarray(sample.ripple_phasor.imag, float)
    return out


def sample_from_report(stamp_ns: int, wheels: list, identification: bool = True,
                       bus_motor_torque=None) -> FdiSample:
    """The :class:`FdiSample` of one report: ``wheels`` holds one channel -> value mapping per wheel, in
    the set's order (the inverse of :func:`report_columns`; values as numbers, or as text in bags recorded
    before the report was numeric); without ``identification`` the terms only fault identification needs
    are left out. Raises ValueError on a malformed report.

    Parameters
    ----------
    stamp_ns : int
        The sample's stamp [ns].
    wheels : list of dict of str to float or str
        One report per wheel.
    identification : bool, optional
        Whether to read the bus-voltage grid too.
    bus_motor_torque : array_like, shape (N, grid), optional
        The bus-voltage grid that went beside the report (else a legacy report's own, if any).

    Returns
    -------
    FdiSample
        Fields (N,) for N wheels; ``bus_motor_torque`` (N, grid) [N m].
    """
    def column(key):
        if not all(key in w for w in wheels):
            return None
        return np.array([float(w[key]) for w in wheels])
    skip = () if identification else IDENTIFICATION_FIELDS
    fields = {name: column(key) for key, name in REPORT_FIELDS if name not in skip}
    if fields["tcv"] is None or fields["reaction_torque"] is None:
        raise ValueError("FDI telemetry without tcv or reaction_torque")
    re, im = column("ripple_phasor_re"), column("ripple_phasor_im")
    if re is not None and im is not None:
        fields["ripple_phasor"] = re + 1j * im
    if identification and bus_motor_torque is not None:
        fields["bus_motor_torque"] = np.asarray(bus_motor_torque, float)
    elif identification and all(BUS_GRID_KEY in w for w in wheels):
        try:
            grids = [base64.b64decode(w[BUS_GRID_KEY], validate=True) for w in wheels]
            fields["bus_motor_torque"] = np.array([np.frombuffer(g, "<f8") for g in grids], float)
        except (ValueError, binascii.Error) as exc:
            raise ValueError(f"{BUS_GRID_KEY}: {exc}") from None
    return FdiSample(int(stamp_ns), **fields)


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
        self.pending = []        # control samples of the FDI period so far
        self.last = None         # (stamp_ns, wheel speed) of the previous sample

    def add(self, stamp_ns: int, tcv, reaction_torque, wheel_speed=None) -> FdiSample | None:
        """One control-rate sample; the FDI sample on an FDI stamp.

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp [ns].
        tcv : array_like
            (N,) torque command voltages u [V].
        reaction_torque : array_like
            (N,) reaction torques r [N m].
        wheel_speed : array_like or None
            (N,) wheel speeds Omega [rad/s]; None: only u and r are sampled.

        Returns
        -------
        FdiSample or None
            The FDI sample on an FDI stamp, else None.
        """
        if wheel_speed is None:
            row = self.sampler.add(stamp_ns, tcv, reaction_torque)
            return None if row is None else FdiSample(row[0], row[1][0], row[1][1])
        speed = np.asarray(wheel_speed, float)
        # the wheel angle advances sample by sample; the model terms wait for the FDI stamp and are
        # computed for the whole period at once
        self.pending.append((stamp_ns, np.asarray(tcv, float), np.asarray(reaction_torque, float), speed,
                             self._advance(stamp_ns, speed)))
        if stamp_ns % self.sampler.period_ns:
            return None
        stamps, u, r, w, theta = zip(*self.pending)
        self.pending = []
        u, w = np.array(u), np.array(w)
        signals = self._signals(u, np.array(r), w, np.array(theta))
        rows = [self._sample(s, [x[k] for x in signals]) for k, s in enumerate(stamps)]
        if self.identification and rows[-1] is not None:
            rows[-1].bus_motor_torque = PeriodBusGrid(u, w, self.params)
        return rows[-1]

    def _advance(self, stamp_ns: int, speed):
        """Wheel angle theta at this sample: trapezoid integral of the measured speed."""
        if self.last is None:
            self.theta = np.zeros_like(speed)
        else:
            dt = (stamp_ns - self.last[0]) * 1e-9
            self.theta = self.theta + 0.5 * (self.last[1] + speed) * dt
            # a gap in a wheel's reports (wheel_reports.py: NaN) restarts its angle: the phase is up to a constant
            self.theta = np.where(np.isfinite(self.theta), self.theta, 0.0)
        self.last = (stamp_ns, speed)
        return self.theta

    def _signals(self, tcv, reaction_torque, speed, theta) -> list:
        """What is averaged over the FDI period, per control sample (any leading shape)."""
        if self.mode != "mean":
            raise ValueError("speed-aware FDI needs fdi_sampling 'mean' (the ripple bound is a mean)")
        model, tau_m, free = model_reaction_torque(tcv, speed, self.params)
        phasor = tau_m * np.exp(1j * self.params.poles * theta)
        return [tcv, reaction_torque, speed, model, phasor, tau_m, model + tau_m, free]

    def _sample(self, stamp_ns: int, signals) -> FdiSample | None:
        row = self.sampler.add(stamp_ns, *signals)
        if row is None:
            return None
        return FdiSample(row[0], *row[1], tcv_instant=np.array(signals[0]),
                         reaction_torque_instant=np.array(signals[1]))
