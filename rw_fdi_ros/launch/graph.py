"""The run graph as data: which nodes, with which parameters, for one scenario and seed.

Both our launcher (here, CI, the CLI) and the ROS 2 launch file in
``launch/`` build the graph from :func:`graph_nodes`, so they cannot drift.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..core.plant import hold_command
from ..core.scenario import AXES, Scenario

CONTROL_PERIOD = 0.1


@dataclass
class NodeSpec:
    name: str                 # ROS node name (unique in the graph)
    executable: str           # console script / module under rw_fdi_ros.nodes
    parameters: dict = field(default_factory=dict)
    essential: bool = True    # its death ends the run

    @property
    def module(self) -> str:
        return f"rw_fdi_ros.nodes.{self.executable}"


def graph_nodes(scenario: Scenario, scenario_ref: str, bag: Path | None, command_timeout: float = 5.0,
                emf_limit: str = "kf_scaled"):
    """Plant, three PID controllers and (when ``bag``) the recorder for one run."""
    ic, _ = scenario.draws()
    times, values = scenario.setpoint_schedule()
    hold = hold_command(ic.wheel_speed)
    recording = bag is not None
    nodes = [NodeSpec("plant", "plant", {
        "scenario": scenario_ref, "seed": scenario.seed, "control_period": CONTROL_PERIOD,
        "emf_limit": emf_limit, "command_timeout": command_timeout,
        "wait_for_subscribers": 1 if recording else 0})]
    for i, axis in enumerate(AXES):
        nodes.append(NodeSpec(f"pid_controller_{axis}", "pid_controller", {
            "axis": axis, "control_period": CONTROL_PERIOD, "initial_tcv": float(hold[i]),
            "setpoint_times": [float(t) for t in times], "setpoints": [float(v) for v in values[:, i]],
            "min_subscribers": 2 if recording else 1}))
    if recording:
        nodes.append(NodeSpec("recorder", "recorder", {"output": str(bag)}))
    return nodes
