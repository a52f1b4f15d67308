"""Running sums of one wheel's samples that give the misfit (RSS) of every family's grid point on every ramp,
the commutation ripple (and what the calibration does not know of the unit) projected out.
"""
from __future__ import annotations

import numpy as np

from ..calibration import UnitShares
from .families import (BUS_VOLTAGE_GRID, GRIDS, KINDS, LINEAR_DIRECTIONS, LINEAR_SLOPES, SIGMA_FLOOR,
                       _VISCOUS_NOMINAL, _free,
                       bus_predictions, unit_sensitivities)
from .ramps import RAMP_LENGTH, _LENGTH_LONGEST_FIRST, _LONGEST_FIRST, _RAMP_ORDER, ramp_fractions

# the ripple's amplitude once a wheel's driver is off, in units of its healthy samples' (set_ripple_prior): a
# current loss or a bus drop scales the real ripple down (kappa <= 1); twice, for the scatter of that estimate
KAPPA_MAX = 2.0
_LINEAR = tuple(LINEAR_SLOPES)
_H = len(RAMP_LENGTH)
# the misfits are computed in chunks of ramps, so that a caller whose time is bounded (the isolation node) spreads
# a decision over its periods (FaultIdentifier's work): rss_pieces() pieces a misfit of every family
RAMP_CHUNK = 33    # ramps of a misfit a piece (they fit a cache: 33 x 651 x 6 doubles on a unit)
ADD_CHUNK = 131    # ramps a piece of a sample added: at most three pieces a sample
_CHUNKS = [slice(k, min(k + RAMP_CHUNK, _H)) for k in range(0, _H, RAMP_CHUNK)]
GRID_CHUNK = 256   # grid points of a linear family's N(Delta) a piece, with a unit's penalty


