"""Elman recurrent network NN(2x25x1) as a reaction-wheel observer (thesis 4.3), numpy only.

    h_k = tanh(W_ih x_k + W_hh h_{k-1} + b_h)        (context layer = h_{k-1})
    y_k = tanh(W_ho h_k + b_o)                         (eq. 4.10 on both layers)
    x_k = [u_k / u_scale, r_{k-1} / r_scale]                       thesis, NN(2x25x1)
    x_k = [u_k / u_scale, r_{k-1} / r_scale, Omega_k / w_scale]    speed-aware, NN(3x25x1)

The speed-aware network also sees the measured wheel speed Omega: the holding
command of a healthy wheel varies by ~0.7 V over 20-30 rad/s (friction), so
without it a healthy fast wheel and a faulty slow one look alike.

u is the torque command voltage, r the reaction torque. In training mode
r_{k-1} is the measured torque (thesis Fig. 4.9); in recall mode it is the
network's own previous output (Fig. 4.8), so the network keeps modelling a
healthy wheel when the real one turns faulty. The live node runs recall
mode with this code; training (tools/design/train.py) uses torch with the same
equations, and a test proves both agree.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..physics.wheel_set import AXIS_WHEELS, fitted_for

HIDDEN = 25
INPUTS = 2
# A speed-aware network starts from its steady state for its first input (the wheel was held
# before t = 0): this many steps at that input, from a zero state, feeding back its own output.
# From a zero state its first outputs were off by up to 2.4e-3 N m on a wheel that barely moved,
# which the window mean carried for 40 s (a false alarm at t = 3 s). Training does the same.
SETTLE_STEPS = 50
# a grey box's learnt speeds (speed_coverage): 100 bins over +-speed_scale (2 % of its range each), a bin learnt
# where its training held 30 samples (30 s)
COVERAGE_BINS = 100
COVERAGE_MIN = 30


class ModelError(ValueError):
    """A model file that cannot be used; one line naming the file and how to regenerate it."""


REGENERATE = "regenerate with `rw-fdi train --bags DIR --out DIR` (or `rw-fdi defaults` for the shipped set)"
MODEL_SET = "model_set.json"   # a model directory's card: how it was trained, and which wheels have a network


def network_wheels(models_dir) -> tuple:
    """The wheels a model directory has networks for, in order: its card's ``wheels`` (one network per wheel
    in use of the set it was trained on); a set without them (trained before): x, y, z.

    Parameters
    ----------
    models_dir : str or pathlib.Path
        The model directory.

    Returns
    -------
    tuple of str
        The wheels' names.
    """
    path = Path(models_dir) / MODEL_SET
    try:
        wheels = json.loads(path.read_text()).get("wheels") if path.is_file() else None
    except (OSError, ValueError):
        raise ModelError(f"{path}: not a readable model card; {REGENERATE}") from None
    return tuple(wheels) if wheels else AXIS_WHEELS


def network_wheel(wheel: str, fitted=AXIS_WHEELS) -> str:
    """Whose network a wheel runs (wheel_set.fitted_for): its own where it was trained for, else the first
    of the set's (a redundant wheel, of the same type, out of use while the networks were trained).

    Parameters
    ----------
    wheel : str
        The wheel's name in its set.
    fitted : iterable of str
        The wheels the model set has networks for (:func:`network_wheels`).

    Returns
    -------
    str
        The wheel whose network it runs.
    """
    return fitted_for(wheel, fitted)[0]


def network_path(models_dir, wheel: str) -> Path:
    """The network file ``wheel`` runs in ``models_dir``: ``elman_<network_wheel>.npz``.

    Parameters
    ----------
    models_dir : str or pathlib.Path
        The model directory.
    wheel : str
        The wheel's name.

    Returns
    -------
    pathlib.Path
        The network file.
    """
    return Path(models_dir) / f"elman_{network_wheel(wheel, network_wheels(models_dir))}.npz"


@dataclass
class ElmanWeights:
    w_ih: np.ndarray   # (H, 2)
    w_hh: np.ndarray   # (H, H)
    b_h: np.ndarray    # (H,)
    w_ho: np.ndarray   # (1, H)
    b_o: np.ndarray    # (1,)
    tcv_scale: float = 5.0      # [V] normalises u into [-1, 1] (the +-5 V command range)
    torque_scale: float = 0.03  # [N m] normalises r into [-1, 1] (largest |r| in training)
    speed_scale: float = 0.0    # [rad/s] normalises Omega; 0: no speed input (the thesis' network)
    # kappa: the network's fault-free error bound per unit of mean |r| (residuals.SignedResidual)
    uncertainty_gain: float = 0.0
    # True: the network learnt the nominal wheel model's error r - r_model, and its estimate is r_model plus its
    # output (a grey box, tools/design/service_training.py); False: it learnt r itself (the thesis')
    model_error: bool = False
    # a grey box's learnt speeds: bins of COVERAGE_BINS over [-speed_scale, speed_scale], True where its training
    # held COVERAGE_MIN samples; outside them its estimate is r_model alone (None: every speed, as before)
    speed_coverage: np.ndarray | None = None

    def covers(self, wheel_speed: float) -> bool:
        """Whether a grey box learnt the model's error at this wheel speed (:func:`speed_coverage`).

        Parameters
        ----------
        wheel_speed : float
            Omega [rad/s].

        Returns
        -------
        bool
            True where its training had the speed, or where it records no coverage.
        """
        if self.speed_coverage is None or not self.model_error:
            return True
        k = int(np.floor((wheel_speed / self.speed_scale + 1.0) * 0.5 * COVERAGE_BINS))
        return 0 <= k < COVERAGE_BINS and bool(self.speed_coverage[k])

    @property
    def inputs(self) -> int:
        return INPUTS + (self.speed_scale > 0)

    @property
    def speed_aware(self) -> bool:
        return self.speed_scale > 0

    def validate(self, origin="weights"):
        """Check shapes, finiteness and scales (ModelError naming what is wrong otherwise).

        Parameters
        ----------
        origin : str
            Where the weights come from, for the error.

        Returns
        -------
        ElmanWeights
            ``self``.
        """
        h = self.w_hh.shape[0]
        if not (np.isfinite(self.speed_scale) and self.speed_scale >= 0):
            raise ModelError(f"{origin}: speed_scale must be >= 0; {REGENERATE}")
        if not (np.isfinite(self.uncertainty_gain) and 0 <= self.uncertainty_gain < 10):
            raise ModelError(f"{origin}: uncertainty_gain must lie in [0, 10); {REGENERATE}")
        shapes = {"w_ih": (h, self.inputs), "w_hh": (h, h), "b_h": (h,), "w_ho": (1, h), "b_o": (1,)}
        for name, shape in shapes.items():
            got = getattr(self, name).shape
            if got != shape:
                raise ModelError(f"{origin}: {name} has shape {got}, expected {shape}; {REGENERATE}")
            if not np.all(np.isfinite(getattr(self, name))):
                raise ModelError(f"{origin}: {name} holds non-finite values; {REGENERATE}")
        if not (self.tcv_scale > 0 and self.torque_scale > 0):
            raise ModelError(f"{origin}: normalisation scales must be positive; {REGENERATE}")
        if self.model_error and not self.speed_aware:
            raise ModelError(f"{origin}: a network of the model's error needs the speed input; {REGENERATE}")
        if self.speed_coverage is not None and np.shape(self.speed_coverage) != (COVERAGE_BINS,):
            raise ModelError(f"{origin}: speed_coverage must hold {COVERAGE_BINS} bins; {REGENERATE}")
        return self

    def save(self, path, card: dict | None = None):
        """npz of arrays (never a pickle) plus a JSON card beside it.

        Parameters
        ----------
        path : str or pathlib.Path
            The npz file.
        card : dict or None
            The model card, written as JSON beside it.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, w_ih=self.w_ih, w_hh=self.w_hh, b_h=self.b_h, w_ho=self.w_ho, b_o=self.b_o,
                 tcv_scale=np.array(self.tcv_scale), torque_scale=np.array(self.torque_scale),
                 speed_scale=np.array(self.speed_scale), uncertainty_gain=np.array(self.uncertainty_gain),
                 model_error=np.array(bool(self.model_error)),
                 **({} if self.speed_coverage is None else {"speed_coverage": np.asarray(self.speed_coverage, bool)}))
        if card is not None:
            path.with_suffix(".json").write_text(json.dumps(card, indent=2))

    @classmethod
    def load(cls, path) -> "ElmanWeights":
        """The weights of an npz file (:meth:`save`), validated; ModelError (one line) for a missing or damaged one.

        Parameters
        ----------
        path : str or pathlib.Path
            The npz file.

        Returns
        -------
        ElmanWeights
            The weights.
        """
        path = Path(path)
        if not path.is_file():
            raise ModelError(f"model file not found: {path}; {REGENERATE}")
        try:
            with np.load(path, allow_pickle=False) as z:
                w = cls(**{k: z[k] for k in ("w_ih", "w_hh", "b_h", "w_ho", "b_o")},
                        tcv_scale=float(z["tcv_scale"]), torque_scale=float(z["torque_scale"]),
                        speed_scale=float(z["speed_scale"]) if "speed_scale" in z.files else 0.0,
                        uncertainty_gain=float(z["uncertainty_gain"]) if "uncertainty_gain" in z.files else 0.0,
                        model_error=bool(z["model_error"]) if "model_error" in z.files else False,
                        speed_coverage=np.asarray(z["speed_coverage"], bool) if "speed_coverage" in z.files else None)
        except ModelError:
            raise
        except Exception as exc:  # zip/npz damage, missing arrays, pickled content
            raise ModelError(f"{path}: not a readable Elman model ({type(exc).__name__}); {REGENERATE}") from None
        return w.validate(str(path))

    @classmethod
    def random(cls, rng: np.random.Generator, hidden=HIDDEN, scale=0.1, **kw) -> "ElmanWeights":
        """Thesis 4.3.3 initialisation range [-0.1, 0.1].

        Parameters
        ----------
        rng : numpy.random.Generator
            The random stream.
        hidden : int
            Hidden units.
        scale : float
            Half-width of the uniform range.
        **kw
            The other fields (scales, uncertainty_gain, model_error); ``speed_scale`` > 0 adds the speed input.

        Returns
        -------
        ElmanWeights
            The weights.
        """
        def u(*s):
            return rng.uniform(-scale, scale, s)
        inputs = INPUTS + (kw.get("speed_scale", 0.0) > 0)
        return cls(u(hidden, inputs), u(hidden, hidden), u(hidden), u(1, hidden), u(1), **kw)


