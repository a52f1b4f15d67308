"""ROS 2 launch file: the FDI on anyone's wheels (`ros2 launch rw_fdi_ros fdi.launch.py vehicle:=...`).

No plant and no controllers: the wheel_telemetry node reads what the wheels and their driver report
(sensor_msgs/JointState: speed in velocity, optionally reaction torque in effort, on ``wheels_topic``;
commands in effort on ``command_topic``) and the FDI nodes of the vehicle judge them, reporting on
/diagnostics and /fdi/identification as in our own graph. Built by rw_fdi_ros.runner.graph.attach_nodes.
The wheels are matched by joint name: ``joint_names`` gives the streams' own, in the vehicle's wheel set's
order. Stamps are the messages' own: sim time or wall time alike.

    ros2 launch rw_fdi_ros fdi.launch.py vehicle:=microsat_pyramid joint_names:=rw1,rw2,rw3,rw4 \
        wheels_topic:=/acs/rw/state command_topic:=/acs/rw/cmd namespace:=sc1

A node that fails ends the launch with its name (exit 1); with a source that says its end (/plant/done: our
player, our plant) every node ends with it, else they run until stopped (Ctrl-C).
"""
import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction, SetEnvironmentVariable
from launch.substitutions import LaunchConfiguration
from rw_fdi_ros.paths import fastdds_profiles
from rw_fdi_ros.runner.graph import DEFAULT_GROUPING, GROUPINGS
from rw_fdi_ros.runner.launch_actions import node_actions


def _nodes(context):
    from rw_fdi_ros.runner.graph import attach_nodes
    from rw_fdi_ros.runner.shm import clean_zombie_files
    clean_zombie_files()

    def arg(name):
        return LaunchConfiguration(name).perform(context)
    fdi = {"models": arg("models") or None, "thresholds": arg("thresholds") or None,
           "decision": arg("decision") or None,
           "plugins": tuple(x.strip() for x in arg("observers").split(",") if x.strip())}
    joints = tuple(x.strip() for x in arg("joint_names").split(",") if x.strip())
    nodes = attach_nodes(arg("vehicle") or None, fdi, joints, float(arg("max_gap")) if arg("max_gap") else None)
    sim_time = arg("use_sim_time").lower() in ("true", "1", "yes")
    for node in nodes:
        node.parameters["use_sim_time"] = sim_time
    user = [os.path.abspath(arg("params_file"))] if arg("params_file") else []
    # relative from-names: the streams are found under the launch's namespace as well
    remaps = {"wheel_telemetry": [("wheels", arg("wheels_topic")), ("wheels/command", arg("command_topic"))]}
    return node_actions(nodes, arg("compose"), arg("namespace"), user, remaps, sim_clock=sim_time)


def generate_launch_description():
    return LaunchDescription([
        SetEnvironmentVariable("ROS_AUTOMATIC_DISCOVERY_RANGE",
                               os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")),
        SetEnvironmentVariable("FASTDDS_DEFAULT_PROFILES_FILE", fastdds_profiles() or ""),
        DeclareLaunchArgument("vehicle", default_value="",
                              description="a shipped vehicle, a vehicle file or its FDI directory (empty: the "
                                          "thesis' MakSat)"),
        DeclareLaunchArgument("joint_names", default_value="",
                              description="the streams' joint names in the wheel set's order, comma-separated "
                                          "(empty: reaction_wheel_<name>)"),
        DeclareLaunchArgument("wheels_topic", default_value="wheels",
                              description="JointState: speed in velocity [rad/s], optionally reaction torque in "
                                          "effort [N m]"),
        DeclareLaunchArgument("command_topic", default_value="wheels/command",
                              description="JointState: torque command voltage in effort [V]"),
        DeclareLaunchArgument("max_gap", default_value="",
                              description="[s] speed reports further apart: the periods between not judged "
                                          "(empty: the node's)"),
        DeclareLaunchArgument("models", default_value="", description="the FDI's models (empty: the vehicle's)"),
        DeclareLaunchArgument("thresholds", default_value="", description="its bands (empty: the models')"),
        DeclareLaunchArgument("decision", default_value="",
                              description="an observer (model, linear, elman) or a vote KofN (empty: the method's)"),
        DeclareLaunchArgument("observers", default_value="",
                              description="a user's observers beside ours, comma-separated (docs/observers.md)"),
        DeclareLaunchArgument("compose", default_value=DEFAULT_GROUPING,
                              description="which nodes share a process: " + ", ".join(GROUPINGS)),
        DeclareLaunchArgument("namespace", default_value="", description="every node's namespace (empty: none)"),
        DeclareLaunchArgument("use_sim_time", default_value="false", description="the nodes' clocks follow /clock"),
        DeclareLaunchArgument("params_file", default_value="",
                              description="a ROS 2 parameters file applied to every node after ours"),
        OpaqueFunction(function=_nodes),
    ])