def rss_pieces(penalty: bool) -> int:
    """The yields of ProfileSums.rss_steps: each family's chunks of ramps, and with a unit's ``penalty`` what the
    chunks of each share (N(Delta) in chunks of grid points, the bus family's inverses).

    Parameters
    ----------
    penalty : bool
        Whether the misfit carries a unit's penalty (a noise variance and a unit).

    Returns
    -------
    int
        The pieces.
    """
    shared = sum(-(-len(GRIDS[k]) // GRID_CHUNK) for k in KINDS) if penalty else 0
    return len(_CHUNKS) * len(KINDS) + shared


def add_pieces(elapsed: float) -> int:
    """The ``next`` calls ProfileSums.add_steps takes for a sample ``elapsed`` seconds after the first added: one,
    and one a chunk of ADD_CHUNK of the ramps still growing then.

    Parameters
    ----------
    elapsed : float
        [s] from the first sample added to this one.

    Returns
    -------
    int
        The pieces.
    """
    growing = int(np.count_nonzero(_LENGTH_LONGEST_FIRST > elapsed))
    return 1 + -(-growing // ADD_CHUNK)


def sums_buffers(unit: bool, touched: bool = True) -> dict:
    """Zeroed arrays for the bus family's ramp sums of one wheel's ProfileSums (most of its memory: 261 x 651 x 3
    doubles, 7 on a unit), made before a wheel is alarmed and ``touched`` (every page written now), so that a
    caller whose time is bounded (the isolation node) pays no page faults then: the first samples of a unit's
    sums cost 30 ms in page faults. Zero them again (``fill(0)``) before they serve another wheel's sums.

    Parameters
    ----------
    unit : bool
        For a unit's sums (six columns: the ripple's and the unit's four), else the datasheet wheel's (two).
    touched : bool
        Write every page now.

    Returns
    -------
    dict of str to ndarray
        ``ramp_sq`` (H, G) and ``ramp_cross`` (columns, H, G), zero.
    """
    g = len(BUS_VOLTAGE_GRID)
    out = {"ramp_sq": np.zeros((_H, g)), "ramp_cross": np.zeros((6 if unit else 2, _H, g))}
    if touched:
        for array in out.values():
            array.fill(0.0)
    return out


def finish(steps):
    """Run a generator of steps (ProfileSums.rss_steps, decision.decide_steps) to its end.

    Parameters
    ----------
    steps : generator
        The steps.

    Returns
    -------
    object
        What the generator returns.
    """
    while True:
        try:
            next(steps)
        except StopIteration as end:
            return end.value


def _held_ripple_misfit(sq, c, g):
    """min over kappa in [0, KAPPA_MAX] of sum (e - kappa z)^2 = sq - 2 kappa c + kappa^2 g (c: sum e z, g: sum z^2)."""
    kappa = np.clip(c / g, 0.0, KAPPA_MAX)
    return np.maximum(sq - 2.0 * kappa * c + kappa * kappa * g, 0.0)


def _quadratic(c0: float, c1, c2, delta):
    """max(c0 + Delta (c1_h + Delta c2_h), 0) for every ramp h and grid offset Delta, (H, G), in place."""
    out = c2[:, None] * delta[None]
    out += c1[:, None]
    out *= delta[None]
    out += c0
    return np.maximum(out, 0.0, out=out)


def _quadratic_form(c0, c1, inverse):
    """c^T M c for c = (c0, c1) elementwise and the symmetric 2 x 2 M = ``inverse``."""
    out = c0 * c0
    out *= inverse[0, 0]
    term = c0 * c1
    term *= 2.0 * inverse[0, 1]
    out += term
    np.multiply(c1, c1, out=term)
    term *= inverse[1, 1]
    out += term
    return out


class ProfileSums:
    """Running sums that give RSS(theta) of every grid point of every ramp with the ripple (and the unit's
    uncertainty) projected out:

        RSS = sum e^2 - c^T (G + Pi)^-1 c,  e = r - r^(theta(t)),  c = sum e x,  G = sum x x^T,
        x = (Im p, Re p[, dr^/db(theta)]),  Pi = the unit's prior information (0 on the ripple)

    theta(t) is the grid value throughout for the step and theta_0 + phi_h(t) (theta - theta_0) for ramp h
    (RAMP_SHARE, RAMP_LENGTH). The unit's directions are taken at the grid value for a ramp too (a difference
    of second order).

    The current limiter and the temperature are linear in their parameter (families.LINEAR_SLOPES): with
    Delta = theta - theta_0, e_h = y + phi_h Delta z and x(Delta) = D(Delta) x~, D = I + Delta diag(d), so

        RSS_h(Delta) = S_yy + 2 Delta S_yz,h + Delta^2 S_zz,h - (u + Delta v_h)^T N(Delta) (u + Delta v_h),
        N(Delta) = D (D G~ D + Pi)^-1 D,   u = sum y x~,  v_h = sum phi_h z x~,  G~ = sum x~ x~^T,

    and a sample costs O(ramps), whatever the grid. The bus family is not linear in its voltage: its sums are
    kept per grid point, a ramp's as its difference from the step's while it grows (O(ramps x grid) a sample
    for the first 400 s, O(grid) after). Memory does not grow with the samples.

    ``unit``: what is known of the wheel's unit (calibration.UnitShares); None for the datasheet wheel;
    ``viscous_scale``: the wheel type's (family_predictions); ``floor``: the smallest misfit taken for real
    [N m] (SIGMA_FLOOR of the Type A, wheel.torque_scale of another type), ``unpowered_floor`` that of a sample of
    the driver off (families.noise_floors; None: ``floor``); ``buffers``: zero arrays of
    :func:`sums_buffers` for its ramp sums (made on the spot without).
    """

    def __init__(self, unit: UnitShares | None = None, viscous_scale: float = 1.0, floor: float = SIGMA_FLOOR,
                 buffers: dict | None = None, unpowered_floor: float | None = None):
        self.unit = unit
        self.viscous_scale = float(viscous_scale)
        self.floor = float(floor)
        self.unpowered_floor = self.floor if unpowered_floor is None else float(unpowered_floor)
        self.scales = None if unit is None else unit.scales()
        width = 2 if unit is None else 6
        # the linear families: S_yy, u, G~ shared (y and x~ are the nominal wheel's), S_yz, S_zz, v per ramp
        self.syy = 0.0
        self.u = np.zeros(width)
        self.lin_gram = np.zeros((width, width))
        self.syz = np.zeros((len(_LINEAR), _H))
        self.szz = np.zeros((len(_LINEAR), _H))
        self.v = np.zeros((len(_LINEAR), _H, width))
        # the bus family per grid point; its ripple Gram is the same for every point, the unit's directions not
        g = len(BUS_VOLTAGE_GRID)
        self.sq = np.zeros(g)
        self.cross = np.zeros((g, width))
        self.gram = np.zeros((2, 2)) if unit is None else np.zeros((g, width, width))
        # each ramp's sums less the step's, longest ramp first: nothing once the ramp is over
        buffers = buffers if buffers is not None else sums_buffers(unit is not None, touched=False)
        self.ramp_sq = buffers["ramp_sq"]
        self.ramp_cross = buffers["ramp_cross"][:width]   # a column's ramps and points contiguous (decide reads them)
        self.n = 0
        self.start = None     # [s] the first sample's time
        self.elapsed = 0.0    # [s] from the first sample to the last
        self.driven = 0.0     # [s] from the first sample to the last with motor torque (its driver on)
        self.n_driven = 0     # samples with motor torque
        self.ripple_prior = None    # w: the ripple's phase, of the healthy samples before the onset
        self.prior_on = False       # the ripple one regressor of that phase: the driver off at the last sample

    def floor_variance(self) -> float:
        """The least noise variance the decision takes [N^2 m^2]: the floors' squares averaged over the samples,
        ``floor`` for those with motor torque and ``unpowered_floor`` for those of a driver off.

        Returns
        -------
        float
            sigma_floor^2.
        """
        if not self.n:
            return self.floor ** 2
        return (self.n_driven * self.floor ** 2 + (self.n - self.n_driven) * self.unpowered_floor ** 2) / self.n

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
        samples, or a ripple they cannot resolve, set nothing.

        Parameters
        ----------
        errors : array_like, shape (n,)
            The healthy samples' model error r - r^ [N m].
        ripple_phasors : array_like of complex, shape (n,)
            Their ripple phasors p [N m].
        """
        e = np.asarray(errors, float)
        p = np.asarray(ripple_phasors, complex)
        x = np.column_stack([p.imag, p.real, np.ones(e.size)])
        gram = x.T @ x
        if e.size < 4 or not np.all(np.isfinite(e)) or np.linalg.cond(gram) > 1e12:
            return
        self.ripple_prior = np.linalg.solve(gram, x.T @ e)[:2]

    def _shape(self, width: int):
        """(shape matrix, ripple columns): (Im p, Re p, rest) -> (w^T (Im p, Re p), rest) while ``prior_on``
        (set_ripple_prior), else None and 2."""
        if not (self.prior_on and self.ripple_prior is not None):
            return None, 2
        shape = np.zeros((width - 1, width))
        shape[0, :2] = self.ripple_prior
        shape[1:, 2:] = np.eye(width - 2)
        return shape, 1

    def add(self, row, time: float | None = None):
        """Add one FDI sample.

        Parameters
        ----------
        row : tuple
            (reaction torque, motor torque, friction torque [N m], wheel speed [rad/s], bus torques (G,) [N m],
            ripple phasor [N m][, free motor torque [N m]]).
        time : float, optional
            The sample's time [s]; default: its index (1 s samples).
        """
        finish(self.add_steps(row, time))

    def add_steps(self, row, time: float | None = None):
        """:meth:`add` one piece at a time, for a caller whose time is bounded: a generator that takes exactly
        :func:`add_pieces` ``next`` calls (the linear families' and the step's sums, then a chunk of ADD_CHUNK of
        the bus ramps still growing each), whatever the sample. The sums are whole only once it has returned.

        Parameters
        ----------
        row : tuple
            As for :meth:`add`.
        time : float, optional
            As for :meth:`add`.

        Returns
        -------
        generator
            Yields None; returns None.
        """
        r, tm, tf, w, bus, p, *rest = row
        bus = np.asarray(bus, float)   # a PeriodBusGrid is computed here, for an alarmed wheel only
        free = rest[0] if rest else None
        time = float(self.n if time is None else time)
        self.start = time if self.start is None else self.start
        self.elapsed = time - self.start
        if tm != 0.0:
            self.driven = self.elapsed
            self.n_driven += 1
        self.prior_on = tm == 0.0    # its driver off (set_ripple_prior)
        phi = ramp_fractions(self.elapsed)
        ripple = np.array([np.imag(p), np.real(p)])
        self._add_linear(float(r), float(tm), float(tf), float(w), ripple, free, phi)
        e = r - bus_predictions(tm, tf, w, bus[None, :], self.scales, free, viscous_scale=self.viscous_scale)[:, 0]
        if self.unit is None:
            x = ripple[None, :]
            self.gram += np.outer(ripple, ripple)
        else:
            x = np.empty((len(e), 6))
            x[:, :2] = ripple
            x[:, 2:] = unit_sensitivities(tm, tf, w, bus[None, :], free, self.viscous_scale, ("bus_voltage",))[:, 0]
            self.gram += x[:, :, None] * x[:, None, :]
        self.cross += e[:, None] * x
        self.sq += e * e
        growing = int(np.count_nonzero(_LENGTH_LONGEST_FIRST > self.elapsed))   # phi < 1
        # where the bridge does not clip at V it does not at any voltage above: a ramp to V moves nothing there
        clips = bus != bus[0]
        first = int(clips.argmax()) if clips.any() else len(bus)
        e, x = e[first:], x[first:] if len(x) > 1 else x
        for start in range(0, growing, ADD_CHUNK):
            yield
            rows = slice(start, min(start + ADD_CHUNK, growing))
            if first == len(bus):
                continue
            e_ramp = r - bus_predictions(tm, tf, w, bus[None, :], self.scales, free, first=first,
                                         fraction=phi[_LONGEST_FIRST[rows]], viscous_scale=self.viscous_scale)
            self.ramp_sq[rows, first:] += e_ramp * e_ramp - e * e
            moved = e_ramp - e
            for j in range(x.shape[1]):
                self.ramp_cross[j, rows, first:] += moved * x[:, j]
        self.n += 1

    def _add_linear(self, r, tm, tf, w, ripple, free, phi):
        """The linear families' sums of one sample (the class docstring): y, x~ and each family's z."""
        viscous = self.viscous_scale * _VISCOUS_NOMINAL * w
        if self.scales is None:
            motor, friction, sv, x = tm, tf, 1.0, ripple
        else:
            kt, gd, sv, sc = (float(s) for s in self.scales)
            f = float(_free(np.atleast_1d(tm), free)[0])
            motor, friction = kt * (tm + (gd - 1.0) * f), sv * viscous + sc * (tf - viscous)
            x = np.concatenate([ripple, (-tm, -f, viscous, tf - viscous)])
        y = r + motor - friction                     # the nominal wheel's error
        self.syy += y * y
        self.u += y * x
        self.lin_gram += np.outer(x, x)
        for i, kind in enumerate(_LINEAR):
            # e = y + phi Delta z: the limiter scales the (unit's) motor torque, the temperature the viscous drag
            z = motor if kind == "current_limiter" else -sv * self.viscous_scale * LINEAR_SLOPES[kind] * w
            pz = phi * z
            self.syz[i] += pz * y
            self.szz[i] += pz * pz
            self.v[i] += pz[:, None] * x[None]

    def _ripple_usable(self, gram) -> bool:
        return (self.n > 2 and bool(np.all(np.isfinite(gram))) and np.abs(gram).max() > 0.0
                and np.linalg.cond(gram) <= 1e12)

    def rss(self, noise_variance: float | None = None) -> dict:
        """RSS of every ramp and grid point of every family, the ripple projected out; with ``noise_variance``
        (c s^2) and a unit, the unit's uncertainty too (penalised by its prior), else the unit taken at its
        mean.

        Parameters
        ----------
        noise_variance : float, optional
            c s^2 [N^2 m^2]: the unit's uncertainty's penalty scale; None: the unit at its mean.

        Returns
        -------
        dict of str to ndarray, shape (H, G)
            Kind -> RSS [N^2 m^2] per ramp (RAMP_LENGTH order) and grid point of its grid (GRIDS).
        """
        return finish(self.rss_steps(noise_variance))

    def rss_steps(self, noise_variance: float | None = None):
        """:meth:`rss` one piece at a time: a generator that yields after each of :func:`rss_pieces` pieces (a chunk
        of RAMP_CHUNK ramps of one family, or what a family's chunks share) and returns what rss returns (the bus
        family put in RAMP_LENGTH order on the last ``next``), for a caller whose time is bounded.

        Parameters
        ----------
        noise_variance : float, optional
            As for :meth:`rss`.

        Returns
        -------
        generator
            Yields None; returns what :meth:`rss` returns.
        """
        width = self.u.size
        shape, nr = self._shape(width)
        gram = self.lin_gram if shape is None else shape @ self.lin_gram @ shape.T
        ripple = self._ripple_usable(gram[:nr, :nr])
        penalty = None
        if noise_variance is not None and self.unit is not None:
            penalty = np.zeros((gram.shape[0],) * 2)
            penalty[nr:, nr:] = noise_variance * np.linalg.inv(self.unit.covariance + 1e-12 * np.eye(4))
            if nr == 1:   # its driver off: kappa held to its scale by a prior N(0, KAPPA_MAX^2)
                penalty[0, 0] = noise_variance / KAPPA_MAX**2
        out = {}
        for i, kind in enumerate(_LINEAR):
            out[kind] = np.empty((_H, len(GRIDS[kind])))
            prepared = {}
            if penalty is not None:
                yield from self._prepare_linear(i, kind, shape, nr, gram, ripple, penalty, prepared)
            for rows in _CHUNKS:
                out[kind][rows] = self._rss_linear(i, kind, shape, nr, gram, ripple, penalty, rows, prepared)
                yield
        stored, prepared = np.empty((_H, len(BUS_VOLTAGE_GRID))), {}
        if penalty is not None:
            yield from self._bus_inverse(shape, nr, ripple, penalty, prepared)
        for rows in _CHUNKS:
            stored[rows] = self._rss_bus(shape, nr, ripple, penalty, rows, prepared)
            yield
        out["bus_voltage"] = stored[_RAMP_ORDER]
        return {k: out[k] for k in KINDS}

    def _rss_linear(self, i, kind, shape, nr, gram, ripple, penalty, rows, prepared):
        """Rows ``rows`` of one linear family's RSS (H, G) in closed form (the class docstring); ``prepared``:
        what every chunk of one call shares, filled by the first."""
        delta = GRIDS[kind] - GRIDS[kind][0]
        u, v = (self.u, self.v[i][rows]) if shape is None else (shape @ self.u, self.v[i][rows] @ shape.T)
        syz, szz = self.syz[i][rows], self.szz[i][rows]
        if penalty is None and not ripple:
            return _quadratic(self.syy, 2.0 * syz, szz, delta)
        sq = self.syy + 2.0 * delta[None] * syz[:, None] + delta[None] ** 2 * szz[:, None]
        if penalty is None:
            if nr == 1:   # its driver off: kappa within [0, KAPPA_MAX], not free (set_ripple_prior)
                return _held_ripple_misfit(sq, u[0] + delta[None] * v[:, 0][:, None], float(gram[0, 0]))
            inverse = np.linalg.inv(gram[:nr, :nr])
            ur, vr = u[:nr], v[:, :nr]
            a0, a1, a2 = ur @ inverse @ ur, vr @ inverse @ ur, np.einsum("hi,ij,hj->h", vr, inverse, vr)
            # one quadratic in Delta per ramp, its coefficients first: (S_yy - a0) + Delta (2 b + Delta c)
            return _quadratic(self.syy - a0, 2.0 * (syz - a1), szz - a2, delta)
        keep = slice(0, gram.shape[0]) if ripple else slice(nr, gram.shape[0])
        n_of, nu, alpha = prepared["n_of"], prepared["nu"], prepared["alpha"]
        v = v[:, keep]
        beta = v @ nu.T                                                      # (h, G)
        gamma = np.einsum("hi,hj->hij", v, v).reshape(len(v), -1) @ n_of.reshape(len(delta), -1).T
        return np.maximum(sq - (alpha[None] + 2.0 * delta[None] * beta + delta[None] ** 2 * gamma), 0.0)

    def _prepare_linear(self, i, kind, shape, nr, gram, ripple, penalty, prepared):
        """What every ramp of a linear family shares with a unit's penalty: N(Delta) and its products with u, in
        GRID_CHUNK grid points a piece (a generator: yields after each)."""
        delta = GRIDS[kind] - GRIDS[kind][0]
        u = self.u if shape is None else shape @ self.u
        keep = slice(0, gram.shape[0]) if ripple else slice(nr, gram.shape[0])
        d = np.zeros(gram.shape[0])
        d[nr:] = LINEAR_DIRECTIONS[kind]
        k = len(range(gram.shape[0])[keep])
        n_of, nu = np.empty((len(delta), k, k)), np.empty((len(delta), k))
        for start in range(0, len(delta), GRID_CHUNK):
            points = slice(start, start + GRID_CHUNK)
            scale = (1.0 + delta[points, None] * d[None])[:, keep]             # D(Delta), (g, k)
            matrix = scale[:, :, None] * gram[keep, keep][None] * scale[:, None, :] + penalty[keep, keep][None]
            n_of[points] = scale[:, :, None] * np.linalg.inv(matrix) * scale[:, None, :]   # N(Delta), (g, k, k)
            nu[points] = n_of[points] @ u[keep]                                # (g, k)
            yield
        prepared.update(n_of=n_of, nu=nu, alpha=nu @ u[keep])                   # alpha (G,)

    def _bus_inverse(self, shape, nr, ripple, penalty, prepared):
        """What every ramp of the bus family shares with a unit's penalty: one (k, k) inverse per grid point, in
        GRID_CHUNK points a piece (a generator: yields after each)."""
        gram = self.gram if shape is None else shape @ self.gram @ shape.T
        width = gram.shape[-1]
        keep = slice(0, width) if ripple else slice(nr, width)
        # one (k, k) inverse per grid point serves all its ramps: c^T (G + Pi)^-1 c as batched products,
        # five times faster than a solve per ramp
        inverse = prepared["inverse"] = np.empty((len(gram), len(range(width)[keep]), len(range(width)[keep])))
        for start in range(0, len(gram), GRID_CHUNK):
            points = slice(start, start + GRID_CHUNK)
            inverse[points] = np.linalg.inv((gram[points] + penalty)[:, keep, keep])        # (g, k, k)
            yield

    def _rss_bus(self, shape, nr, ripple, penalty, rows, prepared):
        """Rows ``rows`` (of their stored order, longest ramp first) of the bus family's RSS (H, G) of its per-point
        sums; ``prepared``: what every chunk of one call shares, filled by the first."""
        sq = self.sq[None] + self.ramp_sq[rows]
        if penalty is None:
            if not ripple:
                return np.maximum(sq, 0.0)
            # the ripple's columns alone: they are the first two of every point's, and their Gram is the same
            c0 = self.ramp_cross[0, rows] + self.cross[None, :, 0]      # (ramps, grid): the two ripple columns
            c1 = self.ramp_cross[1, rows] + self.cross[None, :, 1]
            ripple_gram = self.gram if self.unit is None else self.gram[0, :2, :2]
            if nr == 1:   # its driver off: kappa within [0, KAPPA_MAX], not free (set_ripple_prior)
                w = self.ripple_prior
                return _held_ripple_misfit(sq, w[0] * c0 + w[1] * c1, float(w @ ripple_gram @ w))
            sq -= _quadratic_form(c0, c1, np.linalg.inv(ripple_gram))
            return np.maximum(sq, 0.0, out=sq)
        part = self.ramp_cross[:, rows]
        cross = np.empty(part.shape[1:] + part.shape[:1])   # (ramps, grid, width), C order: the products read rows
        np.add(np.moveaxis(part, 0, -1), self.cross[None], out=cross)
        if shape is not None:
            cross = cross @ shape.T
        keep = slice(0, cross.shape[-1]) if ripple else slice(nr, cross.shape[-1])
        c = np.moveaxis(cross[..., keep], 0, 1)                          # (grid, ramps, k)
        return np.maximum(sq - np.einsum("irk,irk->ri", c @ prepared["inverse"], c), 0.0)

    def seen(self, kind: str) -> float:
        """[s] from the first sample to the last that shows ``kind``'s parameter: a current loss or a bus drop
        shows only through the motor torque, so not once the wheel's driver is off (every later sample is the
        same at every grid point, and a ramp's size there would be an extrapolation).

        Parameters
        ----------
        kind : str
            One of KINDS.

        Returns
        -------
        float
            The time [s] from the first sample counted.
        """
        return self.elapsed if kind == "temperature" else self.driven

    def sizes_now(self, kind: str) -> np.ndarray:
        """theta at the last sample that shows it (:meth:`seen`) of every ramp and grid point of ``kind``'s
        family.

        Parameters
        ----------
        kind : str
            One of KINDS.

        Returns
        -------
        ndarray, shape (H, G)
            theta per ramp and grid point of the kind's grid, in its unit.
        """
        grid = GRIDS[kind]
        phi = ramp_fractions(self.seen(kind))[:, None]
        return grid[0] + phi * (grid[None] - grid[0])