class ElmanObserver:
    """Recall-mode Elman network for one wheel: feed (u_k), get r^_k; state carried between calls."""

    def __init__(self, weights: ElmanWeights):
        self.w = weights
        self.hidden = np.zeros(weights.w_hh.shape[0])
        self.previous = None  # last output, normalised
        self.settled = not weights.speed_aware   # see SETTLE_STEPS

    def reset(self, reaction_torque: float = 0.0):
        """Start afresh: hidden state cleared, the fed-back output set to ``reaction_torque``.

        Parameters
        ----------
        reaction_torque : float
            The reaction torque r to start from [N m].
        """
        self.hidden[:] = 0.0
        self.previous = reaction_torque / self.w.torque_scale
        self.settled = not self.w.speed_aware

    def update(self, tcv: float, reaction_torque: float | None = None, wheel_speed: float | None = None) -> float:
        """One FDI sample. ``reaction_torque`` (measured, previous sample) is used only in
        training mode; recall mode passes None and feeds back its own estimate.
        ``wheel_speed`` is required by a speed-aware network and ignored by the thesis' one.

        Parameters
        ----------
        tcv : float
            Torque command voltage u_k [V].
        reaction_torque : float or None
            Measured reaction torque r of the previous sample [N m] (training); None in recall.
        wheel_speed : float or None
            Wheel speed Omega [rad/s].

        Returns
        -------
        float
            r^_k [N m].
        """
        w = self.w
        if self.previous is None:
            self.previous = 0.0
        if w.speed_aware and wheel_speed is None:
            raise ValueError("a speed-aware Elman network needs the wheel speed")
        if not self.settled:
            for _ in range(SETTLE_STEPS):
                self._step(tcv, None, wheel_speed)
            self.settled = True
        out = self._step(tcv, reaction_torque, wheel_speed) * w.torque_scale
        # a grey box beyond the speeds it learnt adds nothing to the model: its state runs on, its guess is not used
        return out if w.covers(wheel_speed) else 0.0

    def _step(self, tcv, reaction_torque, wheel_speed) -> float:
        w = self.w
        fed = self.previous if reaction_torque is None else reaction_torque / w.torque_scale
        drive = w.w_ih[:, 0] * (tcv / w.tcv_scale) + w.w_ih[:, 1] * fed
        if w.speed_aware:
            drive = drive + w.w_ih[:, 2] * (wheel_speed / w.speed_scale)
        self.hidden = np.tanh(drive + w.w_hh @ self.hidden + w.b_h)
        self.previous = float(np.tanh(w.w_ho[0] @ self.hidden + w.b_o[0]))
        return self.previous


