"""The threshold file: an observer's curves or bands with the conditions they were fitted under (JSON), read
with every check a graph needs before it judges with them."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .detection import METHODS, PERSISTENCE, PERSISTENCE_MAX, SIGMAS, WINDOW
from ..physics.wheel_set import fitted_for

class ThresholdError(ValueError):
    """Threshold curves that cannot be used; one line naming the file and the fix."""


REFIT = "regenerate with `rw-fdi fit-thresholds --bags DIR --out DIR` (or `rw-fdi defaults` for the shipped set)"


@dataclass
class ThresholdCurves:
    """Curves per observer and wheel, indexed by FDI sample, with the conditions they were fitted under."""

    observer: str
    curves: dict                     # wheel -> np.ndarray (samples,)
    sample_period: float = 1.0
    window: int = WINDOW
    sigmas: float = SIGMAS
    seeds: list = field(default_factory=list)
    plant: dict = field(default_factory=dict)   # emf_limit, control_period, ... of the fitting runs
    model: str = ""                  # the model card the residuals came from
    method: str = "thesis"           # 'thesis': time-indexed curves; 'speed_aware': constant bands c
    persistence: int = PERSISTENCE   # P the curves are meant for (the band's false-alarm rate needs it)
    false_alarm_rate: float | None = None   # designed per-run rate (speed_aware)
    calibration: dict = field(default_factory=dict)  # how the bands were fitted (speed_aware)
    unit_calibration_time: float = 0.0   # [s] of each run the observers learnt their wheel from (calibration.py)

    def at(self, wheel: str, k: int) -> float:
        """Threshold of ``wheel`` at FDI sample k. A wheel without a curve of its own (the redundant
        wheel off the body axes) gets the widest of its type's (wheel_set.fitted_for).

        Parameters
        ----------
        wheel : str
            The wheel's name.
        k : int
            The FDI sample's index.

        Returns
        -------
        float
            The threshold [N m].
        """
        # past the fitted horizon the last value holds
        return max(float(c[min(k, len(c) - 1)]) for c in (self.curves[a] for a in fitted_for(wheel, self.curves)))

    def save(self, path):
        """Write the curves and what they were fitted under as a JSON threshold file.

        Parameters
        ----------
        path : str or pathlib.Path
            The file.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps({
            "observer": self.observer, "sample_period": self.sample_period, "window": self.window,
            "sigmas": self.sigmas, "runs": len(self.seeds), "seeds": self.seeds, "plant": self.plant,
            "model": self.model, "method": self.method, "persistence": self.persistence,
            "false_alarm_rate": self.false_alarm_rate, "calibration": self.calibration,
            "unit_calibration_time": self.unit_calibration_time,
            "curves": {a: [float(v) for v in c] for a, c in self.curves.items()}}, indent=1))

    @classmethod
    def load(cls, path, observer: str | None = None) -> "ThresholdCurves":
        """The curves of ``path``; with ``observer``, refused unless fitted for that observer slot (a
        model observer's band on the Luenberger observer's residual would alarm on every run).

        Parameters
        ----------
        path : str or pathlib.Path
            The threshold file.
        observer : str or None
            The observer slot the curves must be fitted for.

        Returns
        -------
        ThresholdCurves
            The curves.
        """
        path = Path(path)
        if not path.is_file():
            raise ThresholdError(f"threshold file not found: {path}; {REFIT}")
        try:
            raw = json.loads(path.read_text())
            curves = {a: np.asarray(c, float) for a, c in raw["curves"].items()}
            out = cls(observer=raw["observer"], curves=curves, sample_period=float(raw["sample_period"]),
                      window=int(raw["window"]), sigmas=float(raw["sigmas"]), seeds=list(raw["seeds"]),
                      plant=dict(raw["plant"]), model=str(raw.get("model", "")),
                      method=str(raw.get("method", "thesis")), persistence=int(raw.get("persistence", PERSISTENCE)),
                      false_alarm_rate=raw.get("false_alarm_rate"), calibration=dict(raw.get("calibration") or {}),
                      unit_calibration_time=float(raw.get("unit_calibration_time", 0.0)))
        except (ValueError, KeyError, TypeError) as exc:
            raise ThresholdError(f"{path}: not a readable threshold file ({type(exc).__name__}: {exc}); "
                                 f"{REFIT}") from None
        # one curve per wheel fitted: the thesis' three axis wheels, or every wheel in use of another set
        if not out.curves or any(len(c) == 0 or not np.all(np.isfinite(c)) for c in out.curves.values()):
            raise ThresholdError(f"{path}: needs a finite curve for each wheel it was fitted for; {REFIT}")
        if out.method == "thesis" and set(out.curves) != {"x", "y", "z"}:
            raise ThresholdError(f"{path}: the thesis' curves are for axes x, y, z; {REFIT}")
        if observer is not None and out.observer != observer:
            raise ThresholdError(f"{path}: curves of the {out.observer} observer, not of the {observer} "
                                 f"observer; {REFIT}")
        if out.method not in METHODS:
            raise ThresholdError(f"{path}: unknown method {out.method!r} (known: {', '.join(METHODS)}); {REFIT}")
        if not 1 <= out.persistence <= PERSISTENCE_MAX:
            raise ThresholdError(f"{path}: persistence must lie in [1, {PERSISTENCE_MAX}], got {out.persistence}; "
                                 f"{REFIT}")
        # every number where it enters, the file named: a negated period or window failed later, nameless
        for name, value, ok, want in (
                ("sample_period", out.sample_period, 0.0 < out.sample_period <= 3600.0, "in (0, 3600] s"),
                ("window", out.window, 1 <= out.window <= PERSISTENCE_MAX, f"in [1, {PERSISTENCE_MAX}] samples"),
                ("unit_calibration_time", out.unit_calibration_time, 0.0 <= out.unit_calibration_time <= 1e6,
                 "in [0, 1e6] s"),
                ("false_alarm_rate", out.false_alarm_rate, out.false_alarm_rate is None
                 or 0.0 < float(out.false_alarm_rate) < 1.0, "in (0, 1)")):
            if not ok:
                raise ThresholdError(f"{path}: {name} must lie {want}, got {value!r}; {REFIT}")
        if out.method == "thesis":
            for a, c in out.curves.items():
                if np.any(c < 0):   # a threshold on a mean of |r - r^| below 0 alarms at once, for ever
                    raise ThresholdError(f"{path}: curve {a} has negative values (min {c.min():.3g} at sample "
                                         f"{int(c.argmin())}); a threshold on |r - r^| is >= 0; {REFIT}")
        return out

    @property
    def horizon(self) -> float:
        """[s] up to which the curves say what the fault-free residual is: time-indexed (thesis) curves
        end at their last sample, a speed-aware band holds for any time."""
        if self.method != "thesis":
            return float("inf")
        return (min(len(c) for c in self.curves.values()) - 1) * self.sample_period

    def check_horizon(self, duration: float, origin: str = "thresholds"):
        """Refuse curves that end before the run does: past its last sample a time-indexed curve
        would hold a value fitted for another moment, and the observer could not judge (a 3-sample
        curve held its start-up peak and hid a 40 % current loss).

        Parameters
        ----------
        duration : float
            The run's duration [s].
        origin : str
            Where the curves come from, for the error.
        """
        if self.horizon < float(duration):
            raise ThresholdError(f"{origin}: the curves cover 0-{self.horizon:g} s but the run lasts "
                                 f"{float(duration):g} s; fit them on runs at least as long; {REFIT}")

    def check_method(self, method: str, origin: str = "thresholds"):
        """Refuse curves of another FDI method than the running graph's.

        Parameters
        ----------
        method : str
            The graph's FDI method.
        origin : str
            Where the curves come from, for the error.
        """
        if self.method != method:
            raise ThresholdError(f"{origin}: fitted for fdi_method={self.method!r} but the graph runs "
                                 f"fdi_method={method!r}; {REFIT}")

    def check_unit_calibration(self, seconds: float, origin: str = "thresholds"):
        """Refuse bands fitted with another unit calibration than the running observers': a calibrated
        observer's bound holds its correction's uncertainty, so the bands of one do not fit the other.

        Parameters
        ----------
        seconds : float
            The observers' unit calibration time [s].
        origin : str
            Where the curves come from, for the error.
        """
        if abs(float(seconds) - self.unit_calibration_time) > 1e-9:
            raise ThresholdError(f"{origin}: fitted with unit_calibration_time={self.unit_calibration_time:g} s but "
                                 f"the observers run unit_calibration_time={float(seconds):g} s; fit bands for it "
                                 f"with `rw-fdi fit-thresholds --simulate fault_free_units --unit-calibration "
                                 f"{float(seconds):g} --out DIR`, then pass `--thresholds DIR`")

    def check_compatible(self, plant, origin: str = "thresholds"):
        """Refuse curves fitted under other plant choices than the running graph's.

        ``plant``: the running :class:`PlantChoices`, or a mapping of the choices to check. A
        choice the file does not record was fitted under its legacy value (plant_choices.LEGACY).

        Parameters
        ----------
        plant : PlantChoices or dict
            The running choices, or a mapping of the choices to check.
        origin : str
            Where the curves come from, for the error.
        """
        from ..mission.plant_choices import PlantChoices
        fitted = PlantChoices.from_recorded(self.plant)
        if isinstance(plant, dict):
            keys, running = list(plant), PlantChoices(**{**fitted.as_dict(), **plant})
        else:
            keys, running = None, plant
        for key, was, now in running.differences(fitted, keys):
            raise ThresholdError(f"{origin}: fitted with {key}={was!r} but the graph runs {key}={now!r}; {REFIT}")
