"""The decision: from a wheel's profile sums, which family (if any) its fault is and how large, with an interval
(the package's docstring has the rule).
"""
from __future__ import annotations

import numpy as np

from ..calibration import UnitShares
from .families import DRIVE, GRIDS, KINDS, REPORTED_TOLERANCE, SIGMA_FLOOR, UNKNOWN
from .ramps import RAMP_LENGTH, RAMP_SHARE, _NEIGHBOURS, ramp_fractions
from .result import MIN_SAMPLES, Identification
from .sums import ProfileSums, finish, rss_pieces


EXPLAINED = 0.9        # share of the nominal misfit a family must explain to be named
DECISIVE = 25.0        # likelihood-ratio margin over every other family (in s^2)
CHI2_95 = 3.841        # chi2 with 1 degree of freedom, 95 %
CORRELATION = 10.0     # interval widening for serially correlated 1 s samples
# driven samples a current loss needs to be told from a bus drop once its driver is off: one for the family's
# parameter, one to tell them apart (the ripple's amplitude is bounded, KAPPA_MAX, and takes none; 3 with it
# free; chosen on the tuning seeds: docs/fdir.md)
MIN_DRIVEN = 2
FREE_UNIT_SHARE = 1e-3   # of the floor^2: a ridge only, the unit's shares all but free (noise estimate)


def _noise(sums: ProfileSums, known):
    """(s^2, s^2 across, every family's RSS) of the sums: the noise variance of the best fit, at least the
    driven floor's (s^2) or at least the samples' mean floor (ProfileSums.floor_variance: what tells a temperature
    from a drive fault, a spin-down's samples included), and the RSS ``known`` with the unit at its mean, or with a
    calibrated unit held to what the calibration knows, its prior weighed by s^2 across (a generator of
    ProfileSums.rss_steps' pieces)."""
    floor2 = sums.floor ** 2
    if sums.unit is None:
        noise = _least(known) / max(sums.n - 3, 1)
        return max(noise, floor2), max(noise, sums.floor_variance()), known
    # the noise from the fit where the unit is free (a unit taken at a wrong mean is no noise)
    free = yield from sums.rss_steps(FREE_UNIT_SHARE * floor2)
    noise = _least(free) / max(sums.n - 7, 1)
    s2, across = max(noise, floor2), max(noise, sums.floor_variance())
    # the prior on the unit weighs as much as one sample's noise does on average: a spin-down's samples are 1e4x
    # finer than driven ones, and held to the driven floor the calibration's mean outweighed them (a viscous share
    # 2 sigma off named a temperature ramp 'unknown', explaining 36 %); all driven, it is the driven floor exactly
    prior = s2 if sums.n_driven == sums.n else across
    return s2, across, (yield from sums.rss_steps(CORRELATION * prior))


def _least(fits: dict) -> float:
    """The least RSS of every family's."""
    return min(float(f.min()) for f in fits.values())


def _finite(fits: dict):
    """Whether every RSS is finite, a family a piece (a generator: yields after each, returns the answer)."""
    for f in fits.values():
        if not np.isfinite(f.sum()):   # RSS are >= 0: a sum is finite where every term is (one pass, no temporary)
            return False
        yield
    return True


def held_to_reports(fits: dict, sums: ProfileSums, reported: dict, noise_variance: float) -> dict:
    """The families' RSS with what the wheel reports of itself: a family whose parameter is reported (its bus
    voltage, its temperature) keeps only the sizes within REPORTED_TOLERANCE of the report (inf elsewhere), so a
    report at the nominal value (or a bus above it) rules its family out; a bus reported below nominal that
    explains the torque within DECISIVE s^2 of the best family rules the current limiter out, as one fault is
    the cause (a limiter share and a bus drop that clip to the same current are the same wheel at one operating
    point, and only the report tells them apart); one that does not leaves the limiter in (a bus a little low
    beside a current loss).

    Parameters
    ----------
    fits : dict of str to ndarray, shape (H, G)
        Kind -> RSS per ramp and grid point.
    sums : ProfileSums
        The wheel's sums (the sizes now of every ramp).
    reported : dict of str to float
        Kind -> the reported value in the family's unit (the bus on the 8-V grid).
    noise_variance : float
        s^2 [N^2 m^2], the decision's.

    Returns
    -------
    dict of str to ndarray
        The RSS held to the reports.
    """
    out = dict(fits)
    best = min(float(f.min()) for f in fits.values())
    for kind, value in reported.items():
        if kind == "bus_voltage":
            value = min(value, GRIDS[kind][0])   # a bus above its nominal clips no more current than the nominal
        near = np.abs(sums.sizes_now(kind) - value) <= REPORTED_TOLERANCE[kind]
        out[kind] = np.where(near, fits[kind], np.inf)
        # a bus reported low that explains the torque as well as any family is the cause: not a current loss too
        dropped = kind == "bus_voltage" and GRIDS[kind][0] - value > REPORTED_TOLERANCE[kind]
        if dropped and out[kind].min() - best <= DECISIVE * noise_variance:
            out["current_limiter"] = np.full_like(fits["current_limiter"], np.inf)
    return out


