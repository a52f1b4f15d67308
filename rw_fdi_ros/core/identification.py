"""Fault identification: which fault a wheel has and how large (thesis 1.2.1, the step it leaves out).

Once a wheel is alarmed, each fault kind is a one-parameter family of the
nominal Bialke wheel (core/wheel.py) driven by the measured command u and
wheel speed Omega, every term the mean over one FDI period of its
control-rate values (telemetry.TelemetrySampler):

    current_loss  a [-]:   r^ = -a tau_m(u, Omega; 8 V) + tau_f(Omega; 23 C)           (limiter)
    temperature   T [C]:   r^ = -tau_m(u, Omega; 8 V) + tau_v(T) Omega + tau_c tanh(.)  (eq. 2.15)
    bus_voltage   V [V]:   r^ = -tau_m(u, Omega; V)   + tau_f(Omega; 23 C)             (eqs. 2.9-2.14)

A current loss scales the motor torque for a given command; a temperature rise
changes the friction in proportion to speed; a bus drop only clips the current
when the wheel needs the voltage headroom (high speed and command). The
aliased commutation ripple enters as two nuisance regressors, Im p and Re p
(p: the ripple phasor; its gain and phase are unknown):

    r_k = r^_k(theta) + alpha Im p_k + beta Re p_k + e_k

Each family is fitted by least squares on a grid of theta, alpha and beta
eliminated by projection:  RSS_h(theta) = || P_perp (r - r^(theta)) ||^2.

* kind: the family with the lowest RSS, if it explains at least
  ``EXPLAINED`` of what the nominal wheel leaves unexplained,
  1 - RSS_h / RSS_nominal, and beats every other family by a likelihood-ratio
  margin (RSS_other - RSS_h) / s^2 >= ``DECISIVE``; else ``unknown``.
* size: the argmin; interval {theta : RSS_h(theta) - RSS_min <= chi2_1(0.95) s^2 c}
  with s^2 = max(RSS_min / (n - 3), sigma_floor^2) and c = ``CORRELATION``
  for the serial correlation of 1 s samples (bearing noise, ripple beats).
  Where the interval reaches the end of the grid only a bound is observable
  (tau_v is 0 from 215 C on; a bus clipping only part of the time).

Samples count from the wheel's first alarm on (the fault began before it)
and are never forgotten: the few seconds after a fault, while the controller
moves the command, are what tells a current loss from a bus drop; a window of
the last 300 samples forgot them and turned 2.5 % of 40 % current losses
"unknown" by the end of the run. The estimate is refined on every sample.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import wheel as wm

KINDS = ("current_loss", "temperature", "bus_voltage")
UNKNOWN = "unknown"
# Grids of each family's parameter, nominal value first (it is the healthy wheel in all three).
# Fine enough that a grid step changes the torque by less than the noise floor: a coarser grid
# makes the family whose parameter falls between two points look worse than it is.
CURRENT_LIMITER_GRID = np.round(np.arange(1.0, -1e-9, -0.001), 6)           # share of motor current
TEMPERATURE_GRID = np.round(np.arange(23.0, 215.0 + 1e-9, 0.25), 6)          # [C]; tau_v = 0 from 215 C
BUS_VOLTAGE_GRID = np.round(np.arange(8.0, 1.5 - 1e-9, -0.01), 6)           # [V]
UNITS = {"current_loss": "", "temperature": "C", "bus_voltage": "V"}
EXPLAINED = 0.9        # share of the nominal misfit a family must explain to be named
DECISIVE = 25.0        # likelihood-ratio margin over every other family (in s^2)
CHI2_95 = 3.841        # chi2 with 1 degree of freedom, 95 %
CORRELATION = 10.0     # interval widening for serially correlated 1 s samples
# [N m] per FDI sample, the smallest misfit taken for real: the bearing torque noise the models
# leave out (1.5e-5, eq. 2.16) plus half a grid step, up to 4e-5 N m where the bus family is steep.
SIGMA_FLOOR = 5e-5
MIN_SAMPLES = 5


def bus_motor_torque(tcv, wheel_speed, params: wm.WheelParams = wm.WheelParams(), grid=BUS_VOLTAGE_GRID):
    """Motor torque k_t I_m(u, Omega; V) of a healthy wheel at every bus voltage of ``grid``: (..., len(grid))."""
    u = np.asarray(tcv, float)[..., None]
    w = np.asarray(wheel_speed, float)[..., None]
    return params.torque_constant * wm.motor_current(u, w, grid, 1.0, params)


def family_predictions(motor_torque, friction_torque, wheel_speed, bus_torque):
    """Predicted reaction torque of every grid point of every family, (sum of grid sizes, n), families
    in KINDS order, for n FDI samples of one wheel.

    ``motor_torque``, ``friction_torque``, ``wheel_speed``: (n,) period means of the nominal
    wheel's tau_m and tau_f and of Omega; ``bus_torque``: (n, len(BUS_VOLTAGE_GRID)).
    """
    tm, tf, w = (np.atleast_1d(np.asarray(x, float)) for x in (motor_torque, friction_torque, wheel_speed))
    tv = _VISCOUS_GRID   # eq. 2.15 is the same law for every wheel of the type: once, not per sample
    coulomb = tf - _VISCOUS_NOMINAL * w
    return np.concatenate([-CURRENT_LIMITER_GRID[:, None] * tm[None] + tf[None],
                           -tm[None] + tv[:, None] * w[None] + coulomb[None],
                           -np.atleast_2d(np.asarray(bus_torque, float)).T + tf[None]])


_VISCOUS_GRID = wm.viscous_coefficient(TEMPERATURE_GRID)
_VISCOUS_NOMINAL = float(wm.viscous_coefficient(wm.NOMINAL.temperature))
GRIDS = {"current_loss": CURRENT_LIMITER_GRID, "temperature": TEMPERATURE_GRID, "bus_voltage": BUS_VOLTAGE_GRID}
_SLICES = dict(zip(KINDS, np.split(np.arange(sum(map(len, GRIDS.values()))),
                                   np.cumsum([len(GRIDS[k]) for k in KINDS])[:-1])))


class ProfileSums:
    """Running sums that give RSS(theta) of every grid point with the ripple terms projected out:

        RSS = sum e^2 - c^T G^-1 c,  e = r - r^(theta),  c = sum e x,  G = sum x x^T,  x = (Im p, Re p)

    A sample costs O(grid) and the memory does not grow with the samples.
    """

    def __init__(self):
        size = sum(map(len, GRIDS.values()))
        self.sq = np.zeros(size)
        self.cross = np.zeros((size, 2))
        self.gram = np.zeros((2, 2))
        self.n = 0

    def add(self, row):
        """``row``: (reaction torque, motor torque, friction torque, wheel speed, bus torques, phasor)."""
        r, tm, tf, w, bus, p = row
        e = r - family_predictions(tm, tf, w, bus[None, :])[:, 0]
        x = np.array([np.imag(p), np.real(p)])
        self.sq += e * e
        self.cross += e[:, None] * x[None, :]
        self.gram += np.outer(x, x)
        self.n += 1

    def rss(self) -> np.ndarray:
        if self.n <= 2 or not np.all(np.isfinite(self.gram)) or np.linalg.cond(self.gram) > 1e12:
            return np.maximum(self.sq, 0.0)
        solved = np.linalg.solve(self.gram, self.cross.T)          # (2, size)
        return np.maximum(self.sq - np.einsum("ij,ji->i", self.cross, solved), 0.0)


@dataclass
class Identification:
    """What the identifier says about one wheel at one FDI sample."""

    kind: str                    # one of KINDS or 'unknown'
    size: float = float("nan")   # in the kind's unit (limiter share, C, V)
    low: float = float("nan")
    high: float = float("nan")
    samples: int = 0
    explained: float = 0.0       # 1 - RSS_kind / RSS_nominal
    best_guess: str = ""         # the best-fitting family even when the kind is 'unknown'
    rss: dict = field(default_factory=dict)   # kind -> RSS minimum
    healthy: bool = False        # the best fit is the nominal wheel: the data show no fault

    @property
    def bound_only(self) -> str:
        """'upper' / 'lower' when the interval reaches the grid's end (only a bound is observable)."""
        if self.kind == "bus_voltage" and self.low <= BUS_VOLTAGE_GRID[-1]:
            return "upper"
        if self.kind == "temperature" and self.high >= TEMPERATURE_GRID[-1]:
            return "lower"
        if self.kind == "current_loss" and self.low <= CURRENT_LIMITER_GRID[-1]:
            return "upper"
        return ""

    def message(self) -> str:
        """One line a person reads at a glance."""
        if self.kind == UNKNOWN:
            if self.samples < MIN_SAMPLES:
                return f"identifying ({self.samples} samples)"
            if self.healthy:
                return "fits a healthy wheel: alarm not confirmed"
            guess = self.best_guess.replace("_", " ")
            return f"unknown fault (closest: {guess}, explains {100 * self.explained:.0f} %)"
        head, digits = {"current_loss": ("current loss, limiter", 2), "temperature": ("temperature", 0),
                        "bus_voltage": ("bus voltage", 2)}[self.kind]
        unit = f" {UNITS[self.kind]}" if UNITS[self.kind] else ""
        def fmt(v):
            return f"{v:.{digits}f}"
        if self.bound_only == "upper":
            return f"{head} <= {fmt(self.high)}{unit}"
        if self.bound_only == "lower":
            return f"{head} >= {fmt(self.low)}{unit}"
        return f"{head} {fmt(self.size)}{unit} [{fmt(self.low)}, {fmt(self.high)}]"

    def values(self) -> dict:
        """The /diagnostics key-values (strings)."""
        def num(v):
            return "nan" if not np.isfinite(v) else f"{v:.6g}"
        return {"fault_kind": self.kind, "fault_size": num(self.size), "fault_size_low": num(self.low),
                "fault_size_high": num(self.high)}


