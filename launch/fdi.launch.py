"""ROS 2 launch file: the FDI on anyone's wheels (`ros2 launch rw_fdi_ros fdi.launch.py vehicle:=...`).

No plant and no controllers: the wheel_telemetry node reads what the wheels and their driver report
(sensor_msgs/JointState: speed in velocity, optionally reaction torque in effort, on ``wheels_topic``;
commands in effort on ``command_topic``; optionally the bus voltage, sensor_msgs/BatteryState, on
``bus_voltage_topic`` and the temperature, sensor_msgs/Temperature, on ``temperature_topic``, each naming its
joint in frame_id) and the FDI nodes of the vehicle judge them, reporting on
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
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from rw_fdi_ros.runner.launch_actions import environment_and_arguments, node_actions


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
    remaps = {"wheel_telemetry": [("wheels", arg("wheels_topic")), ("wheels/command", arg("command_topic")),
                                  ("wheels/bus_voltage", arg("bus_voltage_topic")),
                                  ("wheels/temperature", arg("temperature_topic"))]}
    return node_actions(nodes, arg("compose"), arg("namespace"), user, remaps, sim_clock=sim_time)


def generate_launch_description():
    return LaunchDescription([
        *environment_and_arguments("compose", "models", "thresholds", "decision", "observers", "namespace",
                                   "use_sim_time", "params_file"),
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
        DeclareLaunchArgument("bus_voltage_topic", default_value="wheels/bus_voltage",
                              description="BatteryState, optional: the bus at a wheel's driver in voltage [V], its "
                                          "joint in header.frame_id (empty: every wheel)"),
        DeclareLaunchArgument("temperature_topic", default_value="wheels/temperature",
                              description="Temperature, optional: a wheel's in temperature [C], its joint in "
                                          "header.frame_id (empty: every wheel)"),
        DeclareLaunchArgument("max_gap", default_value="",
                              description="[s] speed reports further apart: the periods between not judged "
                                          "(empty: the node's)"),
        OpaqueFunction(function=_nodes),
    ])