def decide(sums: ProfileSums, reported: dict | None = None) -> Identification:
    """Kind and size from the profile sums of one wheel's samples (the package's docstring); the size is the fault's
    at the last sample (a ramp may still be growing).

    Parameters
    ----------
    sums : ProfileSums
        The wheel's sums since the fault's onset.
    reported : dict of str to float, optional
        What the wheel reports of a family's parameter (:func:`held_to_reports`).

    Returns
    -------
    Identification
        Kind, size (in the kind's unit: share, [C] or [V]) and interval; ``unknown`` under MIN_SAMPLES.
    """
    return finish(_decide(sums, reported))


def decision_steps(sums: ProfileSums) -> int:
    """The steps :func:`decide_steps` takes on ``sums``, whatever its answer: the misfits' pieces (one misfit on the
    datasheet wheel, three on a unit: :func:`_noise`; ProfileSums.rss_steps) and the decision's own (the checks
    and the least misfit a family a piece, the reports, the best point, its sizes, its interval, the unit's two).

    Parameters
    ----------
    sums : ProfileSums
        The wheel's sums.

    Returns
    -------
    int
        The number of ``next`` calls the generator takes to return.
    """
    unit = sums.unit is not None
    misfits = rss_pieces(False) + (2 * rss_pieces(True) if unit else 0)
    return misfits + len(KINDS) * (3 if unit else 2) + 5 + (2 if unit else 0)


def decide_steps(sums: ProfileSums, reported: dict | None = None):
    """:func:`decide` one piece at a time, for a caller whose time is bounded: a generator that takes exactly
    :func:`decision_steps` ``next`` calls, whatever the answer (an early 'unknown' waits out the rest, so the
    answer's timing depends on the counts alone), and returns the Identification. ``sums`` must not change
    until it has returned.

    Parameters
    ----------
    sums : ProfileSums
        The wheel's sums since the fault's onset.
    reported : dict of str to float, optional
        What the wheel reports of a family's parameter (:func:`held_to_reports`).

    Returns
    -------
    generator
        Yields None; returns the Identification.
    """
    taken, steps = 1, _decide(sums, reported)
    while True:
        try:
            next(steps)
        except StopIteration as end:
            found = end.value
            break
        taken += 1
        yield
    if taken > decision_steps(sums):
        raise RuntimeError("decide_steps took more steps than decision_steps counts")
    for _ in range(decision_steps(sums) - taken):
        yield
    return found


def _decide(sums: ProfileSums, reported: dict | None):
    """decide's body, a generator of the misfits' pieces (ProfileSums.rss_steps)."""
    n = sums.n
    if n < MIN_SAMPLES:
        return Identification(UNKNOWN, samples=n)
    known = yield from sums.rss_steps()      # the unit at its mean (the datasheet wheel without a unit)
    if not (yield from _finite(known)):
        return Identification(UNKNOWN, samples=n)
    s2, s2_across, fits = yield from _noise(sums, known)
    if fits is not known and not (yield from _finite(fits)):
        return Identification(UNKNOWN, samples=n)
    nominal = fits["current_limiter"][0, 0]          # grid[0] of every family is the healthy wheel, whatever the ramp
    if reported:
        fits = held_to_reports(fits, sums, reported, s2)
    yield
    # the first family (KINDS order) at the least misfit: every family's grid[0] is the healthy wheel, and their
    # closed forms and sums may leave a tie there a few rounding errors apart
    mins = {}
    for k in KINDS:
        mins[k] = float(fits[k].min())
        yield
    least = min(mins.values())
    best = next(k for k in KINDS if mins[k] <= least + 1e-12 * abs(least))
    if not np.isfinite(mins[best]):   # reports no family can meet (a bus below the grid's end)
        return Identification(UNKNOWN, samples=n)
    rss = fits[best]
    ramp, point = np.unravel_index(int(rss.argmin()), rss.shape)
    rss_min = float(rss[ramp, point])
    explained = 1.0 - rss_min / nominal if nominal > 0 else 0.0
    # a current loss and a bus drop differ only while driven (the driven floor); a temperature and a drive fault
    # also in a spin-down, whose floor is the bearing noise alone
    margin = min((mins[k] - rss_min) / (s2 if k in DRIVE and best in DRIVE else s2_across)
                 for k in KINDS if k != best)
    yield
    step = abs(GRIDS[best][1] - GRIDS[best][0])
    yield
    low, high = _interval(sums, best, rss, s2, step)
    yield
    size = float(_sizes(sums, best, np.array([ramp]), np.array([point]))[0])
    out = Identification(best, size, low, high, n, float(explained), best, mins)
    out.healthy = point == 0
    yield from _describe_fit(out, sums, ramp, rss, known[best], s2, step)
    # a current loss and a bus drop differ only in how the motor torque varies with the command and speed: under
    # MIN_DRIVEN driven samples (a wheel given up at once) that is no evidence, whatever the spin-down's count
    few_driven = best in DRIVE and sums.n_driven < MIN_DRIVEN and "bus_voltage" not in (reported or {})
    if explained < EXPLAINED or margin < DECISIVE or out.healthy or few_driven:
        out.kind = UNKNOWN
        # the fault is in the drive, which of its two the samples cannot say: said so, not hidden in 'unknown'
        drive_only = best in DRIVE and all((mins[k] - rss_min) / s2_across >= DECISIVE for k in KINDS
                                           if k not in DRIVE)
        if explained >= EXPLAINED and not out.healthy and drive_only:
            out.between = DRIVE
    return out


