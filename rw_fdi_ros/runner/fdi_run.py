"""A run with the FDI half live: the whole graph recorded, then its verdict (and figure) attached."""
from __future__ import annotations

from ..fdi_config import FdiConfig
from ..storage.bag import read_series
from ..scoring import bag_series
from .residual_figure import plot_residuals
from .scenario_run import RunOutcome, run_scenario
from .verdict import fdi_verdict, verdict_topics


def run_with_fdi(ref: str, seed=None, out_dir="bags", fdi=None, figure: bool = False, **kw) -> RunOutcome:
    """Run the full graph (plant, PIDs, wheel allocation, observers, isolation, recorder) with the FDI ``fdi``
    (FdiConfig or its mapping; None: the shipped one); attach the FDI verdict. ``fdi.fdir`` False: the wheel
    allocation keeps every wheel in use (detection alone)."""
    fdi = FdiConfig.of(fdi)
    outcome = run_scenario(ref, seed=seed, out_dir=out_dir, fdi=fdi, **kw)
    if outcome.bag.exists():
        try:
            data = read_series(outcome.bag, verdict_topics(fdi.plugin_slots))
            outcome.summary = {**(outcome.summary or {}), "fdi": {**fdi_verdict(data),
                                                                  "health": bag_series.health_from_bag(outcome.bag)}}
            if figure:
                figure = outcome.bag.parent / f"{outcome.bag.name}_fdi.png"
                outcome.summary["figure"] = str(plot_residuals(data, figure))
        except Exception as exc:  # the run's own failure reason matters more
            if outcome.ok:
                outcome.ok, outcome.reason = False, f"reading FDI results: {exc}"
    return outcome
