"""A user's observer as a plug-in: the interface it implements and how it is found (docs/observers.md).

An observer estimates each wheel's reaction torque r^ once per FDI sample; the FDI
makes its residual (the signed 40-sample mean of r - r^ with the ripple bound,
residuals.SignedResidual), learns each wheel's unit on top of it when the run
calibrates (calibration.py), fits its band (threshold_fit.py) and alarms on it, as
for the three observers of ours. A plug-in is named on the command line
(``--observer SPEC``) by

* an entry point of the group ``rw_fdi_ros.observers`` (``kalman = my_pkg.kalman:KalmanObserver``), or
* a dotted path ``my_pkg.kalman:KalmanObserver`` (or ``my_pkg.kalman.KalmanObserver``), or
* a file ``path/to/kalman.py:KalmanObserver``.

Its files (its trained ``state`` and its bands) live in the FDI directory as ours do:
``observer_<slot>.json`` (data, never a pickle) and ``thresholds_<slot>.json``.
"""
from __future__ import annotations

import copy
import importlib
import importlib.util
import json
import re
import sys
from pathlib import Path

import numpy as np

ENTRY_POINT_GROUP = "rw_fdi_ros.observers"
BUILTIN_SLOTS = ("elman", "linear", "model")
RESERVED_SLOTS = (*BUILTIN_SLOTS, "verdict", "identification", "telemetry", "wheels")
_SLOT = re.compile(r"^[a-z][a-z0-9_]{0,31}$")


class ObserverError(ValueError):
    """A plug-in that cannot be found, loaded or run: one line naming it."""


class WheelObserver:
    """The base of a plug-in observer: r^ of every wheel of the set, one FDI sample at a time.

    Subclass it, set ``slot`` and implement :meth:`estimate`; the rest is optional.

    Attributes
    ----------
    slot : str
        Its name: topics ``/fdi/<slot>/...``, files ``thresholds_<slot>.json``, report columns. Lower-case
        letters, digits and '_', not one of ours (elman, linear, model).
    description : str
        One line for the threshold file and the docs.
    wheels : tuple of str
        The wheels of the set, in the order of every (N,) field of a sample (x, y, z, s by default).
    fdi_period : float
        The FDI sample period T [s].
    state : dict
        What :meth:`train` returned, as loaded from ``observer_<slot>.json`` ({} untrained).
    """

    slot = ""
    description = ""

    def __init__(self, wheels, fdi_period: float = 1.0, state: dict | None = None):
        self.wheels = tuple(wheels)
        self.fdi_period = float(fdi_period)
        self.state = copy.deepcopy(dict(state or {}))   # each run its own: a plug-in may change it
        self.reset()

    def reset(self) -> None:
        """Forget the run so far (a new run starts: a bag replay feeds many through one node)."""

    def estimate(self, sample) -> np.ndarray:
        """r^_k [N m] of every wheel for one FDI sample.

        Parameters
        ----------
        sample : core.telemetry.FdiSample
            The period means of the wheels' telemetry, every field (N,): ``tcv`` u [V], ``reaction_torque``
            r [N m], ``wheel_speed`` Omega [rad/s], ``model_torque`` (the nominal Bialke model at u and
            Omega) [N m], ``motor_torque``, ``friction_torque`` [N m], ``ripple_phasor`` (complex) [N m];
            ``stamp_ns`` its time [ns].

        Returns
        -------
        array_like, shape (N,)
            The estimate of each wheel's reaction torque [N m]. An estimate made before r_k is seen is a
            prediction, and its residual shows a fault at once; one that follows r_k absorbs it.
        """
        raise NotImplementedError

    def calibrate(self, sample) -> None:
        """Called before :meth:`estimate` on each sample of a run's unit calibration (its first
        ``unit_calibration`` seconds, the wheels assumed healthy). The FDI's own calibration already learns
        each wheel's unit from the residual (calibration.py); an observer that learns more of its own does
        it here.

        Parameters
        ----------
        sample : FdiSample
            The FDI sample.
        """

    def uncertainty_gain(self, wheel: str) -> float:
        """kappa of ``wheel``: the share of the torque demand mean(|r|) the observer's own model error may
        reach unfaulted, added to the residual's bound (residuals.SignedResidual; 0: an exact model). By
        default ``state['uncertainty_gain'][wheel]`` when :meth:`train` measured one, else 0.

        Parameters
        ----------
        wheel : str
            The wheel's name.

        Returns
        -------
        float
            kappa [-].
        """
        return float(self.state.get("uncertainty_gain", {}).get(wheel, 0.0))

    @classmethod
    def train(cls, runs, wheels, fdi_period: float) -> dict | None:
        """Optional: learn from fault-free runs; the dict returned (JSON data: numbers, lists, strings) is
        saved as ``observer_<slot>.json`` and given back as ``state``. None: nothing to learn.

        Parameters
        ----------
        runs : list of FdiSamples
            Each run's FDI samples: arrays ``time`` (n,), ``tcv``, ``reaction_torque``, ``wheel_speed``,
            ``model_torque`` (n, N), ...; ``rows()`` gives them one FdiSample at a time, as
            :meth:`estimate` sees them.
        wheels : tuple of str
            The wheel set's names (the columns).
        fdi_period : float
            T [s].

        Returns
        -------
        dict or None
            The state (JSON data); None: nothing learnt.
        """
        return None


