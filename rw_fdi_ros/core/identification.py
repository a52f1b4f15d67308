"""Fault identification: which fault a wheel has and how large (thesis 1.2.1, the step it leaves out).

Once a wheel is alarmed, each fault kind is a one-parameter family of the nominal Bialke wheel
(core/wheel.py) driven by the measured command u and wheel speed Omega, every term the mean over one FDI
period of its control-rate values (telemetry.TelemetrySampler):

    current_loss  a [-]:   r^ = -a tau_m(u, Omega; 8 V) + tau_f(Omega; 23 C)           (limiter)
    temperature   T [C]:   r^ = -tau_m(u, Omega; 8 V) + tau_v(T) Omega + tau_c tanh(.)  (eq. 2.15)
    bus_voltage   V [V]:   r^ = -tau_m(u, Omega; V)   + tau_f(Omega; 23 C)             (eqs. 2.9-2.14)

The aliased commutation ripple enters as two nuisance regressors (p: the ripple phasor):

    r_k = r^_k(theta) + alpha Im p_k + beta Re p_k + e_k,   RSS_h(theta) = || P_perp (r - r^(theta)) ||^2

over a grid of theta per family, alpha and beta eliminated by projection, and over a grid of ramps
(RAMP_SHARE, RAMP_LENGTH: theta moving linearly from the healthy value; the step is one of them).

* kind: the family with the lowest RSS, if it explains at least ``EXPLAINED`` of what the nominal wheel
  leaves unexplained and beats every other family by (RSS_other - RSS_h) / s^2 >= ``DECISIVE``; else
  ``unknown``;
* size: theta at the last sample of the best fit; interval {theta : RSS_h(theta) - RSS_min <=
  chi2_1(0.95) s^2 c}, s^2 = max(RSS_min / (n - 3), sigma_floor^2), c = ``CORRELATION`` for the serial
  correlation of 1 s samples; where it reaches the grid's end only a bound is observable.

On a calibrated unit (core/calibration.py) every family is the unit's (its shares b^ scale k_t, G_d, the
viscous and coulomb friction), and what the calibration does not know enters as four more regressors
dr^/db with its posterior N(0, Sigma) as prior: RSS_h(theta) = min || r - r^(theta; b^) - X_r (alpha,
beta) - X_u(theta) db ||^2 + c s^2 db' Sigma^-1 db.

Samples count from the fault's onset on (FaultIdentifier finds it in the samples kept before the alarm)
and are never forgotten. A wheel given up (its driver off) goes on through its spin-down, which shows only
a temperature; its ripple is then one regressor of the phase its healthy samples before the onset give,
and under MIN_DRIVEN driven samples a current loss and a bus drop are named together (``between``).
The derivation, the choices and their measurements: docs/fdi.md, "Fault
identification".
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np

from . import wheel as wm
from .calibration import PHYSICAL, UnitCalibration, UnitShares, regressors

KINDS = ("current_loss", "temperature", "bus_voltage")
UNKNOWN = "unknown"
# Grids of each family's parameter, nominal value first (it is the healthy wheel in all three).
# Fine enough that a grid step changes the torque by less than the noise floor: a coarser grid
# makes the family whose parameter falls between two points look worse than it is.
CURRENT_LIMITER_GRID = np.round(np.arange(1.0, -1e-9, -0.001), 6)           # share of motor current
TEMPERATURE_GRID = np.round(np.arange(23.0, 215.0 + 1e-9, 0.25), 6)          # [C]; tau_v = 0 from 215 C
BUS_VOLTAGE_GRID = np.round(np.arange(8.0, 1.5 - 1e-9, -0.01), 6)           # [V]
UNITS = {"current_loss": "", "temperature": "C", "bus_voltage": "V"}
# The two families that show only through the motor torque: at one operating point a limiter share and a bus
# voltage that clips to the same current are the same wheel, and a few samples may not tell them apart
DRIVE = ("current_loss", "bus_voltage")
EXPLAINED = 0.9        # share of the nominal misfit a family must explain to be named
DECISIVE = 25.0        # likelihood-ratio margin over every other family (in s^2)
CHI2_95 = 3.841        # chi2 with 1 degree of freedom, 95 %
CORRELATION = 10.0     # interval widening for serially correlated 1 s samples
# [N m] per FDI sample, the smallest misfit taken for real: the bearing torque noise the models
# leave out (1.5e-5, eq. 2.16) plus half a grid step, up to 4e-5 N m where the bus family is steep.
SIGMA_FLOOR = 5e-5
MIN_SAMPLES = 5
# driven samples a current loss needs to be told from a bus drop once its driver is off: one for the family's
# parameter, one to tell them apart (the ripple's amplitude is bounded, KAPPA_MAX, and takes none; 3 with it
# free; chosen on the tuning seeds: docs/fdir.md)
MIN_DRIVEN = 2
# the ripple's amplitude once a wheel's driver is off, in units of its healthy samples' (set_ripple_prior): a
# current loss or a bus drop scales the real ripple down (kappa <= 1); twice, for the scatter of that estimate
KAPPA_MAX = 2.0
ONSET_HEALTHY = 4   # samples before a fault's onset its healthy fit needs (onset_index: a constant, the ripple)
FREE_UNIT_SHARE = 1e-3   # of the floor^2: a ridge only, the unit's shares all but free (noise estimate)


def bus_motor_torque(tcv, wheel_speed, params: wm.WheelParams = wm.WheelParams(), grid=BUS_VOLTAGE_GRID):
    """Motor torque k_t I_m(u, Omega; V) of a healthy wheel at every bus voltage of ``grid``: (..., len(grid)).

    Parameters
    ----------
    tcv : float or array_like
        Torque command voltage u [V], any shape (...), e.g. (N,) for one sample of the set.
    wheel_speed : float or array_like
        Wheel speed Omega [rad/s], broadcasting with ``tcv``.
    params : WheelParams
        The wheel type, scalar fields (one datasheet wheel).
    grid : array_like, shape (G,)
        Bus voltages V [V].

    Returns
    -------
    ndarray, shape (..., G)
        tau_m [N m] at current limiter 1.
    """
    u = np.asarray(tcv, float)[..., None]
    w = np.asarray(wheel_speed, float)[..., None]
    return params.torque_constant * wm.motor_current(u, w, grid, 1.0, params)


def family_predictions(motor_torque, friction_torque, wheel_speed, bus_torque, scales=None, free_motor_torque=None,
                       fraction=None, viscous_scale: float = 1.0):
    """Predicted reaction torque of every grid point of every family, (sum of grid sizes, n), families
    in KINDS order, for n FDI samples of one wheel.

    ``motor_torque``, ``friction_torque``, ``wheel_speed``: (n,) period means of the nominal
    wheel's tau_m and tau_f and of Omega; ``bus_torque``: (n, len(BUS_VOLTAGE_GRID)); ``scales``:
    the unit's (1 + d_kt, 1 + d_Gd, 1 + b_v, 1 + b_c) (None: the datasheet wheel), whose driver gain
    acts on ``free_motor_torque`` (tau_m where the bridge does not clip; default tau_m).

    ``fraction`` (H,), for one sample (n = 1): how far each of H ramps has come towards the grid value,
    theta = theta_0 + phi (theta_grid - theta_0); then (H, sum of grid sizes). The bus family's torque at a
    voltage between two grid points is interpolated (the grid is 0.01 V). ``viscous_scale``: the wheel type's
    viscous friction over eq. 2.15's law (WheelParams.viscous_scale; the thesis' type 1).

    Parameters
    ----------
    motor_torque : float or array_like, shape (n,)
        The nominal wheel's tau_m(u, Omega; 8 V) [N m].
    friction_torque : float or array_like, shape (n,)
        The nominal wheel's tau_f(Omega; 23 C) [N m].
    wheel_speed : float or array_like, shape (n,)
        Omega [rad/s].
    bus_torque : array_like, shape (n, G)
        tau_m at every voltage of BUS_VOLTAGE_GRID [N m] (:func:`bus_motor_torque`).
    scales : sequence of 4 float, optional
        The unit's scales (dimensionless); None for the datasheet wheel.
    free_motor_torque : float or array_like, shape (n,), optional
        tau_m where the bridge does not clip, else 0 [N m]; None: ``motor_torque``.
    fraction : array_like, shape (H,), optional
        phi of each ramp (dimensionless, :func:`ramp_fractions`), with n = 1.

    Returns
    -------
    ndarray, shape (S, n) or (H, S)
        Predicted reaction torque r^ [N m]; S = the sum of the grid sizes (the grids of GRIDS in KINDS order).
    """
    tm, tf, w = (np.atleast_1d(np.asarray(x, float)) for x in (motor_torque, friction_torque, wheel_speed))
    bus = np.atleast_2d(np.asarray(bus_torque, float)).T          # (len(BUS_VOLTAGE_GRID), n)
    if fraction is None:      # grid points down axis 0, samples along axis 1
        limiter, tv = CURRENT_LIMITER_GRID[:, None], viscous_scale * _VISCOUS_GRID[:, None]
    else:                     # ramps down axis 0, grid points along axis 1, the one sample along axis 2
        phi = np.asarray(fraction, float)[:, None]
        limiter = (1.0 + phi * (CURRENT_LIMITER_GRID - 1.0))[..., None]
        tv = viscous_scale * wm.viscous_coefficient(TEMPERATURE_GRID[0] + phi * (TEMPERATURE_GRID
                                                                                 - TEMPERATURE_GRID[0]))[..., None]
        volts = BUS_VOLTAGE_GRID[0] + phi * (BUS_VOLTAGE_GRID - BUS_VOLTAGE_GRID[0])
        bus = np.interp(volts, BUS_VOLTAGE_GRID[::-1], bus[::-1, 0])[..., None]
    viscous = viscous_scale * _VISCOUS_NOMINAL * w
    coulomb = tf - viscous
    if scales is None:
        out = np.concatenate([-limiter * tm + tf, -tm + tv * w + coulomb, -bus + tf], axis=-2)
    else:
        kt, gd, sv, sc = (float(x) for x in scales)
        free = _free(tm, free_motor_torque)
        motor = kt * (tm + (gd - 1.0) * free)          # the unit's k_t clip((1 + d_Gd) G_d u, I_max), first order
        friction = sv * viscous + sc * coulomb
        out = np.concatenate([-limiter * motor + friction, -motor + sv * tv * w + sc * coulomb,
                              -kt * (bus + (gd - 1.0) * _bus_free(tm, free, bus)) + friction], axis=-2)
    return out if fraction is None else out[..., 0]


def unit_sensitivities(motor_torque, friction_torque, wheel_speed, bus_torque, free_motor_torque=None,
                       viscous_scale: float = 1.0):
    """dr^/d(d_kt, d_Gd, b_v, b_c) of every grid point, (sum of grid sizes, n, 4): the directions in which
    what the calibration does not know of the unit moves each family's prediction (to first order).

    Parameters
    ----------
    motor_torque : float or array_like, shape (n,)
        The nominal wheel's tau_m [N m].
    friction_torque : float or array_like, shape (n,)
        The nominal wheel's tau_f(Omega; 23 C) [N m].
    wheel_speed : float or array_like, shape (n,)
        Omega [rad/s].
    bus_torque : array_like, shape (n, G)
        tau_m at every voltage of BUS_VOLTAGE_GRID [N m].
    free_motor_torque : float or array_like, shape (n,), optional
        tau_m where the bridge does not clip, else 0 [N m]; None: ``motor_torque``.
    viscous_scale : float, optional
        The wheel type's viscous friction over eq. 2.15's law.

    Returns
    -------
    ndarray, shape (S, n, 4)
        dr^/db [N m] per unit share, S = the sum of the grid sizes.
    """
    tm, tf, w = (np.atleast_1d(np.asarray(x, float)) for x in (motor_torque, friction_torque, wheel_speed))
    bus = np.atleast_2d(np.asarray(bus_torque, float)).T
    free = _free(tm, free_motor_torque)
    n, temperatures, limiters = len(tm), len(TEMPERATURE_GRID), CURRENT_LIMITER_GRID[:, None]
    viscous = viscous_scale * _VISCOUS_NOMINAL * w
    motor = np.concatenate([-limiters * tm[None], np.broadcast_to(-tm[None], (temperatures, n)), -bus])
    gain = np.concatenate([-limiters * free[None], np.broadcast_to(-free[None], (temperatures, n)),
                           -_bus_free(tm, free, bus)])
    visc = np.concatenate([np.broadcast_to(viscous[None], (len(CURRENT_LIMITER_GRID), n)),
                           viscous_scale * _VISCOUS_GRID[:, None] * w[None],
                           np.broadcast_to(viscous[None], (len(BUS_VOLTAGE_GRID), n))])
    return np.stack([motor, gain, visc, np.broadcast_to((tf - viscous)[None], (_SIZE, n))], axis=-1)


def _free(tm, free_motor_torque):
    return tm if free_motor_torque is None else np.atleast_1d(np.asarray(free_motor_torque, float))


def _bus_free(tm, free, bus):
    """The bus family's unclipped motor torque: the 8 V wheel's where the bus at V clips no more than 8 V
    does (equal torques), else 0."""
    return np.where(np.abs(bus - tm) <= 1e-12 + 1e-9 * np.abs(tm), free, 0.0)


_VISCOUS_GRID = wm.viscous_coefficient(TEMPERATURE_GRID)
_VISCOUS_NOMINAL = float(wm.viscous_coefficient(wm.NOMINAL.temperature))
GRIDS = {"current_loss": CURRENT_LIMITER_GRID, "temperature": TEMPERATURE_GRID, "bus_voltage": BUS_VOLTAGE_GRID}
_SIZE = sum(map(len, GRIDS.values()))
_SLICES = dict(zip(KINDS, np.split(np.arange(sum(map(len, GRIDS.values()))),
                                   np.cumsum([len(GRIDS[k]) for k in KINDS])[:-1])))


# The ways a fault may have grown (steps, and ramps of 50-300 s in service: rw-fdi bench service). A ramp is
# (a, D): the share of its way it had come at the first sample counted (a slow ramp's alarm lags its onset by
# more than the samples kept before an alarm) and the seconds from that sample to its end, so at ``elapsed``
# seconds from the first sample phi = a + (1 - a) min(elapsed / D, 1). The step (phi = 1 throughout) is first.
RAMP_START_SHARES = (0.0, 0.2, 0.4, 0.55, 0.7, 0.8, 0.9, 0.95)
RAMP_SECONDS = (10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 105.0, 120.0, 135.0, 150.0, 165.0,
                180.0, 200.0, 225.0, 250.0, 275.0, 300.0, 350.0, 400.0)
# a slow ramp whose first tenth or so passed unseen before the first sample counted (a wheel held at one operating
# point from its alarm on): between the step's 0 and 0.2, on the ramps of a minute and longer only, where a shorter
# one would let a current loss mimic a bus ramp's few driven samples (chosen on the tuning seeds: docs/fdir.md)
SLOW_START_SHARES = (0.03, 0.06, 0.1, 0.15)
SLOW_SECONDS = 60.0
_RAMPS = ([(a, d) for a in RAMP_START_SHARES for d in RAMP_SECONDS]
          + [(a, d) for a in SLOW_START_SHARES for d in RAMP_SECONDS if d >= SLOW_SECONDS])
RAMP_SHARE = np.array([1.0] + [a for a, _ in _RAMPS])
RAMP_LENGTH = np.array([0.0] + [d for _, d in _RAMPS])


def _ramp_neighbours() -> list:
    """Ramp index -> the ramps next to it (itself included): at its length and the lengths either side, the
    ramps of its share and of the shares either side of it there; the step (index 0) has none."""
    lengths = sorted(set(RAMP_LENGTH[1:]))
    out = [np.array([], int)]
    for a, d in zip(RAMP_SHARE[1:], RAMP_LENGTH[1:]):
        i, near = lengths.index(d), []
        for length in lengths[max(i - 1, 0):i + 2]:
            row = np.flatnonzero(RAMP_LENGTH == length)
            row = row[np.argsort(RAMP_SHARE[row])]
            k = int(np.searchsorted(RAMP_SHARE[row], a))
            near += list(row[max(k - 1, 0):k + 1 + int(k < row.size and RAMP_SHARE[row][k] == a)])
        out.append(np.unique(near))
    return out


_NEIGHBOURS = _ramp_neighbours()
RAMP_NOTED_S = 30.0   # [s] a shorter ramp is reported as the step it all but is


# ProfileSums keeps its ramps longest first, so the ramps still growing are always the first ones (a slice,
# updated in place; an index gather/scatter over them cost 7 ms a sample)
_LONGEST_FIRST = np.argsort(-RAMP_LENGTH, kind="stable")
_LENGTH_LONGEST_FIRST = RAMP_LENGTH[_LONGEST_FIRST]
_RAMP_ORDER = np.argsort(_LONGEST_FIRST)     # stored position -> RAMP_SHARE/RAMP_LENGTH order


def ramp_fractions(elapsed: float) -> np.ndarray:
    """phi of every ramp (RAMP_SHARE, RAMP_LENGTH) at ``elapsed`` seconds from the first sample counted.

    Parameters
    ----------
    elapsed : float
        Time from the first sample counted [s].

    Returns
    -------
    ndarray, shape (H,)
        phi in [0, 1] per ramp (1 for the step), H = len(RAMP_LENGTH).
    """
    grown = np.clip(float(elapsed) / np.maximum(RAMP_LENGTH, 1e-9), 0.0, 1.0)
    return np.where(RAMP_LENGTH > 0.0, RAMP_SHARE + (1.0 - RAMP_SHARE) * grown, 1.0)


class ProfileSums:
    """Running sums that give RSS(theta) of every grid point of every ramp with the ripple (and the unit's
    uncertainty) projected out:

        RSS = sum e^2 - c^T (G + Pi)^-1 c,  e = r - r^(theta(t)),  c = sum e x,  G = sum x x^T,
        x = (Im p, Re p[, dr^/db(theta)]),  Pi = the unit's prior information (0 on the ripple)

    theta(t) is the grid value throughout for the step and theta_0 + phi(t) (theta - theta_0) for a ramp
    (RAMP_SHARE, RAMP_LENGTH). A sample costs O(grid) once every ramp is over (O(ramps x grid) before) and the
    memory does not grow with the samples; the unit's directions are taken at the grid value for a ramp too (a
    difference of second order). ``unit``: what is known of the wheel's unit (calibration.UnitShares); None for
    the datasheet wheel; ``viscous_scale``: the wheel type's (family_predictions); ``floor``: the smallest misfit
    taken for real [N m] (SIGMA_FLOOR of the Type A, wheel.torque_scale of another type).
    """

    def __init__(self, unit: UnitShares | None = None, viscous_scale: float = 1.0, floor: float = SIGMA_FLOOR):
        self.unit = unit
        self.viscous_scale = float(viscous_scale)
        self.floor = float(floor)
        self.scales = None if unit is None else unit.scales()
        width = 2 if unit is None else 6
        self.sq = np.zeros(_SIZE)
        self.cross = np.zeros((_SIZE, width))
        # the ripple's Gram is the same for every grid point; the unit's directions are not
        self.gram = np.zeros((2, 2)) if unit is None else np.zeros((_SIZE, width, width))
        # each ramp's sums less the step's, longest ramp first: nothing once the ramp is over
        self.ramp_sq = np.zeros((len(RAMP_LENGTH), _SIZE))
        self.ramp_cross = np.zeros((len(RAMP_LENGTH), _SIZE, width))
        self.n = 0
        self.start = None     # [s] the first sample's time
        self.elapsed = 0.0    # [s] from the first sample to the last
        self.driven = 0.0     # [s] from the first sample to the last with motor torque (its driver on)
        self.n_driven = 0     # samples with motor torque
        self.ripple_prior = None    # w: the ripple's phase, of the healthy samples before the onset
        self.prior_on = False       # the ripple one regressor of that phase: the driver off at the last sample

    def set_ripple_prior(self, errors, ripple_phasors):
        """The ripple's phase as the wheel's healthy samples before the onset give it (their model ``errors`` and
        ``ripple_phasors``): w = (alpha_0, beta_0), their least-squares coefficients beside a constant (what
        the model leaves of a unit not calibrated, which would turn the phase). While ``prior_on`` (a wheel
        given up: the samples left carry no ripple, and the few driven ones cannot hold its two coefficients) the
        ripple is one regressor of that phase, its amplitude kappa free,

            r_k = r^_k(theta) + kappa w^T (Im p_k, Re p_k) + e_k,

        as p is the nominal motor torque's phasor and a current loss or a bus drop scales the real one (kappa in
        [0, 1]; the healthy wheel 1): it is held within [0, KAPPA_MAX] (a prior of that scale on a unit), else a
        few driven samples' misfit went into an amplitude hundreds of times the wheel's. Fewer than four
        samples, or a ripple they cannot resolve, set nothing."""
        e = np.asarray(errors, float)
        p = np.asarray(ripple_phasors, complex)
        x = np.column_stack([p.imag, p.real, np.ones(e.size)])
        gram = x.T @ x
        if e.size < 4 or not np.all(np.isfinite(e)) or np.linalg.cond(gram) > 1e12:
            return
        self.ripple_prior = np.linalg.solve(gram, x.T @ e)[:2]

    def _ripple_columns(self, cross, gram):
        """(cross, gram, ripple columns): the ripple's two regressors, or its one of the healthy samples' phase
        while ``prior_on`` (set_ripple_prior)."""
        if not (self.prior_on and self.ripple_prior is not None):
            return cross, gram, 2
        width = gram.shape[-1]
        shape = np.zeros((width - 1, width))       # (Im p, Re p, rest) -> (w^T (Im p, Re p), rest)
        shape[0, :2] = self.ripple_prior
        shape[1:, 2:] = np.eye(width - 2)
        return cross @ shape.T, shape @ gram @ shape.T, 1

    def add(self, row, time: float | None = None):
        """``row``: (reaction torque, motor torque, friction torque, wheel speed, bus torques, phasor[, free
        motor torque]); ``time`` [s]: the sample's (default: its index, 1 s samples)."""
        r, tm, tf, w, bus, p, *rest = row
        free = rest[0] if rest else None
        time = float(self.n if time is None else time)
        self.start = time if self.start is None else self.start
        self.elapsed = time - self.start
        if tm != 0.0:
            self.driven = self.elapsed
            self.n_driven += 1
        self.prior_on = tm == 0.0    # its driver off (set_ripple_prior)
        e = r - family_predictions(tm, tf, w, bus[None, :], self.scales, free, viscous_scale=self.viscous_scale)[:, 0]
        ripple = np.array([np.imag(p), np.real(p)])
        if self.unit is None:
            x = ripple[None, :]
            self.gram += np.outer(ripple, ripple)
        else:
            x = np.empty((_SIZE, 6))
            x[:, :2] = ripple
            x[:, 2:] = unit_sensitivities(tm, tf, w, bus[None, :], free, self.viscous_scale)[:, 0]
            self.gram += x[:, :, None] * x[:, None, :]
        self.cross += e[:, None] * x
        self.sq += e * e
        growing = int(np.count_nonzero(_LENGTH_LONGEST_FIRST > self.elapsed))   # phi < 1
        if growing:
            phi = ramp_fractions(self.elapsed)[_LONGEST_FIRST[:growing]]
            e_ramp = r - family_predictions(tm, tf, w, bus[None, :], self.scales, free, fraction=phi,
                                            viscous_scale=self.viscous_scale)
            self.ramp_sq[:growing] += e_ramp * e_ramp - e * e
            self.ramp_cross[:growing] += (e_ramp - e)[:, :, None] * x[None]
        self.n += 1

    def _ripple_usable(self, gram) -> bool:
        return (self.n > 2 and bool(np.all(np.isfinite(gram))) and np.abs(gram).max() > 0.0
                and np.linalg.cond(gram) <= 1e12)

    def rss(self, noise_variance: float | None = None) -> np.ndarray:
        """RSS of every ramp and grid point, (ramps, grid), the ripple projected out; with ``noise_variance``
        (c s^2) and a unit, the unit's uncertainty too (penalised by its prior), else the unit taken at its
        mean."""
        sq = self.sq[None] + self.ramp_sq[_RAMP_ORDER]
        cross = self.cross[None] + self.ramp_cross[_RAMP_ORDER]          # (ramps, grid, width)
        cross, gram, nr = self._ripple_columns(cross, self.gram)
        ripple_gram = gram if self.unit is None else gram[0, :nr, :nr]
        ripple = self._ripple_usable(ripple_gram)
        if noise_variance is None or self.unit is None:
            if not ripple:
                return np.maximum(sq, 0.0)
            c = cross[..., :nr]
            if nr == 1:   # its driver off: kappa within [0, KAPPA_MAX], not free (set_ripple_prior)
                g = float(ripple_gram.reshape(-1)[0])
                kappa = np.clip(c[..., 0] / g, 0.0, KAPPA_MAX)
                return np.maximum(sq - 2.0 * kappa * c[..., 0] + kappa * kappa * g, 0.0)
            return np.maximum(sq - np.einsum("hij,hij->hi", c @ np.linalg.inv(ripple_gram), c), 0.0)
        width = gram.shape[-1]
        keep = slice(0, width) if ripple else slice(nr, width)
        penalty = np.zeros((width, width))
        penalty[nr:, nr:] = noise_variance * np.linalg.inv(self.unit.covariance + 1e-12 * np.eye(4))
        if nr == 1:   # its driver off: kappa held to its scale by a prior N(0, KAPPA_MAX^2)
            penalty[0, 0] = noise_variance / KAPPA_MAX**2
        # one (k, k) inverse per grid point serves all its ramps: c^T (G + Pi)^-1 c as batched products,
        # five times faster than a solve per ramp
        inverse = np.linalg.inv((gram + penalty)[:, keep, keep])        # (grid, k, k)
        c = np.moveaxis(cross[..., keep], 0, 1)                          # (grid, ramps, k)
        return np.maximum(sq - np.einsum("irk,irk->ri", c @ inverse, c), 0.0)

    def seen(self, kind: str) -> float:
        """[s] from the first sample to the last that shows ``kind``'s parameter: a current loss or a bus drop
        shows only through the motor torque, so not once the wheel's driver is off (every later sample is the
        same at every grid point, and a ramp's size there would be an extrapolation)."""
        return self.elapsed if kind == "temperature" else self.driven

    def sizes_now(self, kind: str) -> np.ndarray:
        """theta at the last sample that shows it (:meth:`seen`) of every ramp and grid point of ``kind``'s
        family, (ramps, grid)."""
        grid = GRIDS[kind]
        phi = ramp_fractions(self.seen(kind))[:, None]
        return grid[0] + phi * (grid[None] - grid[0])


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
    unit: str = "datasheet"      # the wheel the families scale: 'datasheet', 'calibrated' or 'type' (still learning)
    unit_limited: bool = False   # what is not known of the unit at least doubles the interval
    unpowered: bool = False      # its driver is off (given up by FDIR): its spin-down counts, not its rest
    ramp_s: float = 0.0          # [s] how long the fault took to grow to its size (0: a step)
    growing: bool = False        # it was still growing at the last sample: the size is the size then
    at_s: float = float("nan")   # [s] the time of the last sample (the stamp the size is the fault's at)
    between: tuple = ()          # 'unknown', yet one of these (DRIVE: the samples do not tell the two apart)

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
        why = ""
        if self.unit_limited:
            why = (" (wide: the unit is not calibrated yet)" if self.unit == "type"
                   else " (wide: what the calibration does not know of the unit)")
        if self.growing:
            why += " (still growing)"
        elif self.ramp_s >= RAMP_NOTED_S:
            why += f" (grew over ~{self.ramp_s:.0f} s)"
        if self.unpowered:
            why += " (its driver off: its spin-down counted, its rest not)"
        if self.kind == UNKNOWN:
            if self.samples < MIN_SAMPLES:
                return f"identifying ({self.samples} samples)"
            if self.healthy:
                return "fits a healthy wheel: alarm not confirmed"
            guess = self.best_guess.replace("_", " ")
            if self.between:
                return (f"current loss or bus drop, its driven samples do not tell which (closest: {guess}, explains "
                        f"{100 * self.explained:.0f} %){why}")
            return f"unknown fault (closest: {guess}, explains {100 * self.explained:.0f} %){why}"
        head, digits = {"current_loss": ("current loss, limiter", 2), "temperature": ("temperature", 0),
                        "bus_voltage": ("bus voltage", 2)}[self.kind]
        unit = f" {UNITS[self.kind]}" if UNITS[self.kind] else ""
        def fmt(v):
            return f"{v:.{digits}f}"
        if self.bound_only == "upper":
            return f"{head} <= {fmt(self.high)}{unit}{why}"
        if self.bound_only == "lower":
            return f"{head} >= {fmt(self.low)}{unit}{why}"
        return f"{head} {fmt(self.size)}{unit} [{fmt(self.low)}, {fmt(self.high)}]{why}"

    def values(self) -> dict:
        """The /diagnostics key-values (strings)."""
        def num(v):
            return "nan" if not np.isfinite(v) else f"{v:.6g}"
        return {"fault_kind": self.kind, "fault_size": num(self.size), "fault_size_low": num(self.low),
                "fault_size_high": num(self.high), "fault_unit": self.unit,
                "fault_size_unit_limited": "true" if self.unit_limited else "false",
                "fault_growing": "true" if self.growing else "false", "fault_ramp_s": num(self.ramp_s),
                "fault_size_at_s": num(self.at_s), "fault_kind_between": " or ".join(self.between)}


