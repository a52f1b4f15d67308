"""FDI samples out of bags: the 1 s samples of command voltage and reaction torque the observers see."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.sampling import sample_series
from ..nodes.topics import REACTION_TORQUE, TCV
from ..storage.bag import BagError, bag_is_complete, read_bag


@dataclass
class FdiSamples:
    """One run at the FDI period: time (n,), tcv (n, 3) [V], reaction torque (n, 3) [N m]."""

    bag: Path
    seed: int | None
    time: np.ndarray
    tcv: np.ndarray
    reaction_torque: np.ndarray


def fdi_samples(data, period: float = 1.0, sampling: str = "mean") -> FdiSamples:
    """Pair /wheel/tcv and /wheel/reaction_torque by stamp and make the FDI samples the nodes make."""
    t_u, u = data.vectors(TCV)
    t_r, r = data.vectors(REACTION_TORQUE)
    if len(t_u) == 0 or len(t_r) == 0:
        raise BagError(f"{data.path}: no {TCV} / {REACTION_TORQUE} messages")
    common, iu, ir = np.intersect1d(np.round(t_u * 1e9).astype(np.int64), np.round(t_r * 1e9).astype(np.int64),
                                    return_indices=True)
    stamps, u_s, r_s = sample_series(common, u[iu], r[ir], period, sampling)
    seed = None
    if data.scenario_text:
        import yaml
        seed = (yaml.safe_load(data.scenario_text) or {}).get("seed")
    return FdiSamples(bag=data.path, seed=seed, time=stamps // 10**9 + (stamps % 10**9) * 1e-9, tcv=u_s, reaction_torque=r_s)


def bag_dirs(root) -> list:
    """Bag directories under ``root`` (itself if it is one), sorted."""
    root = Path(root)
    if not root.exists():
        raise BagError(f"{root}: no such directory")
    if list(root.glob("*.mcap")):
        return [root]
    dirs = sorted(p for p in root.iterdir() if p.is_dir() and list(p.glob("*.mcap")))
    if not dirs:
        raise BagError(f"{root}: no bags in it (expected bag directories with a .mcap file)")
    return dirs


def load_samples(root, period: float = 1.0, complete_only: bool = True, on_skip=None, sampling: str = "mean") -> list:
    """FDI samples of every bag under ``root``; unreadable or incomplete bags are reported and skipped."""
    out = []
    for bag in bag_dirs(root):
        try:
            if complete_only and not bag_is_complete(bag):
                raise BagError(f"{bag}: incomplete bag (no metadata.yaml or MCAP footer)")
            out.append(fdi_samples(read_bag(bag, topics=[TCV, REACTION_TORQUE, "/scenario"]), period, sampling))
        except BagError as exc:
            if on_skip is None:
                raise
            on_skip(str(exc))
    return out