def decide(sums: ProfileSums) -> Identification:
    """Kind and size from the profile sums of one wheel's samples (module docstring)."""
    n = sums.n
    if n < MIN_SAMPLES:
        return Identification(UNKNOWN, samples=n)
    rss_all = sums.rss()
    if not np.all(np.isfinite(rss_all)):
        return Identification(UNKNOWN, samples=n)
    fits = {k: rss_all[_SLICES[k]] for k in KINDS}
    nominal = fits["current_loss"][0]                       # grid[0] of every family is the healthy wheel
    best = min(KINDS, key=lambda k: fits[k].min())
    grid, rss = GRIDS[best], fits[best]
    rss_min = float(rss.min())
    s2 = max(rss_min / max(n - 3, 1), SIGMA_FLOOR ** 2)
    explained = 1.0 - rss_min / nominal if nominal > 0 else 0.0
    margin = min((fits[k].min() - rss_min) / s2 for k in KINDS if k != best)
    inside = np.nonzero(rss - rss_min <= CHI2_95 * s2 * CORRELATION)[0]
    # never narrower than the grid's own resolution: half a step either side
    lo_i, hi_i = inside.min(), inside.max()
    step = abs(grid[1] - grid[0])
    ends = sorted((float(grid[lo_i]), float(grid[hi_i])))
    low = max(ends[0] - step / 2, min(grid[0], grid[-1]))
    high = min(ends[1] + step / 2, max(grid[0], grid[-1]))
    size = float(grid[rss.argmin()])
    out = Identification(best, size, low, high, n, float(explained), best, {k: float(fits[k].min()) for k in KINDS})
    out.healthy = size == grid[0]
    if explained < EXPLAINED or margin < DECISIVE or out.healthy:
        out.kind = UNKNOWN
    return out