def decide(sums: ProfileSums) -> Identification:
    """Kind and size from the profile sums of one wheel's samples (module docstring); the size is the fault's
    at the last sample (a ramp may still be growing).

    Parameters
    ----------
    sums : ProfileSums
        The wheel's sums since the fault's onset.

    Returns
    -------
    Identification
        Kind, size (in the kind's unit: share, [C] or [V]) and interval; ``unknown`` under MIN_SAMPLES.
    """
    n = sums.n
    if n < MIN_SAMPLES:
        return Identification(UNKNOWN, samples=n)
    known = sums.rss()                  # the unit at its mean (the datasheet wheel without a unit)
    if not np.all(np.isfinite(known)):
        return Identification(UNKNOWN, samples=n)
    floor2 = sums.floor ** 2
    s2 = max(float(known.min()) / max(n - 3, 1), floor2)
    rss_all = known
    if sums.unit is not None:
        # the noise from the fit where the unit is free (a unit taken at a wrong mean is no noise),
        # then every family with the unit held to what the calibration knows
        s2 = max(float(sums.rss(FREE_UNIT_SHARE * floor2).min()) / max(n - 7, 1), floor2)
        rss_all = sums.rss(CORRELATION * s2)
    if not np.all(np.isfinite(rss_all)):
        return Identification(UNKNOWN, samples=n)
    fits = {k: rss_all[:, _SLICES[k]] for k in KINDS}
    nominal = fits["current_loss"][0, 0]          # grid[0] of every family is the healthy wheel, whatever the ramp
    best = min(KINDS, key=lambda k: fits[k].min())
    rss = fits[best]
    ramp, point = np.unravel_index(int(rss.argmin()), rss.shape)
    rss_min = float(rss[ramp, point])
    explained = 1.0 - rss_min / nominal if nominal > 0 else 0.0
    margin = min((fits[k].min() - rss_min) / s2 for k in KINDS if k != best)
    now, step = sums.sizes_now(best), abs(GRIDS[best][1] - GRIDS[best][0])
    low, high = _interval(now, rss, s2, step)
    out = Identification(best, float(now[ramp, point]), low, high, n, float(explained), best,
                         {k: float(fits[k].min()) for k in KINDS})
    out.healthy = point == 0
    out.at_s = float(sums.start + sums.seen(best))
    phi = ramp_fractions(sums.seen(best))[ramp]
    out.growing = bool(phi < 1.0)
    if RAMP_LENGTH[ramp] > 0.0:
        out.ramp_s = float(RAMP_LENGTH[ramp] / (1.0 - RAMP_SHARE[ramp]))
    if sums.unit is not None:
        out.unit = sums.unit.source
        # the interval were the unit known exactly, both without the ramps' neighbours (they are the same)
        alone = _interval(now, known[:, _SLICES[best]], s2, step, neighbours=False)
        held = _interval(now, rss, s2, step, neighbours=False)
        out.unit_limited = (held[1] - held[0]) > 2.0 * (alone[1] - alone[0])
    # a current loss and a bus drop differ only in how the motor torque varies with the command and speed: under
    # MIN_DRIVEN driven samples (a wheel given up at once) that is no evidence, whatever the spin-down's count
    few_driven = best in DRIVE and sums.n_driven < MIN_DRIVEN
    if explained < EXPLAINED or margin < DECISIVE or out.healthy or few_driven:
        out.kind = UNKNOWN
        # the fault is in the drive, which of its two the samples cannot say: said so, not hidden in 'unknown'
        drive_only = best in DRIVE and all((fits[k].min() - rss_min) / s2 >= DECISIVE for k in KINDS if k not in DRIVE)
        if explained >= EXPLAINED and not out.healthy and drive_only:
            out.between = DRIVE
    return out