def _describe_fit(out: Identification, sums: ProfileSums, ramp: int, rss, known, s2: float, step: float):
    """The best fit's when, ramp and unit on ``out`` (its kind's RSS ``rss``; ``known``: with the unit at its
    mean): the time of its size, whether it still grows, the ramp's length, and whether the unit's uncertainty
    rather than the samples limits its interval (a generator: yields after each of the unit's two intervals)."""
    seen = sums.seen(out.kind)
    out.at_s = float(sums.start + seen)
    out.growing = bool(ramp_fractions(seen)[ramp] < 1.0)
    if RAMP_LENGTH[ramp] > 0.0:
        out.ramp_s = float(RAMP_LENGTH[ramp] / (1.0 - RAMP_SHARE[ramp]))
    if sums.unit is not None:
        out.unit = sums.unit.source
        # the interval were the unit known exactly, both without the ramps' neighbours (they are the same)
        alone = _interval(sums, out.kind, known, s2, step, neighbours=False)
        yield
        held = _interval(sums, out.kind, rss, s2, step, neighbours=False)
        yield
        out.unit_limited = (held[1] - held[0]) > 2.0 * (alone[1] - alone[0])


def _interval(sums: ProfileSums, kind: str, rss, s2, step, neighbours: bool = True) -> tuple:
    """{theta : RSS(theta) - RSS_min <= chi2_1(0.95) s^2 c} over every ramp (theta at the last sample that shows
    ``kind``, ProfileSums.sizes_now, computed only where needed), widened to the best size of each ramp next to
    the best one on the ramps' grid (the fault's own ramp lies between grid ramps, and a neighbour's size is as
    near it as the best's), never narrower than the grid's own resolution (half a ``step`` either side) nor
    outside the grid."""
    inside = rss - rss.min() <= CHI2_95 * s2 * CORRELATION
    best = int(rss.min(axis=1).argmin())
    if neighbours:
        for h in _NEIGHBOURS[best]:
            if np.isfinite(rss[h]).any():   # a ramp the reports leave a size on
                inside[h, rss[h].argmin()] = True
    ramps, points = np.nonzero(inside)
    sizes = _sizes(sums, kind, ramps, points)
    ends = float(sizes.min()), float(sizes.max())
    # every ramp's sizes run between those of the grid's two ends (theta_0 + phi (theta - theta_0), monotone)
    every = np.arange(rss.shape[0])
    grid = GRIDS[kind]
    ends_of_grid = [_sizes(sums, kind, every, np.full(every.size, k)) for k in (int(grid.argmin()), int(grid.argmax()))]
    bounds = float(min(e.min() for e in ends_of_grid)), float(max(e.max() for e in ends_of_grid))
    return max(ends[0] - step / 2, bounds[0]), min(ends[1] + step / 2, bounds[1])


def _sizes(sums: ProfileSums, kind: str, ramps, points) -> np.ndarray:
    """theta of ramps ``ramps`` at grid points ``points`` (arrays of indices), as ProfileSums.sizes_now gives them."""
    grid = GRIDS[kind]
    phi = ramp_fractions(sums.seen(kind))
    return grid[0] + phi[ramps] * (grid[points] - grid[0])


def identify(reaction_torque, motor_torque, friction_torque, wheel_speed, bus_torque, ripple_phasor,
             unit: UnitShares | None = None, free_motor_torque=None, times=None,
             viscous_scale: float = 1.0, floor: float = SIGMA_FLOOR, reported: dict | None = None) -> Identification:
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
    reported : dict of str to float, optional
        What the wheel reports of a family's parameter at the last sample (:func:`held_to_reports`).

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
    return decide(sums, reported)
