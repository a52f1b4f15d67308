"""What the identifier says of one wheel: the Identification type, its words (message) and its /diagnostics
key-values (values), and the one decoder that turns those key-values back into it (from_values).

Every reader of a recorded identification (a bag's /diagnostics or /fdi/identification, a run's record) goes
through :meth:`Identification.from_values`: the keys are known here only, and a name the identifier gave a
kind before it took the scenario's (FORMER_NAMES) reads as the kind's name now.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .families import CURRENT_LIMITER_GRID, TEMPERATURE_GRID, UNITS, UNKNOWN, bus_voltage_grid
from .ramps import RAMP_NOTED_S

MIN_SAMPLES = 5   # samples since the onset under which the identifier is still identifying (no kind yet)
# a kind's former name -> its name now (core/mission/scenario.FAULT_KINDS): bags recorded before say the former
FORMER_NAMES = {"current_loss": "current_limiter"}
# a kind as a person reads it in a message
SPOKEN = {"current_limiter": "current loss", "temperature": "temperature", "bus_voltage": "bus voltage"}
NONE = "none"   # the status of a wheel never alarmed says this kind (the isolation node's /fdi/identification)


def kind_name(kind: str) -> str:
    """The name now of a fault kind as recorded, a former name (FORMER_NAMES) or the one now.

    Parameters
    ----------
    kind : str
        A kind as a bag or a record says it.

    Returns
    -------
    str
        The kind's name now: one of KINDS, 'unknown', or ``kind`` unchanged where it is no former name.
    """
    return FORMER_NAMES.get(kind, kind)


def _number(v: float) -> str:
    """A float as values() writes it: 6 significant digits, 'nan' where not finite."""
    return "nan" if not np.isfinite(v) else f"{v:.6g}"


@dataclass
class Identification:
    """What the identifier says about one wheel at one FDI sample."""

    kind: str                    # one of KINDS (the scenario's names) or 'unknown'
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
    bus_nominal: float = 8.0     # [V] the wheel type's bus, where the bus family's grid starts (bus_voltage_grid)

    @property
    def bound_only(self) -> str:
        """'upper' / 'lower' when the interval reaches the grid's end (only a bound is observable)."""
        if self.kind == "bus_voltage" and self.low <= bus_voltage_grid(self.bus_nominal)[-1] + 1e-6:
            return "upper"
        if self.kind == "temperature" and self.high >= TEMPERATURE_GRID[-1]:
            return "lower"
        if self.kind == "current_limiter" and self.low <= CURRENT_LIMITER_GRID[-1]:
            return "upper"
        return ""

    def message(self) -> str:
        """One line a person reads at a glance.

        Returns
        -------
        str
            The line.
        """
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
                # 0: alarmed, its first decision under way (FaultIdentifier's work)
                return f"identifying ({self.samples} samples)" if self.samples else "identifying"
            if self.healthy:
                return "fits a healthy wheel: alarm not confirmed"
            guess = SPOKEN.get(self.best_guess, self.best_guess.replace("_", " "))
            if self.between:
                return (f"current loss or bus drop, its driven samples do not tell which (closest: {guess}, explains "
                        f"{100 * self.explained:.0f} %){why}")
            return f"unknown fault (closest: {guess}, explains {100 * self.explained:.0f} %){why}"
        head, digits = {"current_limiter": ("current loss, limiter", 2), "temperature": ("temperature", 0),
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
        """The /diagnostics key-values (strings); :meth:`from_values` reads them back.

        Returns
        -------
        dict of str to str
            fault_kind, fault_size, fault_size_low, fault_size_high (6 significant digits, 'nan'), fault_unit,
            fault_size_unit_limited, fault_growing ('true'/'false'), fault_ramp_s, fault_size_at_s [s] and
            fault_kind_between (the kinds joined by ' or ', else empty); fault_bus_nominal_v [V] on a wheel
            type whose bus is not the thesis' 8 V.
        """
        bus = {} if self.bus_nominal == 8.0 else {"fault_bus_nominal_v": _number(self.bus_nominal)}
        return bus | {"fault_kind": self.kind, "fault_size": _number(self.size), "fault_size_low": _number(self.low),
                "fault_size_high": _number(self.high), "fault_unit": self.unit,
                "fault_size_unit_limited": "true" if self.unit_limited else "false",
                "fault_growing": "true" if self.growing else "false", "fault_ramp_s": _number(self.ramp_s),
                "fault_size_at_s": _number(self.at_s), "fault_kind_between": " or ".join(self.between)}

    @classmethod
    def from_values(cls, values) -> Identification | None:
        """The Identification a status' key-values hold: the inverse of :meth:`values`, for every reader of a
        recorded identification.

        Kinds recorded under a former name (FORMER_NAMES) read as the name now; keys a bag recorded before they
        existed take their defaults; ``samples`` (the isolation node adds it on /fdi/identification) is read
        where present. What values() does not carry (explained, best_guess, rss, healthy, unpowered) keeps its
        default.

        Parameters
        ----------
        values : Mapping of str to str
            A status' key-values (DiagnosticStatus.values as a dict), other keys ignored.

        Returns
        -------
        Identification or None
            None where the status holds no identification (no ``fault_kind``, or 'none': a wheel never alarmed).
        """
        kind = values.get("fault_kind", NONE)
        if kind == NONE:
            return None

        def num(key, default=float("nan")):
            text = values.get(key, "")
            return float(text) if text else default
        between = values.get("fault_kind_between", "")
        return cls(kind_name(kind), num("fault_size"), num("fault_size_low"), num("fault_size_high"),
                   samples=int(values.get("samples", 0)), unit=values.get("fault_unit", "datasheet"),
                   unit_limited=values.get("fault_size_unit_limited") == "true",
                   growing=values.get("fault_growing") == "true", ramp_s=num("fault_ramp_s", 0.0),
                   at_s=num("fault_size_at_s"), bus_nominal=num("fault_bus_nominal_v", 8.0),
                   between=tuple(kind_name(k) for k in between.split(" or ")) if between else ())

    def brief(self) -> dict:
        """kind, size, size_low and size_high as :meth:`values` writes them (strings): a runs table's columns.

        Returns
        -------
        dict of str to str
            kind, size, size_low, size_high.
        """
        v = self.values()
        return {"kind": self.kind, **{k[len("fault_"):]: v[k] for k in ("fault_size", "fault_size_low",
                                                                        "fault_size_high")}}