def _interval(sizes, rss, s2, step, neighbours: bool = True) -> tuple:
    """{theta : RSS(theta) - RSS_min <= chi2_1(0.95) s^2 c} over every ramp (``sizes``: theta at the last sample
    of each ramp and grid point), widened to the best size of each ramp next to the best one on the ramps'
    grid (the fault's own ramp lies between grid ramps, and a neighbour's size is as near it as the best's),
    never narrower than the grid's own resolution (half a ``step`` either side) nor outside the grid."""
    inside = rss - rss.min() <= CHI2_95 * s2 * CORRELATION
    best = int(rss.min(axis=1).argmin())
    if neighbours:
        for h in _NEIGHBOURS[best]:
            inside[h, rss[h].argmin()] = True
    ends = float(sizes[inside].min()), float(sizes[inside].max())
    bounds = float(sizes.min()), float(sizes.max())
    return max(ends[0] - step / 2, bounds[0]), min(ends[1] + step / 2, bounds[1])


def identify(reaction_torque, motor_torque, friction_torque, wheel_speed, bus_torque, ripple_phasor,
             unit: UnitShares | None = None, free_motor_torque=None, times=None,
             viscous_scale: float = 1.0, floor: float = SIGMA_FLOOR) -> Identification:
    """Kind and size of one wheel's fault from its n FDI samples since the onset (whole arrays; ``times`` [s]
    default: 1 s apart).

    Parameters
    ----------
    reaction_torque : array_like, shape (n,)
        Measured reaction torque r [N m], the FDI period means.
    motor_torque : array_like, shape (n,)
        The nominal wheel's tau_m [N m].
    friction_torque : array_like, shape (n,)
        The nominal wheel's tau_f [N m].
    wheel_speed : array_like, shape (n,)
        Omega [rad/s].
    bus_torque : array_like, shape (n, G)
        tau_m at every voltage of BUS_VOLTAGE_GRID [N m].
    ripple_phasor : array_like of complex, shape (n,)
        The ripple phasor p [N m].
    unit : UnitShares, optional
        What is known of the wheel's unit; None for the datasheet wheel.
    free_motor_torque : array_like, shape (n,), optional
        tau_m where the bridge does not clip, else 0 [N m].
    times : array_like, shape (n,), optional
        Sample times [s].
    viscous_scale : float, optional
        The wheel type's viscous friction over eq. 2.15's law.
    floor : float, optional
        The smallest misfit taken for real [N m] (SIGMA_FLOOR times the type's wheel.torque_scale).

    Returns
    -------
    Identification
        As :func:`decide` gives it.
    """
    sums = ProfileSums(unit, viscous_scale, floor)
    free = [None] * len(reaction_torque) if free_motor_torque is None else free_motor_torque
    times = range(len(reaction_torque)) if times is None else times
    for *row, t in zip(reaction_torque, motor_torque, friction_torque, wheel_speed, bus_torque, ripple_phasor, free,
                       times):
        sums.add(tuple(row), t)
    return decide(sums)


