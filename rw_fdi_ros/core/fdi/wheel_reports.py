"""A real wheel's reports, at their own rate, on the FDI's control grid.

A wheel and its driver report speed and command (perhaps reaction torque) at
their own stamps, with jitter and gaps. :class:`ControlGrid` puts them on the
grid t_k = k dt that :class:`~.telemetry.TelemetrySampler` averages:

* Omega(t_k): between the speed reports around t_k, linear plus what the commands explain (below);
* u(t_k): the last command stamped before t_k (the driver holds it over the step);
* r(t_k): a reported reaction torque, linear like Omega; without one the
  wheel's momentum balance over the step, r = -J dOmega/dt:
      r_k = -J (Omega(t_k) - Omega(t_{k-1})) / dt,
  whose mean over an FDI period telescopes to -J (Omega(t) - Omega(t - T)) / T,
  so the speed noise enters the FDI sample once, not once per step. r_k is the
  mean torque over the step, so the row's speed is the step's mean,
  (Omega(t_{k-1}) + Omega(t_k)) / 2: the nominal model at it is the step's mean
  model torque to second order (at Omega(t_k) the friction's and the EMF's
  slopes put half a step's speed change between them: 1.5e-6 N m in a 40-s
  window on a Type A held by a speed loop, half the model observer's band).

Between two speed reports at t_a and t_b the speed is not linear where the
command changes: a slew's torque step between two 1-s reports would put a
quarter of a second of it into the speed at the FDI stamp, and into every
window mean that ends there (0.6 mN m against an HR16's 0.14 mN m band on
Basilisk's 1-Hz tachometer). With the wheel type's nominal model r^(u, Omega)
the grid takes what the commands explain and spreads only the rest linearly:

    Omega(t) = Omega_lin(t) + M(t) - M(t_b) (t - t_a) / (t_b - t_a),   M(t) = -1/J integral_{t_a}^{t} r^ ds,

so a healthy wheel's derived torque is its model's, and a fault's torque is
spread over the reports' interval (exact at the reports, whatever their rate).
That holds for commands stamped on the grid (a driver in step with the FSW): a
command stamped inside a step is in force over the whole step in the rows,
over part of it in the bend.

Speed reports further apart than ``max_gap`` leave the grid points between
them without values (NaN): the FDI sample of that period is not finite and the
FDI says it cannot judge, rather than judging a guess. So does a period the
reports did not cover from its start (the first, where the reports began in
it): its mean would be over part of the period, which the band's telescoped
speed noise does not cover.

Speed and command come on two streams, and one may arrive after the other: a
speed report waits until a command stamped at or after it has come (the
commands before it are then all in) or until ``hold`` seconds of newer speed
reports have, so the rows do not depend on the order the two streams arrive
in; :meth:`ControlGrid.flush` gives what still waits at a stream's end.

:class:`ReportSampler` is the grid and the sampler together: the one way FDI
samples are made, from reports, by the wheel_telemetry node (our plant's
streams and anyone's), the core loop (pipeline.FdiPipeline) and the offline
tools (:func:`report_samples`). Our plant reports on the grid itself, with its
reaction torque: there the rows are the reports as sent, u(t_k) the command
sent at t_(k-1), and no row at the first report (no command is in force yet).

A wheel's housekeeping (bus voltage, temperature: :meth:`ReportSampler.add_housekeeping`) comes at its own slow
rate and is not averaged: each FDI sample carries the value last reported at its stamp, for the identification
to hold its families to. A report arriving after the sample of its stamp went out counts from the next one,
and one stamped before the newest report of its channel is dropped, whichever wheel it names.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .telemetry import TelemetrySampler, model_reaction_torque


class ControlGrid:
    """Speed, command and optional torque reports in, rows (t_k, u, r, Omega) on the grid k dt out (Omega the
    step's mean speed where r comes from the speed: module docstring).

    Parameters
    ----------
    step : float
        dt [s], the grid's step (a divisor of the FDI period).
    inertia : float
        J [kg m^2], the rotor's, for r without a torque report.
    max_gap : float
        [s] speed reports further apart than this leave the grid points between them NaN (2.5 s: reports at a
        1-s FDI period's rate pass, with jitter and one lost).
    hold : float
        [s] how long, in newer speed reports, a speed report waits for the commands before it (a driver that
        sends its command only on change); 0: until they come (a source in lockstep with its commands: ours).
    model : callable or None
        r^(u, Omega) [N m], the nominal reaction torque, for the speed between reports (module docstring); None:
        the speed linear between them.
    """

    def __init__(self, step: float = 0.1, inertia: float = 0.0077, max_gap: float = 2.5, hold: float = 1.0,
                 model=None):
        self.model = model
        self.step_ns = int(round(step * 1e9))
        self.inertia = float(inertia)
        self.max_gap_ns = int(round(max_gap * 1e9))
        self.hold_ns = int(round(hold * 1e9)) if hold > 0 else None
        self.waiting = []         # speed reports (stamp_ns, Omega, r or None) not yet put on the grid
        self.report = None        # the newest speed report put on the grid
        self.after_gap = False    # the grid point before next_k was unknown (a gap)
        self.commands = []        # (stamp_ns, u) not yet superseded for the grid points to come
        self.next_k = None        # the next grid point to give
        self.previous = None      # Omega at the grid point before next_k (None: not known)

    def add_command(self, stamp_ns: int, tcv) -> list:
        """A command report: u [V] per wheel from ``stamp_ns`` on; the grid points it completes.

        Parameters
        ----------
        stamp_ns : int
            The command's stamp [ns].
        tcv : array_like
            (N,) torque command voltages u [V].

        Returns
        -------
        list of tuple
            The rows the speed reports that waited for it give (:meth:`add_speed`).
        """
        if self.commands and stamp_ns <= self.commands[-1][0]:
            return []   # late or repeated: the driver already holds a newer one
        self.commands.append((int(stamp_ns), np.asarray(tcv, float)))
        return self._release()

    def add_speed(self, stamp_ns: int, wheel_speed, reaction_torque=None) -> list:
        """A speed report; the grid points it (or a command) completes.

        Parameters
        ----------
        stamp_ns : int
            The report's stamp [ns].
        wheel_speed : array_like
            (N,) wheel speeds Omega [rad/s].
        reaction_torque : array_like or None
            (N,) reported reaction torques r [N m]; None: from the speed (module docstring).

        Returns
        -------
        list of tuple
            (t_k [ns], u (N,) [V], r (N,) [N m], Omega (N,) [rad/s]) for each grid point t_k the reports now
            settle, NaN where they leave it unknown.
        """
        stamp_ns = int(stamp_ns)
        newest = self.waiting[-1][0] if self.waiting else self.report[0] if self.report else None
        if newest is not None and stamp_ns <= newest:
            return []   # late or repeated
        self.waiting.append((stamp_ns, np.asarray(wheel_speed, float),
                             None if reaction_torque is None else np.asarray(reaction_torque, float)))
        return self._release()

    def flush(self) -> list:
        """The rows of every speed report still waiting for commands: the stream has ended.

        Returns
        -------
        list of tuple
            As :meth:`add_speed`.
        """
        rows = []
        while self.waiting:
            rows += self._take(*self.waiting.pop(0))
        return rows

    def _release(self) -> list:
        """The rows of the waiting speed reports whose commands are all in, or that waited ``hold``."""
        last_command = self.commands[-1][0] if self.commands else None
        rows = []
        while self.waiting and ((last_command is not None and last_command >= self.waiting[0][0])
                                or (self.hold_ns is not None
                                    and self.waiting[-1][0] - self.waiting[0][0] >= self.hold_ns)):
            rows += self._take(*self.waiting.pop(0))
        return rows

    def _take(self, stamp_ns: int, speed, torque) -> list:
        """The grid points up to a speed report, interpolated from the one before it."""
        before, self.report = self.report, (stamp_ns, speed, torque)
        if before is None:
            self.next_k = -(-stamp_ns // self.step_ns)   # the first grid point at or after the first report
            return self._at(stamp_ns, speed, torque) if stamp_ns == self.next_k * self.step_ns else []
        rows = []
        gap = stamp_ns - before[0] > self.max_gap_ns
        derived = torque is None or before[2] is None
        points = range(self.next_k, stamp_ns // self.step_ns + 1)
        bend = (self._bend(before, (stamp_ns, speed), [k * self.step_ns for k in points])
                if derived and not gap and self.model is not None else None)
        for j, k in enumerate(points):
            t = k * self.step_ns
            if gap:
                rows.append(self._unknown(t, speed.shape))
                continue
            w = (t - before[0]) / (stamp_ns - before[0])
            omega = (1.0 - w) * before[1] + w * speed + (0.0 if bend is None else bend[j])
            measured = None if derived else (1.0 - w) * before[2] + w * torque
            rows += self._at(t, omega, measured)
        return rows

    def _bend(self, a: tuple, b: tuple, times: list):
        """M(t) - M(t_b) (t - t_a) / (t_b - t_a) at the grid points ``times`` between reports a and b (module
        docstring): the speed the commands explain beyond the straight line, the model piecewise constant between
        the commands' stamps and at the straight line's speed. None where no grid point lies strictly inside."""
        (ta, wa), (tb, wb) = a[:2], b
        inside = [t for t in times if ta < t < tb]
        if not inside or not self.commands:
            return None
        cuts = np.array(sorted({ta, tb, *inside, *(c for c, _ in self.commands if ta < c < tb)}))
        stamps = [c for c, _ in self.commands]
        forces = np.searchsorted(stamps, cuts[:-1], side="right") - 1   # the command in force over each (x, y]
        if forces[0] < 0:
            return None   # no command yet over part of it: the straight line
        u = np.array([self.commands[i][1] for i in forces])
        mid = 0.5 * (cuts[:-1] + cuts[1:])
        share = ((cuts - ta) / (tb - ta)).reshape(-1, *([1] * np.ndim(wa)))
        bend = 0.0
        for _ in range(2):   # the model at the bent speed: twice, for friction that turns near zero speed
            line = wa + (wb - wa) * share
            omega = 0.5 * (line[:-1] + line[1:]) + 0.5 * (bend[:-1] + bend[1:]) if np.ndim(bend) else \
                wa + (wb - wa) * ((mid - ta) / (tb - ta)).reshape(share[:-1].shape)
            steps = -self.model(u, omega) / self.inertia * (np.diff(cuts) * 1e-9).reshape(share[:-1].shape)
            m = np.concatenate([np.zeros_like(steps[:1]), np.cumsum(steps, axis=0)])
            bend = m - m[-1] * share
        at = {t: j for j, t in enumerate(cuts)}
        return [bend[at[t]] if ta < t < tb else 0.0 for t in times]

    def _at(self, t: int, omega, measured) -> list:
        """The row of grid point t (next_k), from Omega(t) and a reported r(t) (None: from the speed)."""
        self.next_k += 1
        previous, self.previous = self.previous, omega
        after_gap, self.after_gap = self.after_gap, False
        u = self._command(t)
        if measured is None:
            if previous is None:   # no step behind it: the stream's first point, or the first after a gap
                nan = np.full(np.shape(omega), np.nan)
                return [(t, u, nan, nan)] if after_gap and u is not None else []
            measured = -self.inertia * (omega - previous) / (self.step_ns * 1e-9)
            omega = 0.5 * (previous + omega)   # the step's mean torque is the model's at its mid speed
        if u is None:
            return []       # no command yet: nothing the wheel was asked to do
        return [(t, u, measured, omega)]

    def _unknown(self, t: int, shape) -> tuple:
        self.next_k += 1
        self.previous, self.after_gap = None, True   # the next derivative needs two known points
        u = self._command(t)
        nan = np.full(shape, np.nan)
        return t, (nan if u is None else u), nan, nan

    def _command(self, t: int):
        """The last command stamped before t (None: none yet); those before it are dropped."""
        while len(self.commands) > 1 and self.commands[1][0] < t:
            self.commands.pop(0)
        return self.commands[0][1] if self.commands and self.commands[0][0] < t else None


class ReportSampler:
    """A wheel set's reports in, its FDI samples (telemetry.FdiSample, every FDI period) out:
    :class:`ControlGrid` then telemetry.TelemetrySampler, the nominal model the wheel type's.

    Parameters
    ----------
    wheel : core.physics.wheel.WheelParams
        The wheel type (its datasheet: the nominal model, the rotor inertia J).
    fdi_period : float
        T [s].
    control_period : float
        dt [s] of the grid, a divisor of T.
    max_gap : float
        [s] speed reports further apart leave the periods between them not judged (NaN).
    identification : bool
        The samples also carry the terms fault identification fits (the bus-voltage grid).
    hold : float
        [s] ControlGrid's: how long a speed report waits for its commands (0: until they come).
    """

    def __init__(self, wheel, fdi_period: float = 1.0, control_period: float = 0.1, max_gap: float = 2.5,
                 identification: bool = False, hold: float = 1.0):
        self.grid = ControlGrid(control_period, wheel.inertia, max_gap, hold,
                                model=lambda u, omega: model_reaction_torque(u, omega, wheel)[0])
        self.sampler = TelemetrySampler(fdi_period, "mean", wheel, identification=identification)
        self.period_rows = round(fdi_period / control_period)   # grid rows that cover an FDI period
        self.rows = 0   # grid rows since the last FDI sample
        self.housekeeping = {}   # channel -> [(stamp_ns, values)], rising, the first in force at the next sample

    def add_housekeeping(self, stamp_ns: int, bus_voltage=None, temperature=None):
        """A housekeeping report: the wheels' bus voltage and temperature from ``stamp_ns`` on, NaN for a wheel it
        does not name (that wheel keeps its last report).

        Parameters
        ----------
        stamp_ns : int
            The report's stamp [ns].
        bus_voltage : array_like or None
            (N,) the bus voltage at each wheel's driver [V].
        temperature : array_like or None
            (N,) each wheel's temperature [C].
        """
        for channel, values in (("bus_voltage", bus_voltage), ("temperature", temperature)):
            if values is None:
                continue
            values = np.asarray(values, float)
            reports = self.housekeeping.setdefault(channel, [])
            if reports and stamp_ns < reports[-1][0]:
                continue   # late: a newer report is in force
            if reports:
                values = np.where(np.isnan(values), reports[-1][1], values)
            reports.append((int(stamp_ns), values))

    def add_command(self, stamp_ns: int, tcv) -> list:
        """A command report (ControlGrid.add_command).

        Parameters
        ----------
        stamp_ns : int
            The command's stamp [ns].
        tcv : array_like
            (N,) torque command voltages u [V].

        Returns
        -------
        list of telemetry.FdiSample
            The FDI samples it completes.
        """
        return self._sampled(self.grid.add_command(stamp_ns, tcv))

    def add_speed(self, stamp_ns: int, wheel_speed, reaction_torque=None) -> list:
        """A speed report, with the reaction torque where the wheel reports it (ControlGrid.add_speed).

        Parameters
        ----------
        stamp_ns : int
            The report's stamp [ns].
        wheel_speed : array_like
            (N,) wheel speeds Omega [rad/s].
        reaction_torque : array_like or None
            (N,) reaction torques r [N m]; None: from the speed.

        Returns
        -------
        list of telemetry.FdiSample
            The FDI samples it completes.
        """
        return self._sampled(self.grid.add_speed(stamp_ns, wheel_speed, reaction_torque))

    def flush(self) -> list:
        """What still waits, the streams having ended.

        Returns
        -------
        list of telemetry.FdiSample
            The FDI samples it completes.
        """
        return self._sampled(self.grid.flush())

    def _sampled(self, rows) -> list:
        out = []
        for row in rows:
            self.rows += 1
            sample = self.sampler.add(*row)
            if sample is None:
                continue
            if self.rows < self.period_rows:   # the reports began inside its period: not judged (module docstring)
                nan = np.full(np.shape(sample.tcv), np.nan)
                sample = replace(sample, tcv=nan, reaction_torque=nan, wheel_speed=nan, tcv_instant=nan,
                                 reaction_torque_instant=nan)
            self.rows = 0
            out.append(self._with_housekeeping(sample))
        return out

    def _with_housekeeping(self, sample):
        """The sample with each housekeeping channel's report in force at its stamp (NaN: none yet)."""
        held = {}
        for channel, reports in self.housekeeping.items():
            while len(reports) > 1 and reports[1][0] <= sample.stamp_ns:
                reports.pop(0)
            values = reports[0][1]
            held[channel] = values if reports[0][0] <= sample.stamp_ns else np.full_like(values, np.nan)
        return replace(sample, **held) if held else sample


def report_samples(stamps_ns, tcv, reaction_torque, wheel_speed, wheel, fdi_period: float = 1.0,
                   control_period: float = 0.1, identification: bool = False) -> list:
    """The FDI samples of a run reported on the grid (time first, our plant's): at each stamp the speed and
    reaction torque, then the command sent at it, through :class:`ReportSampler`.

    Parameters
    ----------
    stamps_ns : array_like of int, shape (n,)
        The steps' stamps [ns].
    tcv : array_like, shape (n, N)
        The command u [V] sent at each stamp (in force over the next step).
    reaction_torque, wheel_speed : array_like, shape (n, N)
        r [N m] and Omega [rad/s] at each stamp.
    wheel : core.physics.wheel.WheelParams
        The wheel type.
    fdi_period, control_period : float
        T and dt [s].
    identification : bool
        With the terms fault identification fits.

    Returns
    -------
    list of telemetry.FdiSample
        One per FDI stamp after the first.
    """
    reports = ReportSampler(wheel, fdi_period, control_period, identification=identification)
    out = []
    for stamp, u, r, w in zip(stamps_ns, tcv, reaction_torque, wheel_speed):
        out += reports.add_speed(int(stamp), w, r)
        out += reports.add_command(int(stamp), u)
    return out + reports.flush()


def speed_noise(stamps, speeds) -> float | None:
    """sigma_Omega [rad/s] of a tachometer's reports, from their second differences where the reports are evenly
    spaced: white noise of sigma gives Omega_(k+1) - 2 Omega_k + Omega_(k-1) a variance of 6 sigma^2, the
    wheel's own acceleration changes far less between reports; the median absolute deviation keeps a slew's
    steps out. It is the ``speed_noise`` of residuals.speed_noise_reach.

    Parameters
    ----------
    stamps : array_like, shape (n,)
        The reports' times [s], rising.
    speeds : array_like, shape (n,)
        The reported speeds Omega [rad/s].

    Returns
    -------
    float or None
        sigma_Omega [rad/s]; None (unknown) with fewer than 10 evenly spaced, finite triples.
    """
    if len(speeds) < 12:
        return None
    h = np.diff(stamps)
    even = np.abs(h[1:] - h[:-1]) <= 0.1 * h[:-1]
    d2 = (speeds[2:] - 2.0 * speeds[1:-1] + speeds[:-2])[even]
    d2 = d2[np.isfinite(d2)]
    if d2.size < 10:
        return None
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))