def _hook(observer: WheelObserver, hook: str, *args):
    """``observer.hook(*args)``, anything it raises one ObserverError naming the plug-in (the node, the offline
    tools and the core loop all say it in one line)."""
    try:
        return getattr(observer, hook)(*args)
    except ObserverError:
        raise
    except SystemExit as exc:   # sys.exit() in a user's code must not end the run as if it had finished
        raise ObserverError(f"observer {observer.slot}: {hook}() called sys.exit({exc.code!r})") from None
    except Exception as exc:   # noqa: BLE001 -- a user's code: whatever it raises is said, naming it
        raise ObserverError(f"observer {observer.slot}: {hook}() raised {type(exc).__name__}: {exc}") from exc


def step(observer: WheelObserver, sample, calibrating: bool) -> np.ndarray:
    """One FDI sample through ``observer``: its calibration hook while ``calibrating``, then its estimate,
    checked to hold one real number per wheel (ObserverError otherwise). A non-finite value passes: the
    observer is blind on that wheel for that sample, which its residual says (residuals.SignedResidual).

    Parameters
    ----------
    observer : WheelObserver
        The user's observer.
    sample : FdiSample
        The FDI sample.
    calibrating : bool
        Whether the sample is one of the unit calibration's.

    Returns
    -------
    numpy.ndarray
        (N,) r^ [N m].
    """
    if calibrating:
        _hook(observer, "calibrate", sample)
    raw = _hook(observer, "estimate", sample)
    try:
        estimate = np.asarray(raw)
        if np.iscomplexobj(estimate):
            raise TypeError("complex values")
        estimate = estimate.astype(float).reshape(-1)
    except (TypeError, ValueError) as exc:
        shown = repr(raw)
        raise ObserverError(f"observer {observer.slot}: estimate() must give real numbers [N m], one per wheel; "
                            f"got {shown[:60]}{'...' if len(shown) > 60 else ''} ({exc})") from None
    if estimate.shape != (len(observer.wheels),):
        raise ObserverError(f"observer {observer.slot}: estimate() gave {estimate.size} values for "
                            f"{len(observer.wheels)} wheels ({', '.join(observer.wheels)})")
    return estimate


