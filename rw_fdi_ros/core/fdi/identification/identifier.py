"""FaultIdentifier: the wheels sample by sample, each alarmed wheel's fault identified from its onset on (the
isolation node, the core loop and the offline tools)."""
from __future__ import annotations

from collections import deque
from dataclasses import replace

import numpy as np

from ...physics import wheel as wm
from ..calibration import PHYSICAL, UnitCalibration, regressors
from .decision import decide, decide_steps, decision_steps
from .families import noise_floors
from .onset import onset_index
from .result import Identification
from .sums import ProfileSums, add_pieces, sums_buffers


# steps of a wheel's identification per FDI sample where time is bounded (the isolation node, and the core loop and
# offline judge that answer as it does): pieces of 0.1-0.5 ms of this machine's at the record's sitting, a sample
# added in at most three of them (docs/benchmarks.md "Flight budget")
IDENTIFICATION_WORK = 8
# samples added to a wheel's sums, while more wait, before a decision is made on those so far: the samples kept before
# an alarm take a minute or two to add at this budget (all their ramps still growing), and the answer must not wait
DECIDE_EVERY = 25


class _Task:
    """A piece of a wheel's identification under way: its steps (a generator, or the lazy identifier's count of
    them) and what is done with what they return once the last is taken."""

    __slots__ = ("steps", "done")

    def __init__(self, steps, done):
        self.steps, self.done = steps, done

    def step(self) -> bool:
        """Take one step; True once it was the last (``done`` called)."""
        if isinstance(self.steps, int):
            self.steps -= 1
            if self.steps > 0:
                return False
            value = None
        else:
            try:
                next(self.steps)
                return False
            except StopIteration as end:
                value = end.value
        self.done(value)
        return True


