"""The closed loop of a vehicle without ROS: :func:`flight.fly` under the gains of the vehicle's design.

The design simulates the loop itself (controller_design.step_responses flies flight.fly), so the loop and
the design live apart and this module, above both, joins them.
"""
from __future__ import annotations

from .controller_design import design_controller
from .flight import Fdir, Trajectory, fly, step_metrics
from .control.pid import PidGains
from .physics.plant import batch_vehicle

__all__ = ["Fdir", "Trajectory", "simulate", "step_metrics"]   # the loop's public face: flight's types with it


def simulate(scenarios, gains: PidGains | None = None, **kw) -> Trajectory:
    """Run scenarios (one or a list) to their end under ``gains``, by default the vehicle's.

    Parameters
    ----------
    scenarios : Scenario or list of Scenario
        The B runs of the batch (one vehicle).
    gains : PidGains, optional
        The controllers' gains; None: the vehicle's, designed to its targets (controller_design.py, cached).
    **kw
        flight.fly's options (wheel, control_period, duration, disturbance, wheel_momentum_coupling, wheels,
        fdir, magnetic_field, every).

    Returns
    -------
    Trajectory
        The runs' time series (flight.Trajectory).
    """
    if gains is None:
        gains = design_controller(batch_vehicle(scenarios if isinstance(scenarios, list) else [scenarios])).gains
    return fly(scenarios, gains, **kw)