class PluginRun:
    """One run through a plug-in, as the plug-in node, the offline tools and the core loop all run it: a new
    instance of ``cls`` (its own copy of ``state``) whose first ``calibration_samples`` samples also go to its
    calibration hook (:func:`step`).

    Parameters
    ----------
    cls : type
        The WheelObserver subclass.
    wheels : sequence of str
        The wheel set's names.
    fdi_period : float
        T [s].
    state : dict, optional
        Its trained state (:func:`load_state`).
    calibration_samples : int
        The run's unit-calibration samples (0: none).
    """

    def __init__(self, cls: type, wheels, fdi_period: float, state: dict | None = None,
                 calibration_samples: int = 0):
        try:
            self.observer = cls(wheels, fdi_period, state)
        except ObserverError:
            raise
        except Exception as exc:   # noqa: BLE001 -- a user's code
            raise ObserverError(f"observer {cls.slot}: __init__() raised {type(exc).__name__}: {exc}") from exc
        self.calibration_samples = int(calibration_samples)
        self.seen = 0

    def uncertainty_gains(self) -> list:
        """kappa of each wheel (:meth:`WheelObserver.uncertainty_gain`).

        Returns
        -------
        list of float
            kappa, in the wheels' order.
        """
        return [float(_hook(self.observer, "uncertainty_gain", a)) for a in self.observer.wheels]

    def step(self, sample) -> np.ndarray:
        """r^_k (N,) of the run's next FDI sample.

        Parameters
        ----------
        sample : FdiSample
            The FDI sample.

        Returns
        -------
        numpy.ndarray
            (N,) r^_k [N m].
        """
        calibrating = self.seen < self.calibration_samples
        self.seen += 1
        return step(self.observer, sample, calibrating)

    def series(self, samples) -> np.ndarray:
        """r^ (n, N) of a whole run (FdiSamples), from its first sample.

        Parameters
        ----------
        samples : FdiSamples
            The run's FDI samples.

        Returns
        -------
        numpy.ndarray
            (n, N) r^ [N m].
        """
        rows = [self.step(row) for row in samples.rows()]
        return np.array(rows).reshape(len(samples.time), len(self.observer.wheels))


def _entry_points() -> dict:
    from importlib.metadata import entry_points
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def _from_file(path: Path, attr: str):
    name = f"rw_fdi_ros_observer_{re.sub(r'[^0-9a-zA-Z_]', '_', str(path.resolve()))}"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module   # dataclasses and pickling look their module up by name
        spec.loader.exec_module(module)
    return getattr(sys.modules[name], attr)


def load_observer(spec: str) -> type:
    """The WheelObserver class ``spec`` names: an entry point of ENTRY_POINT_GROUP, ``module:Class``,
    ``module.Class`` or ``file.py:Class``; ObserverError (one line) for one that cannot be found or is not an
    observer.

    Parameters
    ----------
    spec : str
        What the user wrote after ``--observer``.

    Returns
    -------
    type
        The class, its ``slot`` checked.
    """
    spec = str(spec).strip()
    found = _entry_points()
    try:
        if spec in found:
            cls = found[spec].load()
        elif ":" in spec or "." in spec:
            where, _, attr = spec.rpartition(":") if ":" in spec else spec.rpartition(".")
            if where.endswith(".py"):
                if not Path(where).is_file():
                    raise ObserverError(f"observer {spec}: no file {where}")
                cls = _from_file(Path(where), attr)
            else:
                cls = getattr(importlib.import_module(where), attr)
        else:
            known = ", ".join(sorted(found)) or "none installed"
            raise ObserverError(f"observer {spec!r}: not an entry point of {ENTRY_POINT_GROUP} ({known}) nor "
                                "module:Class or file.py:Class")
    except ObserverError:
        raise
    except Exception as exc:   # noqa: BLE001 -- importing a user's module runs its code: whatever it raises
        raise ObserverError(f"observer {spec}: cannot load it ({type(exc).__name__}: {exc})") from None
    if not (isinstance(cls, type) and issubclass(cls, WheelObserver)):
        raise ObserverError(f"observer {spec}: {cls!r} is not a subclass of rw_fdi_ros.core.fdi.observer_plugin."
                            "WheelObserver")
    if not is_plugin_slot(cls.slot or ""):
        raise ObserverError(f"observer {spec}: its slot {cls.slot!r} must be lower-case letters, digits and '_' "
                            f"(at most 32), not one of {', '.join(RESERVED_SLOTS)}")
    return cls


def is_plugin_slot(slot: str) -> bool:
    """Whether ``slot`` may name a plug-in: lower-case letters, digits and '_' (at most 32), none of ours.

    Parameters
    ----------
    slot : str
        The slot's name.

    Returns
    -------
    bool
        Whether it may.
    """
    return bool(_SLOT.match(slot)) and slot not in RESERVED_SLOTS


