"""What the package's launch files share: our NodeSpecs as launch_ros actions, and a node's failure ending the launch.

Imported by launch/*.launch.py only (launch and launch_ros come from a ROS 2 install, or the copies a test uses).
"""
from __future__ import annotations

import os
import tempfile


# the launch arguments both launch files take: name -> (default, description)
SHARED_ARGUMENTS = {
    "compose": (None, "which nodes share a process: {groupings} (none: every node its own process)"),
    "models": ("", "Elman model directory (empty: shipped)"),
    "thresholds": ("", "threshold directory (empty: the models' when given, else shipped)"),
    "decision": ("", "what makes /diagnostics: an observer (model, linear, elman) or a vote KofN, e.g. 2of3 (empty: "
                     "the method's)"),
    "observers": ("", "a user's observers beside ours, comma-separated (entry point, module:Class or file.py:Class; "
                      "their state and bands in thresholds:=; docs/observers.md); empty: none"),
    "namespace": ("", "every node's namespace, its topics under it (two spacecraft in one ROS graph: namespace:=sc1 "
                      "and namespace:=sc2); empty: none"),
    "use_sim_time": ("false", "every node's clock follows /clock (the plant's simulated time)"),
    "params_file": ("", "a ROS 2 parameters file applied to every node after ours (node names or /** as keys)"),
}


def environment_and_arguments(*names) -> list:
    """The launch environment (discovery on this machine, our DDS profile) and the shared arguments ``names``.

    Parameters
    ----------
    *names : str
        Keys of SHARED_ARGUMENTS.

    Returns
    -------
    list
        SetEnvironmentVariable and DeclareLaunchArgument actions.
    """
    from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
    from ..paths import fastdds_profiles
    from .graph import DEFAULT_GROUPING, GROUPINGS
    return [
        # discovery stays on this machine (ROS_LOCALHOST_ONLY is ignored from kilted on)
        SetEnvironmentVariable("ROS_AUTOMATIC_DISCOVERY_RANGE",
                               os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")),
        # 50 ms reliable-writer heartbeat (config/fastdds.xml): the run's end and bag replay wait on acks
        SetEnvironmentVariable("FASTDDS_DEFAULT_PROFILES_FILE", fastdds_profiles() or ""),
        *(DeclareLaunchArgument(name, default_value=DEFAULT_GROUPING if default is None else default,
                                description=description.format(groupings=", ".join(GROUPINGS)))
          for name in names for default, description in [SHARED_ARGUMENTS[name]])]


class RunFailed(RuntimeError):
    """A node of the run exited non-zero. Raised from its exit handler: an exception is how launch
    ends a launch with a non-zero return code (a Shutdown action alone exits 0)."""


def node_actions(nodes, grouping: str, namespace: str = "", user_params=(), remappings=None, sim_clock=False):
    """launch_ros ``Node`` actions of ``nodes`` (runner.graph.NodeSpec) dealt into the processes of ``grouping``,
    and an exit handler on each that ends the launch when it fails.

    Parameters
    ----------
    nodes : list of NodeSpec
        The graph's nodes.
    grouping : str
        runner.graph.GROUPINGS: which nodes share a process.
    namespace : str
        Every node's namespace ('' none); our parameters file keys every node by /**/name (any namespace).
    user_params : sequence of str
        A user's parameters files, applied after ours (their values win).
    remappings : dict, optional
        Executable -> [(from, to)]: a node's own remappings (a process of one node).
    sim_clock : bool
        Every node's clock follows /clock: under a namespace, its own.

    Returns
    -------
    list
        The Node actions, then their exit handlers.
    """
    from launch.actions import RegisterEventHandler
    from launch.event_handlers import OnProcessExit
    from launch_ros.actions import Node
    from .graph import processes
    from .launcher import write_params_file
    groups = processes(nodes, grouping)
    params = write_params_file(nodes, os.path.join(tempfile.mkdtemp(prefix="rw_fdi_launch_"), "params.yaml"),
                               namespace="any")
    ns = namespace.strip("/")
    # every topic is relative (a node resolves it in its namespace); the clock use_sim_time reads is /clock
    clock = [("/clock", f"/{ns}/clock")] if ns and sim_clock else []
    remappings = remappings or {}
    actions = [Node(package="rw_fdi_ros", executable=p.nodes[0].executable, name=p.name, namespace=ns,
                    parameters=[p.nodes[0].parameters, *user_params], output="screen",
                    remappings=clock + list(remappings.get(p.nodes[0].executable, [])))
               if len(p.nodes) == 1 else
               Node(package="rw_fdi_ros", executable="composed", parameters=[str(params), *user_params],
                    output="screen", namespace=ns, remappings=clock,
                    arguments=[f"{n.name}={n.executable}" for n in p.nodes])
               for p in groups]
    return actions + [RegisterEventHandler(OnProcessExit(target_action=a, on_exit=_on_exit(p.name)))
                      for a, p in zip(actions, groups)]


def _on_exit(name: str):
    """A node that fails ends the launch with code 1, naming itself; a clean exit is a node that saw
    the run end. Exits while the launch is already shutting down are its SIGINT, not a new failure."""
    def on_exit(event, context):
        if event.returncode != 0 and not context.is_shutdown:
            raise RunFailed(f"{name} exited with code {event.returncode}")
        return None
    return on_exit