class WheelRecall:
    """One wheel's network as the Elman node runs it: while the wheel stands by (:func:`standby`) its estimate is
    the measured torque; from its first running sample on, recall started at that sample's torque. A network
    of the model's error (ElmanWeights.model_error) adds the nominal model's torque r_model to its output."""

    def __init__(self, weights: ElmanWeights):
        self.observer = ElmanObserver(weights)
        self.started = False

    def update(self, tcv: float, reaction_torque: float, wheel_speed: float | None = None,
               model_torque: float | None = None) -> float:
        """r^ of one FDI sample (u, the measured r, Omega for a speed-aware network, r_model for one of the
        model's error) [N m].

        Parameters
        ----------
        tcv : float
            Torque command voltage u [V].
        reaction_torque : float
            Measured reaction torque r [N m].
        wheel_speed : float or None
            Wheel speed Omega [rad/s] (speed-aware network).
        model_torque : float or None
            The nominal model's reaction torque r_model [N m] (network of the model's error).

        Returns
        -------
        float
            r^ [N m].
        """
        base = 0.0
        if self.observer.w.model_error:
            if model_torque is None:
                raise ValueError("a network of the model's error needs the nominal model's torque")
            base = float(model_torque)
        if not self.started and standby(tcv, reaction_torque):
            return float(reaction_torque)
        if not self.started:
            self.observer.reset(float(reaction_torque) - base)
            self.started = True
        return base + self.observer.update(float(tcv), None, None if wheel_speed is None else float(wheel_speed))