def absolute_spec(spec: str) -> str:
    """``spec`` with a file's path made absolute (a node process may start elsewhere); others unchanged.

    Parameters
    ----------
    spec : str
        'path/file.py:Class' or 'module:Class'.

    Returns
    -------
    str
        The spec.
    """
    where, sep, attr = str(spec).rpartition(":")
    return f"{Path(where).resolve()}:{attr}" if sep and where.endswith(".py") else str(spec)


def state_path(directory, slot: str) -> Path:
    """Where a plug-in's trained state lies in an FDI directory.

    Parameters
    ----------
    directory : str or pathlib.Path
        The FDI directory.
    slot : str
        The plug-in's slot.

    Returns
    -------
    pathlib.Path
        ``observer_<slot>.json`` in it.
    """
    return Path(directory) / f"observer_{slot}.json"


def save_state(directory, cls: type, spec: str, state: dict, seeds=()) -> Path:
    """``state`` (:meth:`WheelObserver.train`'s) as ``observer_<slot>.json`` in ``directory``, with what made it.

    Parameters
    ----------
    directory : str or pathlib.Path
        The FDI directory.
    cls : type
        The observer's class (its ``slot``).
    spec : str
        Where the class comes from.
    state : dict
        The trained state (JSON data).
    seeds : iterable of int
        The seeds of the runs it was trained on.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = state_path(directory, cls.slot)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        text = json.dumps({"slot": cls.slot, "observer": spec, "seeds": [int(s) for s in seeds if s is not None],
                           "state": state}, indent=1)
    except TypeError as exc:
        raise ObserverError(f"observer {spec}: train() must return JSON data (numbers, lists, strings): {exc}") \
            from None
    path.write_text(text + "\n")
    return path


def find_state(directories, slot: str) -> Path | None:
    """``observer_<slot>.json`` in the first of ``directories`` that holds one (None: none does).

    Parameters
    ----------
    directories : iterable of str or pathlib.Path
        The FDI directories, first searched first.
    slot : str
        The plug-in's slot.

    Returns
    -------
    pathlib.Path or None
        The file.
    """
    return next((state_path(d, slot) for d in directories if state_path(d, slot).is_file()), None)


def read_state(path, slot: str) -> dict:
    """The trained state in the file ``path``, checked to be the state of ``slot`` (ObserverError, one line).

    Parameters
    ----------
    path : str or pathlib.Path
        The state file.
    slot : str
        The plug-in's slot.

    Returns
    -------
    dict
        The state.
    """
    try:
        data = json.loads(Path(path).read_text())
        if not isinstance(data, dict) or data.get("slot") != slot or not isinstance(data.get("state"), dict):
            raise ValueError(f"not the state of observer {slot}")
    except (ValueError, OSError) as exc:
        raise ObserverError(f"{path}: unreadable ({exc})") from None
    return data["state"]


def load_state(directories, slot: str) -> dict:
    """The state of ``slot`` from the first of ``directories`` holding ``observer_<slot>.json`` ({}: none).

    Parameters
    ----------
    directories : iterable of str or pathlib.Path
        The FDI directories, first searched first.
    slot : str
        The plug-in's slot.

    Returns
    -------
    dict
        The state.
    """
    path = find_state(directories, slot)
    return {} if path is None else read_state(path, slot)


def trains(cls: type) -> bool:
    """Whether ``cls`` has a training hook of its own (an untrained one cannot run).

    Returns
    -------
    bool
        Whether it overrides :meth:`WheelObserver.train`.
    """
    return getattr(cls.train, "__func__", None) is not getattr(WheelObserver.train, "__func__", None)


class ObserverModels(dict):
    """What the observers of an FDI are made of, as the offline tools take it: the Elman networks by wheel
    (the dict itself, as before plug-ins) and ``plugins``, ((WheelObserver class, state), ...)."""

    def __init__(self, networks=(), plugins=()):
        super().__init__(networks)
        self.plugins = tuple(plugins)

    def __reduce__(self):   # to worker processes: the networks and the plug-ins, not the dict's items alone
        return (type(self), (dict(self), self.plugins))

