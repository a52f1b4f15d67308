"""Train the three Elman observers (thesis 4.3.3) with torch from fault-free bags.

Two trainings, same network and equations as core/fdi/elman.py:
- ``teacher`` (the thesis, Fig. 4.9): the delayed *measured* torque is the
  second input; the network is then run in recall mode. The thesis used one
  run; ``--runs 1`` reproduces that.
- ``recall``: trained the way it is used: the delayed input is the
  network's own output, back-propagated through time over whole runs.
Deviation from the thesis, stated: Adam instead of traingdx and no
20-fold averaged initialisation (uniform [-0.1, 0.1] from a fixed seed);
both only change how fast training gets there.

Outputs: ``elman_<axis>.npz`` (arrays, never pickles) + ``elman_<axis>.json``
card (bags, seeds, losses, normalisation, plant conditions) per axis.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

from ...core.fdi.detection import FALSE_ALARM_RATE
from ...core.fdi.elman import HIDDEN, SETTLE_STEPS, ElmanWeights
from ...extras import require
from ...paths import shown_path

MODES = ("teacher", "recall")
# Epochs of the speed-aware networks. On the 100 fitting runs (x axis) the largest fault-free run
# statistic fell from 4.6e-4 N m at 300 epochs to 0.9e-4 at 1000 (lr 0.03: 1.2e-4), and the band c
# with it: the held-out detection delay follows c. The thesis set keeps 300 (its limit is its inputs).
EPOCHS = 1000
HUBER_DELTA = 0.1   # [scaled torque] where the Huber loss turns linear
THESIS_EPOCHS = 300


def _torch():
    torch = require("torch", "train")
    torch.set_num_threads(1)   # tiny matrices: threads only add overhead on 2 cores
    return torch


def torch_forward(params, u, r, mode: str, speed=None):
    """Network outputs (..., B, T), normalised; ``params`` = (w_ih, w_hh, b_h, w_ho, b_o) torch tensors, each
    with a leading wheel axis (W, ...) for W networks at once (``u``, ``r``, ``speed`` then (W, B, T)).

    Recall mode feeds back its own output; teacher mode feeds the measured r_{k-1}.
    Both start from the measured r_0 as the delayed input of sample 0. ``speed`` (..., B, T),
    normalised, is the third input of a speed-aware network.
    """
    torch = _torch()
    w_ih, w_hh, b_h, w_ho, b_o = params
    w_in = [w_ih[..., None, :, j] for j in range(w_ih.shape[-1])]   # (..., 1, H): an input's weights
    w_hh_t, w_ho_t, b_h, b_o = w_hh.transpose(-1, -2), w_ho.transpose(-1, -2), b_h[..., None, :], b_o[..., None, :]
    h = torch.zeros(*u.shape[:-1], w_hh.shape[-1], dtype=u.dtype)
    fed = r[..., 0]
    if speed is not None:   # start from the steady state for the first input (elman.SETTLE_STEPS)
        for _ in range(SETTLE_STEPS):
            drive = u[..., 0:1] * w_in[0] + fed[..., None] * w_in[1] + speed[..., 0:1] * w_in[2]
            h = torch.tanh(drive + h @ w_hh_t + b_h)
            fed = torch.tanh(h @ w_ho_t + b_o)[..., 0]   # its own output, as in use
        if mode == "teacher":
            fed = r[..., 0]
    # what does not feed back, every step at once (..., T, B, H): the loop is left the recurrence alone
    given = u.transpose(-1, -2)[..., None] * w_in[0][..., None, :, :] + b_h[..., None, :, :]
    if speed is not None:
        given = given + speed.transpose(-1, -2)[..., None] * w_in[2][..., None, :, :]
    outs = []
    for k, given_k in enumerate(torch.unbind(given, dim=-3)):   # one backward for all the steps' slices
        h = torch.tanh(given_k + fed[..., None] * w_in[1] + h @ w_hh_t)
        y = torch.tanh(h @ w_ho_t + b_o)[..., 0]
        outs.append(y)
        fed = y if mode == "recall" else r[..., k]
    return torch.stack(outs, dim=-1)


LOSSES = ("mse", "huber")


def train_axis(tcv, torque, mode: str = "recall", epochs: int = EPOCHS, lr: float = 0.01, seed: int = 0,
               torque_scale: float | None = None, progress=None, wheel_speed=None, hidden: int = HIDDEN,
               loss: str = "mse"):
    """Fit one wheel's network on (runs, samples) arrays; returns (weights, loss history).

    With ``wheel_speed`` (runs, samples) the network is speed-aware (three inputs). ``hidden``: its hidden
    units; ``loss``: 'mse', the mean of e^2 (the thesis'), or 'huber', quadratic within 0.1 of the scaled
    torque and linear beyond (a few large errors, a slew's first samples, weigh less)."""
    return train_networks(np.asarray(tcv)[None], np.asarray(torque)[None], mode, epochs, lr, (seed,),
                          None if torque_scale is None else (torque_scale,), progress,
                          None if wheel_speed is None else np.asarray(wheel_speed)[None], hidden, loss)[0]


def train_networks(tcv, torque, mode: str = "recall", epochs: int = EPOCHS, lr: float = 0.01, seeds=None,
                   torque_scales=None, progress=None, wheel_speed=None, hidden: int = HIDDEN,
                   loss: str = "mse") -> list:
    """Fit W wheels' networks at once on (W, runs, samples) arrays, as many trainings of :func:`train_axis`
    stepped together: the wheels share no weight, and each has its own loss, Adam state and gradient clip (a
    tenth of a second of Python per epoch carries all of them). ``seeds``: each network's start (default
    0, 1, ...); ``progress(1, loss)`` once an epoch with the largest wheel loss. Returns [(weights, losses)]."""
    if loss not in LOSSES:
        raise ValueError(f"loss {loss!r}: one of {', '.join(LOSSES)}")
    torch = _torch()
    tcv, torque = np.asarray(tcv, float), np.asarray(torque, float)
    count = tcv.shape[0]
    seeds = tuple(range(count)) if seeds is None else tuple(seeds)
    torque_scales = torque_scales or [float(np.abs(t).max() * 1.1) for t in torque]
    speed_scales = ([0.0] * count if wheel_speed is None else [float(np.abs(w).max() * 1.1) for w in wheel_speed])
    starts = [ElmanWeights.random(np.random.default_rng(seed), hidden, tcv_scale=5.0, torque_scale=ts,
                                  speed_scale=ss) for seed, ts, ss in zip(seeds, torque_scales, speed_scales)]
    names = ("w_ih", "w_hh", "b_h", "w_ho", "b_o")
    params = [torch.tensor(np.stack([getattr(w0, k) for w0 in starts]), dtype=torch.float64, requires_grad=True)
              for k in names]
    column = torch.tensor(torque_scales, dtype=torch.float64)[:, None, None]
    u = torch.tensor(tcv / 5.0, dtype=torch.float64)
    r = torch.tensor(torque, dtype=torch.float64) / column
    w = (None if wheel_speed is None else
         torch.tensor(np.asarray(wheel_speed, float), dtype=torch.float64)
         / torch.tensor(speed_scales, dtype=torch.float64)[:, None, None])
    opt = torch.optim.Adam(params, lr=lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs, eta_min=lr / 20)
    losses = []
    for _ in range(epochs):
        opt.zero_grad()
        e = torch_forward(params, u, r, mode, w) - r
        costs = (torch.mean(e ** 2, dim=(1, 2)) if loss == "mse" else torch.nn.functional.huber_loss(
            e, torch.zeros_like(e), delta=HUBER_DELTA, reduction="none").mean(dim=(1, 2)))
        costs.sum().backward()   # each wheel's gradient is its own loss's
        # clip_grad_norm_(1.0) of each wheel's own parameters
        norms = torch.sqrt(sum((p.grad ** 2).reshape(count, -1).sum(dim=1) for p in params))
        clip = torch.clamp(1.0 / (norms + 1e-6), max=1.0)
        for p in params:
            p.grad.mul_(clip.reshape(-1, *([1] * (p.dim() - 1))))
        opt.step()
        sched.step()
        losses.append(costs.detach().numpy().copy())
        if progress:
            progress(1, float(losses[-1].max()))
    history = np.array(losses)
    return [(ElmanWeights(**{k: p.detach().numpy()[i].copy() for k, p in zip(names, params)}, tcv_scale=5.0,
                          torque_scale=torque_scales[i], speed_scale=speed_scales[i]).validate(),
             [float(x) for x in history[:, i]]) for i in range(count)]


def uncertainty_gain(weights, samples, axis: int, false_alarm_rate: float = FALSE_ALARM_RATE,
                     wheel: str | None = None) -> float:
    """kappa of an Elman network (core/fdi/residuals.demand_gain over ``samples``): it models slews less well
    than holding, and its first seconds start from a zero state."""
    from ...core.fdi.residuals import demand_gain, demand_ratio
    from ...core.fdi.elman import recall_series
    ratios = [demand_ratio(s.reaction_torque[:, axis],
                           recall_series(weights, s.tcv[:, axis], s.reaction_torque[0, axis], s.wheel_speed[:, axis],
                                         model_torque=None if getattr(s, "model_torque", None) is None
                                         else s.model_torque[:, axis]),
                           s.ripple_phasor[:, axis], params=getattr(s, "wheel_params", None)) for s in samples]
    kappa = demand_gain([x for x in ratios if x is not None], false_alarm_rate)
    if not kappa < 10.0:   # ElmanWeights refuses such a model: say so now, not when a node loads it
        raise ValueError(f"wheel {wheel or samples[0].wheels[axis]}: the network errs by {kappa:.3g} x the torque "
                         "demand on fault-free "
                         "runs (> 10); train longer or on more runs")
    return kappa


def trained_wheels(samples, plant: dict | None = None) -> tuple:
    """The wheels a model set has networks for: those in use of the runs' wheel set (``plant``'s
    ``wheel_set``, else the samples' columns); a standby wheel, at rest in every training run, runs the
    network of its type (core/fdi/elman.network_wheel)."""
    from ...core.physics.wheel_set import wheel_set
    names = tuple(samples[0].wheels)
    if any(tuple(s.wheels) != names for s in samples):
        raise ValueError("training runs of different wheel sets: train each set on its own")
    active = wheel_set(plant["wheel_set"]).active if plant and plant.get("wheel_set") else names
    return tuple(a for a in names if a in active)


def train_models(samples, out_dir, mode: str = "recall", epochs: int = EPOCHS, plant: dict | None = None,
                 seed: int = 0, quiet: bool = False, speed_aware: bool = True, calibration=None,
                 false_alarm_rate: float = FALSE_ALARM_RATE) -> dict:
    """Train a network per wheel in use of the samples' set (:func:`trained_wheels`; the default set: x, y, z)
    on a list of FdiSamples, all at once (:func:`train_networks`), and save them with cards; returns the set
    card (its ``wheels``: which have one).

    ``speed_aware``: three inputs with the wheel speed (ours); False: the thesis' two.
    ``calibration``: fault-free runs kappa is measured on (default: the training runs). More
    runs than the network was fitted to see more manoeuvres, so kappa covers more of the envelope.
    ``false_alarm_rate``: the designed per-run rate kappa takes half of (:func:`uncertainty_gain`).
    """
    from tqdm import tqdm
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}")
    if not samples:
        raise ValueError("no fault-free bags to train on")
    n = min(len(s.time) for s in samples)
    wheels = trained_wheels(samples, plant)
    columns = [samples[0].wheels.index(a) for a in wheels]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    card = {"mode": mode, "speed_aware": speed_aware, "epochs": epochs, "hidden": HIDDEN, "samples_per_run": n,
            "bags": [shown_path(s.bag, out_dir) for s in samples if s.bag is not None],   # none: core-loop runs
            "seeds": [s.seed for s in samples],
            "plant": plant or {}, "wheels": list(wheels), "axes": {}}
    calibration = list(calibration) if calibration else list(samples)
    if speed_aware:
        card["uncertainty_gain_seeds"] = [s.seed for s in calibration]
    bar = tqdm(total=epochs, desc=f"train elman ({mode}, {len(wheels)} wheels, {len(samples)} runs)", unit="epoch",
               file=sys.stderr, disable=quiet, mininterval=1.0)

    def stacked(field):   # (wheels, runs, samples)
        return np.stack([np.stack([getattr(s, field)[:n, i] for s in samples]) for i in columns])

    def tick(k, loss):
        bar.update(k)
        bar.set_postfix(mse=f"{loss:.2e}", refresh=False)
    trained = train_networks(stacked("tcv"), stacked("reaction_torque"), mode, epochs,
                             seeds=[seed + i for i in columns], progress=tick,
                             wheel_speed=stacked("wheel_speed") if speed_aware else None)
    for i, axis, (weights, losses) in zip(columns, wheels, trained):
        if speed_aware:
            weights.uncertainty_gain = uncertainty_gain(weights, calibration, i, false_alarm_rate, axis)
        axis_card = {**{k: v for k, v in card.items() if k != "axes"}, "axis": axis,
                     "final_loss": losses[-1], "first_loss": losses[0], "tcv_scale": weights.tcv_scale,
                     "torque_scale": weights.torque_scale, "speed_scale": weights.speed_scale,
                     "uncertainty_gain": weights.uncertainty_gain}
        weights.save(out_dir / f"elman_{axis}.npz", axis_card)
        card["axes"][axis] = {"final_loss": losses[-1], "torque_scale": weights.torque_scale,
                              "uncertainty_gain": weights.uncertainty_gain}
    bar.close()
    card["train_seconds"] = time.monotonic() - t0
    (out_dir / "model_set.json").write_text(json.dumps(card, indent=2))
    return card