def onset_index(errors, ripple_phasors, floor: float = SIGMA_FLOOR) -> int:
    """Where a fault's effect in the model error ``errors`` begins (the index of its first sample).

    First the single change point of a step in white noise with the aliased commutation ripple and a
    constant (what the model leaves of a unit not yet calibrated) as nuisance (Basseville & Nikiforov,
    Detection of Abrupt Changes, 1993, sec. 2.2):

        e_j = c + alpha Im p_j + beta Re p_j + delta 1[j >= k] + noise,    k^ = argmin_k RSS_k

    then, as a fault's effect is a step only while the spacecraft holds (a large one grows over the
    seconds before its alarm, a ramp over minutes), the change point of a growing effect lies inside
    it: back from k^ while the sample before leaves the healthy fit (c, alpha, beta) of the samples
    before it by more than 3 max(s, sigma_floor) (s: their residual's rms), and forward from there to
    the first sample that leaves the fit of the samples before it. Without the ripple terms the change
    point followed the ripple: near an alias speed it swings a healthy wheel's error by as much as a
    small fault for tens of seconds; without the walk back a wheel given up seconds after its onset
    lost one of its three or four driven samples (docs/fdir.md).

    Parameters
    ----------
    errors : array_like, shape (n,)
        Model error r - r^ of each FDI sample [N m].
    ripple_phasors : array_like of complex, shape (n,)
        The samples' ripple phasors p [N m].
    floor : float, optional
        The smallest misfit taken for real [N m] (SIGMA_FLOOR times the type's wheel.torque_scale).

    Returns
    -------
    int
        Index of the first sample of the fault's effect, 0 <= index < n (0 for n < 2).
    """
    e = np.asarray(errors, float)
    p = np.asarray(ripple_phasors, complex)
    n = e.size
    if n < 2:
        return 0
    healthy = np.column_stack([np.ones(n), p.imag, p.real])
    fewest = min(ONSET_HEALTHY, n - 1)   # samples before the step: the healthy fit needs them
    best, best_rss = fewest, np.inf
    columns = np.column_stack([healthy, np.zeros(n)])
    for k in range(fewest, n):
        columns[:, 3] = np.arange(n) >= k
        fit, *_ = np.linalg.lstsq(columns, e, rcond=None)
        rss = float(np.sum((e - columns @ fit) ** 2))
        if rss < best_rss:
            best, best_rss = k, rss

    def departure(k):
        """|e - the healthy fit of the samples before k| and the level a sample must pass to leave it."""
        fit, *_ = np.linalg.lstsq(healthy[:k], e[:k], rcond=None)
        left = np.abs(e - healthy @ fit)
        return left, 3.0 * max(float(np.sqrt(np.mean(left[:k] ** 2))), floor)

    while best > fewest:
        left, level = departure(best - 1)
        if left[best - 1] <= level:
            break
        best -= 1
    left, level = departure(best)
    away = np.nonzero(left[best:] > level)[0]
    return best + int(away[0]) if away.size else best