def standby(tcv, reaction_torque) -> bool:
    """Whether an FDI sample is of a standby wheel: unpowered and at rest for the whole period (its command
    and reaction torque means exactly 0; wheel_set.py). A network trained on running wheels has nothing
    to recall there: its recall starts at the wheel's first running sample, and until then its estimate
    is the measured torque (residual 0).

    Parameters
    ----------
    tcv : float
        The sample's mean command [V].
    reaction_torque : float
        The sample's mean reaction torque [N m].

    Returns
    -------
    bool
        True when both are exactly 0.
    """
    return float(tcv) == 0.0 and float(reaction_torque) == 0.0


def recall_series(weights: ElmanWeights, tcv, initial_torque: float = 0.0, wheel_speed=None, reaction_torque=None,
                  model_torque=None):
    """Recall-mode estimates for a sampled tcv series (what the node computes, sample by sample); with
    ``reaction_torque``, from the first running sample (:func:`standby`) on, the measured torque before.

    Parameters
    ----------
    weights : ElmanWeights
        The wheel's network.
    tcv : array_like, shape (n,)
        FDI samples of the command u [V].
    initial_torque : float, optional
        Reaction torque the recall starts from [N m] (without ``reaction_torque``).
    wheel_speed : array_like, shape (n,), optional
        Wheel speed Omega [rad/s]; needed by a speed-aware network.
    reaction_torque : array_like, shape (n,), optional
        Measured reaction torque [N m]: the standby samples' estimate and the recall's start.
    model_torque : array_like, shape (n,), optional
        The nominal model's torque r_model [N m]: needed by a network of the model's error.

    Returns
    -------
    ndarray, shape (n,)
        The estimate r^ [N m].
    """
    tcv = np.asarray(tcv, float)
    speeds = [None] * len(tcv) if wheel_speed is None else np.asarray(wheel_speed, float)
    models = [None] * len(tcv) if model_torque is None else np.asarray(model_torque, float)
    if reaction_torque is not None:
        recall = WheelRecall(weights)
        return np.array([recall.update(u, r, w, m) for u, r, w, m in
                         zip(tcv, np.asarray(reaction_torque, float), speeds, models)])
    if weights.model_error and model_torque is None:
        raise ValueError("a network of the model's error needs the nominal model's torque")
    base = np.asarray(model_torque, float) if weights.model_error else np.zeros(len(tcv))
    obs = ElmanObserver(weights)
    obs.reset(initial_torque - (base[0] if len(base) else 0.0))
    return base + np.array([obs.update(u, None, w) for u, w in zip(tcv, speeds)])


def speed_coverage(wheel_speed, speed_scale: float, min_samples: int = None) -> np.ndarray:
    """The speeds a network's training held: COVERAGE_BINS bins of Omega over [-speed_scale, speed_scale], True
    where at least ``min_samples`` (COVERAGE_MIN) training samples fall. A grey box's correction is what it
    learnt at those speeds; elsewhere (a wheel through zero it never crossed in training, beyond its speeds) it
    would extrapolate, and its estimate is the nominal model's alone (:meth:`ElmanWeights.covers`).

    Parameters
    ----------
    wheel_speed : array_like
        Omega of every training sample [rad/s].
    speed_scale : float
        The network's speed normalisation [rad/s] (1.1 max |Omega| of training).
    min_samples : int, optional
        Samples a bin needs (default COVERAGE_MIN).

    Returns
    -------
    ndarray of bool, shape (COVERAGE_BINS,)
        Whether each bin is covered.
    """
    w = np.asarray(wheel_speed, float).ravel()
    k = np.floor((w / speed_scale + 1.0) * 0.5 * COVERAGE_BINS).astype(int)
    counts = np.bincount(k[(k >= 0) & (k < COVERAGE_BINS)], minlength=COVERAGE_BINS)
    return counts >= (COVERAGE_MIN if min_samples is None else min_samples)