def identify(reaction_torque, motor_torque, friction_torque, wheel_speed, bus_torque, ripple_phasor,
             ) -> Identification:
    """Kind and size of one wheel's fault from its n FDI samples since the alarm (whole arrays)."""
    sums = ProfileSums()
    for row in zip(reaction_torque, motor_torque, friction_torque, wheel_speed, bus_torque, ripple_phasor):
        sums.add(row)
    return decide(sums)


class FaultIdentifier:
    """Three wheels, sample by sample: collects a wheel's FDI samples from its first alarm on and
    identifies its fault on every new sample (the isolation node and the offline tools)."""

    def __init__(self, axes=("x", "y", "z")):
        self.axes = tuple(axes)
        self.reset()

    def reset(self):
        """Forget every wheel's samples: a new run starts."""
        self.sums = {a: None for a in self.axes}     # axis -> ProfileSums once alarmed
        self.latest = {a: None for a in self.axes}

    def update(self, sample, alarmed: dict) -> dict:
        """``sample``: a telemetry.FdiSample with the identification terms; ``alarmed``: axis -> bool.
        Returns axis -> Identification (None for a wheel never alarmed)."""
        for i, a in enumerate(self.axes):
            if self.sums[a] is None and alarmed.get(a):
                self.sums[a] = ProfileSums()
            if self.sums[a] is None:
                continue
            self.sums[a].add((sample.reaction_torque[i], sample.motor_torque[i], sample.friction_torque[i],
                              sample.wheel_speed[i], sample.bus_motor_torque[i], sample.ripple_phasor[i]))
            self.latest[a] = decide(self.sums[a])
        return dict(self.latest)