class FaultIdentifier:
    """The wheels, sample by sample: identifies an alarmed wheel's fault on its samples from the fault's onset on
    (the isolation node, the core loop and the offline tools).

    The alarm comes after the onset (a window mean must cross the band, then the persistence): the
    seconds in between, while the controller moves the command, are what tells a current loss from a
    bus drop that clips to the same current. So the last ``BACKLOG`` samples before an alarm are kept,
    and at the alarm those after the onset the wheel's model error shows (:func:`onset_index`, the
    sample at the change itself left out: its period mean is part healthy) count too. A wheel held at
    one command and speed from its alarm on was answered 'unknown' in 7 % of current losses on varied
    units without them (tuning seeds 82,000,000+).

    With ``calibration_samples`` each wheel's unit is learnt from the first samples of the run as the
    model observer learns it (the same calibration.UnitCalibration on the nominal model's error), and
    a wheel's fault is identified on the unit known at its first alarm.

    With ``work`` the identification of a wheel takes at most that many steps a sample (the isolation node's
    budget per FDI period): a piece of a sample's addition to its sums (ProfileSums.add_steps) or of a decision
    (decision.decide_steps). A wheel's samples queue, a decision runs on the sums as they were when it began (the
    samples that come meanwhile wait) and its answer stands until the next one is done: the answer comes some
    samples later (a decision also every DECIDE_EVERY samples added while more wait: the samples kept before the
    alarm take minutes to add), and no period pays for a whole decision or for them at once. The
    number of steps depends on the counts and times alone, so the lazy identifier (the core loop's) keeps the
    same schedule without deciding, and answers what the last decision done would have. None: every sample is
    added and decided at once."""

    BACKLOG = 60   # FDI samples: the 40-sample window and the persistence the alarm lags by, and a margin
    def __init__(self, wheels=("x", "y", "z"), calibration_samples: int = 0, lazy: bool = False,
                 params: wm.WheelParams = wm.WheelParams(), work: int | None = None):
        self.wheels = tuple(wheels)
        self.params = params   # the wheel type: its viscous law, its calibration regressors, its rest
        self.floor, self.unpowered_floor = noise_floors(params)   # its torques' noise floors, driver on and off
        self.calibration_samples = int(calibration_samples)
        # lazy: decide only when asked (identifications()), for a reader that wants the last answer of a run
        # (the core loop's onboard verdict): the same answers, without the grid fits of every sample between
        self.lazy = bool(lazy)
        # more than a sample's addition takes (add_pieces), or the samples would queue without end
        self.work = None if work is None else max(int(work), add_pieces(0.0) + 1)
        # the live identifier's ramp sums made now, not at an alarm (sums_buffers); the lazy ones of a batch of runs
        # would hold hundreds of MB for wheels that are never alarmed
        self.buffers = None if self.lazy else {a: sums_buffers(self.calibration_samples > 0) for a in self.wheels}
        self.sums = {}
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
        for a, sums in self.sums.items():   # a buffer used is zeroed for the next fault
            if sums is not None and self.buffers is not None:
                for array in self.buffers[a].values():
                    array.fill(0.0)
        self.sums = {a: None for a in self.wheels}     # wheel -> ProfileSums once alarmed
        self.latest = {a: None for a in self.wheels}
        self.stale = set()   # lazy: wheels with a decision done whose answer is not made yet
        self.queue = {a: deque() for a in self.wheels}   # (row, time) not in the sums yet
        self.moved = set()   # wheels whose sums moved since their last decision began
        self.since = {a: 0 for a in self.wheels}   # samples added since the wheel's last decision began
        self.job = {a: None for a in self.wheels}     # wheel -> the _Task under way (a sample added, a decision)
        self.first = {a: None for a in self.wheels}   # [s] the time of the first sample of the wheel's sums
        self.held = {a: deque() for a in self.wheels}   # lazy: rows the schedule added, not yet in the sums
        self.pending = {a: None for a in self.wheels}   # lazy: the flags of the last decision done, not yet made
        self.unpowered = set()   # wheels whose driver went off (given up) after their alarm
        self.reported = {a: {} for a in self.wheels}   # kind -> the wheel's last reported bus voltage, temperature
        # (row, model error, calibration regressors, time) of the samples before an alarm
        self.backlog = {a: deque(maxlen=self.BACKLOG) for a in self.wheels}

    def update(self, sample, alarmed: dict) -> dict:
        """Take one FDI sample of every wheel; identify each alarmed wheel's fault on it.

        Parameters
        ----------
        sample : telemetry.FdiSample
            The sample, with the identification terms.
        alarmed : dict of str to bool
            Wheel -> whether the verdict names it at this sample.

        Returns
        -------
        dict of str to Identification or None
            Wheel -> its identification (None for a wheel never alarmed; a lazy identifier's may be stale:
            :meth:`identifications`).
        """
        stamp = getattr(sample, "stamp_ns", None)
        time = self.samples if stamp is None else 1e-9 * stamp     # [s] (1 s samples where it has no stamp)
        self.samples += 1
        for i, a in enumerate(self.wheels):
            self._note_reports(a, sample, i)
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
                                           self.params.viscous_scale, self.floor,
                                           None if self.buffers is None else self.buffers[a], self.unpowered_floor)
                self.latest[a] = Identification("unknown", samples=0)   # identifying
                self._add_since_onset(a, list(self.backlog[a]) + [(row, error, x, time)], calibration)
                self.backlog[a].clear()
            if not self._at_rest(a, sample, i):
                self.queue[a].append((row, time))
            self._work(a)
        return dict(self.latest)

    def _at_rest(self, a, sample, i) -> bool:
        """Whether the wheel's driver is off and it is at rest: its sample shows nothing (every family gives 0), and
        its fault's size is the one it had when last seen. Driver off, it spins down on its friction alone, which
        still shows a temperature (given up by FDIR)."""
        tcv = getattr(sample, "tcv", None)
        if tcv is None or float(tcv[i]) != 0.0:
            self.unpowered.discard(a)   # driven (again)
            return False
        self.unpowered.add(a)
        if abs(float(sample.wheel_speed[i])) >= 2.0 * self.params.coulomb_smoothing_speed:
            return False
        if self.latest[a] is not None and not self.latest[a].unpowered:
            self.latest[a] = replace(self.latest[a], unpowered=True)
        if self.pending[a] is not None:
            self.pending[a] = (self.pending[a][0], True)
        return True

    def identifications(self) -> dict:
        """What update returns, the lazy identifier's decided now.

        Returns
        -------
        dict of str to Identification or None
            Wheel -> the Identification of the samples so far (None for a wheel never alarmed).
        """
        for a in list(self.stale):
            self._resolve(a)
        return dict(self.latest)

    def _resolve(self, a):
        if a in self.stale:
            self.stale.discard(a)
            reported, unpowered = self.pending[a]
            self.pending[a] = None
            self.latest[a] = self._answer(decide(self.sums[a], reported), unpowered)

    def _work(self, a):
        """The wheel's identification of this sample: its queued samples added and decided at once, or with
        ``work`` that many steps (the class docstring)."""
        if self.work is None:
            while self.queue[a]:
                self._add(a, *self.queue[a].popleft())
            if a in self.moved:
                self.moved.discard(a)
                flags = self._flags(a)
                self._done(a, flags, None if self.lazy else decide(self.sums[a], flags[0]))
            return
        for _ in range(self.work):
            task = self.job[a]
            if task is None:
                if self.queue[a] and not (a in self.moved and self.since[a] >= DECIDE_EVERY):
                    task = self._adding(a, *self.queue[a].popleft())
                elif a in self.moved:
                    self.moved.discard(a)
                    self.since[a] = 0
                    task = self._deciding(a)
                else:
                    return
                self.job[a] = task
            if task.step():
                self.job[a] = None

    def _add(self, a, row, time):
        """One queued sample into the wheel's sums at once (without ``work``)."""
        self.sums[a].add(row, time)
        self.moved.add(a)

    def _adding(self, a, row, time) -> "_Task":
        """A queued sample's way into the sums, ProfileSums.add_steps' pieces (the lazy's held back until a decision
        done needs it, its pieces counted)."""
        self.first[a] = time if self.first[a] is None else self.first[a]

        def added(_):
            if self.lazy:
                self.held[a].append((row, time))
            self.moved.add(a)
            self.since[a] += 1
        steps = add_pieces(time - self.first[a]) if self.lazy else self.sums[a].add_steps(row, time)
        return _Task(steps, added)

    def _deciding(self, a) -> "_Task":
        """A decision on the wheel's sums as they are now (decide_steps; the lazy's steps counted, made when asked)."""
        sums, flags = self.sums[a], self._flags(a)
        n = sums.n + len(self.held[a])
        steps = decision_steps(sums) if self.lazy else decide_steps(sums, flags[0])
        return _Task(steps, lambda found: self._done(a, flags, found, n))

    def _flags(self, a) -> tuple:
        """What a decision beginning now takes beside the sums: the wheel's reports, whether its driver is off."""
        return dict(self.reported[a]), a in self.unpowered

    def _done(self, a, flags, found, n=None):
        """A decision done: its answer the wheel's latest (the lazy's made when asked, on the sums of its ``n``
        samples)."""
        if not self.lazy:
            self.latest[a] = self._answer(found, flags[1])
            return
        while self.held[a] and self.sums[a].n < n:
            self.sums[a].add(*self.held[a].popleft())
        self.pending[a] = flags
        self.stale.add(a)
    def _note_reports(self, a, sample, i):
        """The wheel's housekeeping at this sample (FdiSample.bus_voltage, .temperature), in its family's unit."""
        scale = {"bus_voltage": wm.NOMINAL.bus_voltage / self.params.bus_voltage, "temperature": 1.0}
        for kind, factor in scale.items():
            values = getattr(sample, kind, None)
            if values is not None and np.isfinite(values[i]):
                self.reported[a][kind] = float(values[i]) * factor   # the bus family is on the 8-V grid

    def _answer(self, found: Identification, unpowered: bool) -> Identification:
        """A decision's Identification in the wheel type's units, said unpowered where its driver was off."""
        bus, thesis_bus = self.params.bus_voltage, wm.NOMINAL.bus_voltage
        if bus != thesis_bus:   # the sums' bus family is on the 8-V grid; this wheel's is it scaled (bus_voltage_grid)
            # a size from the bus family: named, or the best guess of an 'unknown'
            scale = bus / thesis_bus if "bus_voltage" in (found.kind, found.best_guess) else 1.0
            found = replace(found, size=found.size * scale, low=found.low * scale, high=found.high * scale,
                            bus_nominal=bus)
        return replace(found, unpowered=True) if unpowered else found

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
        self.queue[a].extend((earlier, time) for earlier, _, _, time in past[onset + 1:-1])
