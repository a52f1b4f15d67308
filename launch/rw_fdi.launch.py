"""ROS 2 launch file for users with a full ROS 2 install (`ros2 launch rw_fdi_ros rw_fdi.launch.py`).

It builds the same graph as `rw-fdi run` from rw_fdi_ros.runner.graph.graph_nodes,
so both launchers start identical nodes with identical parameters: plant,
three controllers, the wheel allocation (reconfiguring on the FDI's confirmed
verdict; ``fdir:=false`` keeps every wheel in use), the FDI nodes (``fdi:=false``
leaves them out) and, with ``bag``, the recorder; ``compose`` groups them into processes as our launcher
does (runner/graph.GROUPINGS: one composed process by default, ``compose:=none`` one per node). Parameters
go as they are: graph_nodes names wheels and
axes by joint (``reaction_wheel_y``, ``attitude_y``) and paths absolutely, and
refuses any string a YAML layer would retype (a bare ``y`` is a boolean to rcl).

The launch ends by itself: every node ends with the run, and then the launch
exits 0. A node that exits non-zero ends the run: launch shuts every other node
down (SIGINT, so the recorder closes a readable bag) and ``ros2 launch`` exits 1
naming the node ("Caught exception in launch ...: <node> exited with code N").
test/test_launch_file.py runs this file under the real launch and launch_ros.

    ros2 launch rw_fdi_ros rw_fdi.launch.py scenario:=bus_5v5_x seed:=3 bag:=bags/demo
    ros2 launch rw_fdi_ros rw_fdi.launch.py models:=my_fdi/ unit_calibration:=150 use_sim_time:=true \
        params_file:=my_params.yaml
"""
import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from rw_fdi_ros.runner.launch_actions import environment_and_arguments, node_actions


def _nodes(context):
    from rw_fdi_ros.runner.scenario_run import resolve_scenario
    from rw_fdi_ros.runner.graph import graph_nodes
    from rw_fdi_ros.runner.shm import clean_zombie_files
    clean_zombie_files()   # Fast DDS files of killed processes (what `fastdds shm clean` removes)
    seed = int(LaunchConfiguration("seed").perform(context))
    scenario, path = resolve_scenario(LaunchConfiguration("scenario").perform(context), seed if seed >= 0 else None)
    bag = LaunchConfiguration("bag").perform(context) or None
    def arg(name):
        return LaunchConfiguration(name).perform(context)

    def flag(name):
        return arg(name).lower() in ("true", "1", "yes")
    # the FDI as every command takes it (rw_fdi_ros/fdi_config.py): a bad value is one line before any node
    fdi = {"method": arg("fdi_method"), "fdir": flag("fdir"), "models": arg("models") or None,
           "thresholds": arg("thresholds") or None, "persistence": int(arg("persistence")) or None,
           "unit_calibration": float(arg("unit_calibration")), "decision": arg("decision") or None,
           "plugins": tuple(x.strip() for x in arg("observers").split(",") if x.strip())} if flag("fdi") else None
    nodes = graph_nodes(scenario, path, bag, fdi=fdi, live=int(arg("live")) if arg("live") else None)
    if flag("use_sim_time"):   # every node's clock follows the plant's /clock
        for node in nodes:
            node.parameters["use_sim_time"] = True
    # a user's parameters file comes after ours, so its values win; a namespace (namespace:=sc1, or an including
    # launch file's PushRosNamespace) puts every node and topic under it
    user = [os.path.abspath(arg("params_file"))] if arg("params_file") else []
    return node_actions(nodes, arg("compose"), arg("namespace"), user, sim_clock=flag("use_sim_time"))


def generate_launch_description():
    return LaunchDescription([
        *environment_and_arguments("compose", "models", "thresholds", "decision", "observers", "namespace",
                                   "use_sim_time", "params_file"),
        DeclareLaunchArgument("scenario", default_value="fault_free", description="scenario name or YAML file"),
        DeclareLaunchArgument("seed", default_value="-1", description="seed (-1: the scenario's)"),
        DeclareLaunchArgument("bag", default_value="", description="bag directory to record (empty: no recorder)"),
        DeclareLaunchArgument("fdi", default_value="true", description="start the observers and the isolation node"),
        DeclareLaunchArgument("fdi_method", default_value="speed_aware", description="speed_aware or thesis"),
        DeclareLaunchArgument("fdir", default_value="true",
                              description="give up a wheel the FDI confirms faulty and bring the redundant one in"),
        DeclareLaunchArgument("persistence", default_value="0",
                              description="samples above the threshold before an alarm (0: the threshold file's)"),
        DeclareLaunchArgument("unit_calibration", default_value="0",
                              description="seconds each observer learns its wheel's unit from (0: the datasheet)"),
        DeclareLaunchArgument("live", default_value="",
                              description="port of a live view: the run in Foxglove as it happens (foxglove-sdk; "
                                          "0: any free port); empty: none"),
        OpaqueFunction(function=_nodes),
    ])
