"""Whether the physics can tell a current loss from a bus drop on a wheel's driven samples.

Both faults act only through the motor current (core/physics/wheel.motor_current): a current loss scales the
bridge current, I = c I_B(u, Omega), and a bus drop caps it, I = min(I_B(u, Omega), I_emf(V_bus, Omega)) in
the motoring quadrant (eqs. 2.9-2.14). At one operating point, u and Omega alike in every sample, a share
and a cap give the same current, and nothing the wheel shows can say which it was; only samples at
several commands or speeds can. A wheel given up (its driver off) shows no current at all from then on,
so what its few driven samples hold is all there is.

This asks the physics, not the identifier: the true fault's noise-free motor torque on the driven
samples against the other family's closest: healthy up to a sample j of its own (any), from there its
parameter free to ramp linearly over the samples left, as a fault may (j may also be any control step of the
sample the true fault first shows in: faults do not begin on a sample's edge, and a latent bus drop shows
where the command rises, as a current loss beginning at that step would),

    D = min_{j, theta_a, theta_b} [ sum_{k<j} (k_t I_other(u_k, Omega_k; healthy) - k_t I_k)^2
          + sum_{k>=j} (k_t I_other(u_k, Omega_k; theta_a + (theta_b - theta_a) s_k) - k_t I_k)^2 ] / sigma^2,
    s_k = (t_k - t_j) / (t_n - t_j),

with sigma the identifier's noise floor for the wheel type (identification.SIGMA_FLOOR times
wheel.torque_scale). The identifier names one of them where
its margin reaches identification.DECISIVE (25); on noisy samples that margin scatters about D, so the two
are told apart where it does so in 95 % of runs, D >= TOLD_APART = (5 + 1.645)^2 = 44. The commutation
ripple is left out: its mean over a 1-s FDI sample at the speeds of service is (B/2) tau_m times at most
2 / (N Omega T), a few 1e-6 N m, which moves sqrt(D) by well under one per sample.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ...physics import wheel as wm
from .decision import DECISIVE
from .families import SIGMA_FLOOR

# where the search starts: every ramp between two values of a coarse grid, then refined by least squares
# (geometric: dense near the healthy value, where a small fault's torque is steep in its parameter)
# (the bus family's for the thesis wheel's 8 V bus, scaled to a wheel type's own by _family)
_GRIDS = {"current_limiter": 1.0 - np.geomspace(1e-4, 1.0, 48), "bus_voltage": 8.0 - np.geomspace(1e-3, 6.5, 48)}
HEALTHY = {"current_limiter": wm.NOMINAL.current_limiter, "bus_voltage": wm.NOMINAL.bus_voltage}   # Table 2.3
# each family's range, the identifier's grids' (identification.CURRENT_LIMITER_GRID, BUS_VOLTAGE_GRID)
_BOUNDS = {"current_limiter": (0.0, 1.0), "bus_voltage": (1.5, HEALTHY["bus_voltage"])}


def _family(kind: str, params: wm.WheelParams):
    """(start grid, (low, high), healthy value) of ``kind``'s family on the wheel type's bus."""
    scale = params.bus_voltage / HEALTHY["bus_voltage"] if kind == "bus_voltage" else 1.0
    low, high = _BOUNDS[kind]
    return _GRIDS[kind] * scale, (low * scale, high * scale), HEALTHY[kind] * scale
# D at which the identifier's margin reaches DECISIVE in 95 % of runs (one-sided normal quantile 1.645)
TOLD_APART = (np.sqrt(DECISIVE) + 1.645) ** 2
REFINED = 8         # the best starts (a beginning and a ramp) refined by least squares
SHOWS = 0.1         # [floors] a control step's torque off the healthy wheel's by more: the fault shows


def _shares(t):
    """s_k = (t_k - t_0) / (t_n - t_0): where a ramp over the samples is at each (0 for one sample)."""
    span = t[-1] - t[0]
    return (t - t[0]) / span if span > 0 else np.zeros_like(t)


def _ramps(table, truth, t) -> tuple:
    """(rss (G, G) of every ramp from grid value a to grid value b over the samples, rounded to the grid in
    between; the best (a, b)) of ``table`` (n, G) torques against ``truth`` (n,)."""
    g = table.shape[1]
    s, rows, ends = _shares(t), np.arange(len(truth)), np.arange(g)
    rss = np.empty((g, g))
    for a in range(g):
        idx = np.rint(a + (ends[:, None] - a) * s[None, :]).astype(int)
        rss[a] = ((table[rows[None, :], idx] - truth[None, :]) ** 2).sum(axis=1)
    return rss, np.unravel_index(int(rss.argmin()), rss.shape)


def drive_current(kind: str, tcv, wheel_speed, value, params: wm.WheelParams = wm.WheelParams()):
    """Motor current of a wheel with a ``kind`` fault of ``value`` at the commands and speeds given.

    Parameters
    ----------
    kind : str
        'current_limiter' (``value``: the limiter share) or 'bus_voltage' (``value``: the bus [V]).
    tcv : float or array_like
        Torque command voltage u [V].
    wheel_speed : float or array_like
        Wheel speed Omega [rad/s], broadcasting with ``tcv`` and ``value``.
    value : float or array_like
        The fault's parameter, in its kind's unit.
    params : WheelParams, optional
        The wheel type.

    Returns
    -------
    ndarray or float
        Motor current I_m [A].
    """
    if kind == "current_limiter":
        return wm.motor_current(tcv, wheel_speed, params.bus_voltage, value, params)
    if kind == "bus_voltage":
        return wm.motor_current(tcv, wheel_speed, value, 1.0, params)
    raise ValueError(f"{kind!r} is not a drive fault (current_limiter, bus_voltage)")


def other_family_misfit(kind: str, tcv, wheel_speed, times, values,
                        params: wm.WheelParams = wm.WheelParams(), period: float | None = None) -> float:
    """D of the module docstring: how far the closest fault of the other drive family stays from a ``kind``
    fault of ``values`` (its parameter at each sample, a ramp included) on samples (``tcv`` [V],
    ``wheel_speed`` [rad/s], ``times`` [s], ascending), in units of the identifier's noise floor squared (the
    wheel type's); inf without samples.

    With ``period`` [s] the samples are the control steps and D is taken on their means over each FDI period
    (the sample stamped k period the mean of the steps after (k - 1) period up to it), what the FDI sees;
    without, each sample is one FDI sample. The other family begins at the first step of any FDI sample, or
    at any step of the sample the fault first shows in: a fault does not begin on a sample's edge, and a
    latent one (a bus drop shows once the wheel needs the voltage) first shows where the command rises,
    inside a sample, as a current loss beginning at that step would.

    Parameters
    ----------
    kind : str
        The true drive fault: 'current_limiter' or 'bus_voltage'.
    tcv : array_like, shape (n,)
        Torque command voltage u of each sample [V].
    wheel_speed : array_like, shape (n,)
        Omega of each sample [rad/s].
    times : array_like, shape (n,)
        The samples' times [s], ascending.
    values : array_like, shape (n,)
        The true fault's parameter at each sample, in its kind's unit.
    params : WheelParams, optional
        The wheel type (its noise floor: SIGMA_FLOOR times wheel.torque_scale).
    period : float, optional
        The FDI period [s] when the samples are control steps; None: each sample is one FDI sample.

    Returns
    -------
    float
        D, in noise floors squared; inf without samples.
    """
    u, w, t, v = (np.asarray(x, float).ravel() for x in (tcv, wheel_speed, times, values))
    if u.size == 0:
        return float("inf")
    kt = params.torque_constant
    sigma = SIGMA_FLOOR * wm.torque_scale(params)   # the identifier's floor for this wheel type
    # where each FDI sample's steps begin in the arrays, and its mean
    first = (np.flatnonzero(np.diff(np.ceil(t / period - 1e-9), prepend=-np.inf)) if period
             else np.arange(u.size))
    count = np.diff(np.append(first, u.size))
    sample_of = np.repeat(np.arange(first.size), count)      # step -> its FDI sample

    def mean(x):
        return np.add.reduceat(x, first, axis=0) / count.reshape((-1,) + (1,) * (x.ndim - 1))
    truth_steps = kt * drive_current(kind, u, w, v, params)
    truth = mean(truth_steps)
    other = "bus_voltage" if kind == "current_limiter" else "current_limiter"
    grid, (low, high), healthy_value = _family(other, params)
    healthy_steps = kt * drive_current(other, u, w, healthy_value, params)
    healthy = mean(healthy_steps)
    before = np.concatenate([[0.0], np.cumsum((healthy - truth) ** 2)])   # the healthy wheel's misfit up to j
    n, sample_t = truth.size, mean(t)

    def misfit(c, x):
        """(FDI-sample torques, healthy before step c, the ramp x = (theta_a, theta_b) from it on - truth) /
        sigma, from c's sample on."""
        j = sample_of[c]
        theta = np.clip(x[0] + (x[1] - x[0]) * _shares(t[c:]), low, high)
        torque = np.add.reduceat(kt * drive_current(other, u[c:], w[c:], theta, params),
                                 np.maximum(first[j:] - c, 0))
        torque[0] += healthy_steps[first[j]:c].sum()
        return (torque / count[j:] - truth[j:]) / sigma

    def cost(c, x):
        return before[sample_of[c]] / sigma**2 + float((misfit(c, x) ** 2).sum())

    starts = {}   # j -> [(misfit, (theta_a, theta_b))]: where a search from sample j begins
    # 1. each sample's own parameter (the one that gives its torque exactly, on a fine grid) and how steep the
    # torque is in it there; a line through them, weighted by the steepness, from every j
    fine = np.linspace(low, high, 1001)
    torques = mean(kt * drive_current(other, u[:, None], w[:, None], fine[None, :], params))      # (n, F)
    at = np.abs(torques - truth[:, None]).argmin(axis=1)
    own = fine[at]
    slope = np.abs(torques[np.arange(n), np.minimum(at + 1, fine.size - 1)]
                   - torques[np.arange(n), np.maximum(at - 1, 0)]) / (2 * (fine[1] - fine[0]))
    for j in range(n):
        sj, weight = _shares(sample_t[j:]), slope[j:] ** 2
        x = np.column_stack([1.0 - sj, sj]) * np.sqrt(weight)[:, None]
        line = np.linalg.lstsq(x, own[j:] * np.sqrt(weight), rcond=None)[0] if weight.sum() > 0 else own[[j, -1]]
        starts[j] = [(cost(first[j], line), tuple(line))]
    # 2. every ramp between two values of a coarse grid (rounded to the grid in between)
    table = mean(kt * drive_current(other, u[:, None], w[:, None], grid[None, :], params))   # (n, G)
    for j in range(n):
        rss, (a, b) = _ramps(table[j:], truth[j:], sample_t[j:])
        starts[j].append(((before[j] + float(rss[a, b])) / sigma**2, (grid[a], grid[b])))
    candidates = [(m, first[j], x) for j, cands in starts.items() for m, x in cands]
    # 3. the other family beginning inside the sample the fault first shows in, from that sample's starts
    shows = np.flatnonzero(np.abs(truth_steps - healthy_steps) > SHOWS * sigma)
    if shows.size:
        j = sample_of[shows[0]]
        candidates += [(cost(c, x), c, x) for c in range(first[j] + 1, first[j] + count[j]) for _, x in starts[j]]
    best = min(m for m, _, _ in candidates)
    # 4. least squares from the best starts, exact
    for _, c, x in sorted(candidates, key=lambda c: c[0])[:REFINED]:
        fit = least_squares(lambda y, c=c: misfit(c, y), np.clip(x, low, high), bounds=(low, high),
                            x_scale=(high - low) / 100)
        best = min(best, cost(c, fit.x))
    return best


def told_apart(misfit: float) -> bool:
    """Whether a drive fault whose other family stays ``misfit`` (D) away is told from it: with noise at the
    floor the identifier's margin is about (sqrt(D) + z)^2, z standard normal, so it reaches DECISIVE in 95 %
    of runs where D >= TOLD_APART.

    Parameters
    ----------
    misfit : float
        D of :func:`other_family_misfit`, in noise floors squared.

    Returns
    -------
    bool
        D >= TOLD_APART.
    """
    return bool(misfit >= TOLD_APART)