class FaultIdentifier:
    """The wheels, sample by sample: identifies an alarmed wheel's fault on every new sample from the
    fault's onset on (the isolation node and the offline tools).

    The alarm comes after the onset (a window mean must cross the band, then the persistence): the
    seconds in between, while the controller moves the command, are what tells a current loss from a
    bus drop that clips to the same current. So the last ``BACKLOG`` samples before an alarm are kept,
    and at the alarm those after the onset the wheel's model error shows (:func:`onset_index`, the
    sample at the change itself left out: its period mean is part healthy) count too. A wheel held at
    one command and speed from its alarm on was answered 'unknown' in 7 % of current losses on varied
    units without them (tuning seeds 82,000,000+).

    With ``calibration_samples`` each wheel's unit is learnt from the first samples of the run as the
    model observer learns it (the same calibration.UnitCalibration on the nominal model's error), and
    a wheel's fault is identified on the unit known at its first alarm."""

    BACKLOG = 60   # FDI samples: the 40-sample window and the persistence the alarm lags by, and a margin
    def __init__(self, wheels=("x", "y", "z"), calibration_samples: int = 0, lazy: bool = False,
                 params: wm.WheelParams = wm.WheelParams()):
        self.wheels = tuple(wheels)
        self.params = params   # the wheel type: its viscous law, its calibration regressors, its rest
        self.floor = SIGMA_FLOOR * wm.torque_scale(params)   # its torques' noise floor
        self.calibration_samples = int(calibration_samples)
        # lazy: decide only when asked (identifications()), for a reader that wants the last answer of a run
        # (the core loop's onboard verdict): the same answers, without the grid fits of every sample between
        self.lazy = bool(lazy)
        self.reset()

    def reset(self):
        """Forget everything of the run, the units learnt included: a new run starts."""
        self.calibrations = ({a: UnitCalibration(self.calibration_samples, params=self.params) for a in self.wheels}
                             if self.calibration_samples else None)
        self.faulted = {a: False for a in self.wheels}   # alarmed once this run: its calibration learns no more
        self.samples = 0
        self.clear()

    def clear(self):
        """Forget every wheel's fault (an operator's reset); the units learnt stay, and a calibration a
        fault interrupted does not learn again (the wheel may still be faulty)."""
        self.sums = {a: None for a in self.wheels}     # wheel -> ProfileSums once alarmed
        self.latest = {a: None for a in self.wheels}
        self.stale = set()   # lazy: wheels whose sums moved since their latest answer
        self.unpowered = set()   # wheels whose driver went off (given up) after their alarm
        # (row, model error, calibration regressors, time) of the samples before an alarm
        self.backlog = {a: deque(maxlen=self.BACKLOG) for a in self.wheels}

    def update(self, sample, alarmed: dict) -> dict:
        """``sample``: a telemetry.FdiSample with the identification terms; ``alarmed``: wheel -> bool.
        Returns wheel -> Identification (None for a wheel never alarmed)."""
        stamp = getattr(sample, "stamp_ns", None)
        time = self.samples if stamp is None else 1e-9 * stamp     # [s] (1 s samples where it has no stamp)
        self.samples += 1
        for i, a in enumerate(self.wheels):
            calibration = None if self.calibrations is None else self.calibrations[a]
            free = None if sample.free_motor_torque is None else sample.free_motor_torque[i]
            row = (sample.reaction_torque[i], sample.motor_torque[i], sample.friction_torque[i],
                   sample.wheel_speed[i], sample.bus_motor_torque[i], sample.ripple_phasor[i], free)
            if self.sums[a] is None:
                model = sample.model_torque
                error = sample.reaction_torque[i] - (model[i] if model is not None else np.nan)
                x = None
                if calibration is not None and np.isfinite(error):
                    x = regressors(sample.motor_torque[i], sample.friction_torque[i], sample.wheel_speed[i],
                                   sample.ripple_phasor[i], free, params=self.params)
                    self.faulted[a] = self.faulted[a] or bool(alarmed.get(a))
                    if not calibration.frozen and not self.faulted[a]:   # learns while its wheel is healthy
                        calibration.update(error, x)
                if not alarmed.get(a):
                    self.backlog[a].append((row, error, x, time))
                    continue
                self.sums[a] = ProfileSums(None if calibration is None else calibration.unit(),
                                           self.params.viscous_scale, self.floor)
                self._add_since_onset(a, list(self.backlog[a]) + [(row, error, x, time)], calibration)
                self.backlog[a].clear()
            tcv = getattr(sample, "tcv", None)
            if tcv is not None and float(tcv[i]) == 0.0:
                # its driver off (given up by FDIR): it spins down on its friction alone, which still shows a
                # temperature; once at rest it shows nothing (every family gives 0), and its fault's size is
                # the one it had when last seen
                self.unpowered.add(a)
                if abs(float(sample.wheel_speed[i])) < 2.0 * self.params.coulomb_smoothing_speed:   # at rest
                    if self.latest[a] is not None and not self.latest[a].unpowered:
                        self.latest[a] = replace(self.latest[a], unpowered=True)
                    continue
            else:
                self.unpowered.discard(a)   # driven (again)
            self.sums[a].add(row, time)
            if self.lazy:
                self.stale.add(a)
            else:
                self.latest[a] = self._decide(a)
        return dict(self.latest)

    def identifications(self) -> dict:
        """wheel -> the Identification of the samples so far (None for a wheel never alarmed); what update
        returns, the lazy identifier's decided now."""
        for a in list(self.stale):
            self._resolve(a)
        return dict(self.latest)

    def _resolve(self, a):
        if a in self.stale:
            self.stale.discard(a)
            self.latest[a] = self._decide(a)

    def _decide(self, a) -> Identification:
        found = decide(self.sums[a])
        return replace(found, unpowered=True) if a in self.unpowered else found

    def _add_since_onset(self, a, past, calibration):
        """Add the kept samples after the onset (the last of ``past`` is the alarm's own, added after)."""
        if any(not np.isfinite(e) for _, e, _, _ in past):   # telemetry without the nominal model: from the alarm
            return
        # each sample's model error on the unit known now (those of the learning window were not
        # corrected when they came; a calibration still learning gives its posterior so far)
        mean = None if calibration is None else calibration.so_far().mean[:PHYSICAL]
        errors = [e if mean is None else e - float(z[:PHYSICAL] @ mean) for _, e, z, _ in past]
        onset = onset_index(errors, [r[5] for r, _, _, _ in past], self.floor)
        self.sums[a].set_ripple_prior(errors[:onset], [r[5] for r, _, _, _ in past[:onset]])
        for earlier, _, _, time in past[onset + 1:-1]:
            self.sums[a].add(earlier, time)
