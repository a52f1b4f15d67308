"""Four wheels that are not our plant, publishing what a real wheel driver reports (test_wheel_telemetry_graph.py).

A speed-mode driver: every 0.1 s a PI on a slow speed reference commands the drive; the rotor is integrated
at 100 Hz (Euler, the bearing noise included, no ripple; the standby wheel stays at rest) from the Type A's
healthy torque; the speed is reported at about 25 Hz with +-30 % jitter, 15 % of the reports lost, under
joint names of its own (rw1-rw4), no torque reported. Wheel 2 loses ``--limiter`` of its current from ``--onset`` on.

Run: python foreign_wheels.py OUT.json --duration 300 --onset 150; it waits for the FDI graph, streams the run
paced by the graph's /wheels/fdi_telemetry, says /plant/done and writes every status it heard on /diagnostics
and /fdi/identification. ``--table CSV --joints A,B,C`` streams a telemetry table instead (docs/telemetry.md: a
Basilisk run of examples/basilisk/closed_loop.py), each report at its own stamp.
"""
import argparse
import json
import sys
import time
from types import SimpleNamespace

import numpy as np

from rw_fdi_ros.core.physics import wheel as wm
from rw_fdi_ros.core.physics.faults import nominal_values

JOINTS = ["rw1", "rw2", "rw3", "rw4"]   # x, y, z and the standby s of orthogonal_skew
TYPE_A = wm.WheelParams()


def stream(duration: float, onset: float, limiter: float, seed: int = 3, h: float = 0.01, bus: float | None = None):
    """(speed reports [(t, speeds)], commands [(t, u)]) of the four wheels; the fourth stands by at rest. Wheel 2's
    fault is a current loss to ``limiter``, or with ``bus`` a drop of its bus to ``bus`` [V]."""
    rng = np.random.default_rng(seed)
    nominal = nominal_values(TYPE_A)
    base = np.array([25.0, 22.0, 28.0, 0.0])
    active = np.arange(4) < 3
    w, u = base.copy(), np.zeros(4)
    speeds, commands, next_report = [], [], 0.0
    for k in range(int(round(duration / h)) + 1):
        t = k * h
        if k % 10 == 0:
            ref = base + 3.0 * active * np.sin(2 * np.pi * t / 200.0 + np.arange(4))
            u = np.clip(2.1 * np.sign(ref) + 0.5 * (ref - w), -5.0, 5.0) * active
            commands.append((t, u.copy()))
        if t >= next_report - 1e-12:
            if rng.random() > 0.15:
                speeds.append((t, w.copy()))
            next_report += rng.uniform(0.7, 1.3) / 25.0
        op = SimpleNamespace(**{kind: np.full(4, v, float) for kind, v in nominal.items()})
        faulty = (np.arange(4) == 1) & (t >= onset)
        if bus is None:
            op.current_limiter = np.where(faulty, limiter, 1.0)
        else:
            op.bus_voltage = np.where(faulty, bus, op.bus_voltage)
        w = w + h * active * wm.net_torque(u, w, t, op, TYPE_A)[0] / TYPE_A.inertia   # the standby one: at rest
    return speeds, commands


def drive_graph(nodes, log_dir, *driver_args) -> list:
    """Start the FDI graph ``nodes`` (runner.graph.attach_nodes), this driver against it with ``driver_args``, and
    return every status it heard once both have ended (the FDI nodes end with the run the driver says done);
    every process torn down whatever happens."""
    import subprocess
    from pathlib import Path
    from rw_fdi_ros.runner.launcher import DomainLease, GraphProcesses, stop_processes
    next(n for n in nodes if n.name == "isolation").parameters["diagnostics_readers"] = 1   # the driver
    out = Path(log_dir) / "heard.json"
    with DomainLease() as lease:
        procs = GraphProcesses(nodes, lease.domain_id, Path(log_dir), grouping="loop_fdi").start()
        driver = subprocess.Popen([sys.executable, __file__, str(out), *map(str, driver_args)], env=procs.env,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            log = driver.communicate(timeout=600)[0].decode()
            assert driver.returncode == 0, log[-2000:]
            result = procs.run(main="isolation", watchdog=60, finisher=None)
            assert result.ok, result.reason
        finally:
            stop_processes([driver])
            procs.stop_all()
    return json.loads(out.read_text())["heard"]


def table(path: str, joints: list) -> tuple:
    """(speed reports, commands) of a telemetry table, each a row where the channel has a value for every wheel."""
    from rw_fdi_ros.tools.evaluation.telemetry_file import read_table
    t = read_table(path, joints)
    times = t.stamps_ns * 1e-9
    return ([(s, w) for s, w in zip(times, t.speed) if np.isfinite(w).all()],
            [(s, u) for s, u in zip(times, t.command) if np.isfinite(u).all()])


def main():
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import BatteryState, JointState, Temperature
    from std_msgs.msg import Header
    from rw_fdi_ros.graph import topics as T
    from rw_fdi_ros.graph.convert import stamp_ns, time_msg
    from rw_fdi_ros.graph.runtime import relative

    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--duration", type=float, default=300.0)
    p.add_argument("--onset", type=float, default=150.0)
    p.add_argument("--limiter", type=float, default=0.5)
    p.add_argument("--namespace", default="", help="the FDI graph's")
    p.add_argument("--speed-topic", default="wheels")
    p.add_argument("--command-topic", default="wheels/command")
    p.add_argument("--table", default=None, help="a telemetry table to stream instead")
    p.add_argument("--joints", default=",".join(JOINTS), help="the stream's joint names")
    p.add_argument("--housekeeping", action="store_true",
                   help="also each wheel's bus voltage (BatteryState, its joint in frame_id) and one temperature for "
                        "all (Temperature, frame_id empty) every second")
    args = p.parse_args()
    joints = args.joints.split(",")
    speeds, commands = stream(args.duration, args.onset, args.limiter) if args.table is None else table(args.table,
                                                                                                        joints)
    rclpy.init()
    # in the FDI graph's namespace: its topics relative, the streams where the driver puts them
    node = rclpy.create_node("foreign_wheels", namespace="/" + args.namespace.strip("/"))
    pub_speed = node.create_publisher(JointState, args.speed_topic, T.RELIABLE)
    pub_command = node.create_publisher(JointState, args.command_topic, T.RELIABLE)
    pub_done = node.create_publisher(Header, relative(T.PLANT_DONE), T.LATCHED)
    pub_bus = node.create_publisher(BatteryState, relative(T.WHEEL_BUS_VOLTAGE), T.RELIABLE)
    pub_temperature = node.create_publisher(Temperature, relative(T.WHEEL_TEMPERATURE), T.RELIABLE)
    heard, fdi_at, carried = [], [-1.0], {}
    for topic in (relative(T.DIAGNOSTICS), relative(T.IDENTIFICATION)):
        node.create_subscription(DiagnosticArray, topic, lambda m: heard.extend(
            (stamp_ns(m.header.stamp) * 1e-9, s.name, s.hardware_id, s.level[0] if isinstance(s.level, bytes)
             else s.level, s.message, {v.key: v.value for v in s.values}) for s in m.status), T.RELIABLE)

    def on_fdi(m):
        fdi_at[0] = stamp_ns(m.header.stamp) * 1e-9
        # the housekeeping the FDI telemetry carries (the channels '<wheel>/bus_voltage', '.../temperature')
        carried.update({n: v for n, v in zip(m.name, m.position) if n.endswith(("/bus_voltage", "/temperature"))})
    sub_fdi = node.create_subscription(JointState, relative(T.FDI_TELEMETRY), on_fdi, T.RELIABLE)

    def wait(ready, timeout):
        deadline = time.monotonic() + timeout
        while not ready() and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        return ready()

    if not wait(lambda: pub_speed.get_subscription_count() and pub_command.get_subscription_count()
                and (not args.housekeeping
                     or pub_bus.get_subscription_count() and pub_temperature.get_subscription_count())
                and node.count_publishers(node.resolve_topic_name(relative(T.DIAGNOSTICS)))
                # the pacing hears the telemetry: a sample sent before this reader matched is never heard again
                and sub_fdi.get_publisher_count(), 180.0):
        sys.exit("the FDI graph did not come up within 180 s")

    def joint_state(t, field, values):
        msg = JointState(name=joints)
        msg.header.stamp = time_msg(int(round(t * 1e9)))
        setattr(msg, field, [float(v) for v in values])
        return msg

    events = sorted([(t, 0, u) for t, u in commands] + [(t, 1, w) for t, w in speeds], key=lambda e: (e[0], e[1]))
    second = 0
    for t, kind, values in events:
        if t >= second:   # paced: at most 5 s ahead of the telemetry the graph made
            if not wait(lambda: fdi_at[0] >= second - 5.0, 120.0):
                sys.exit(f"no FDI telemetry for {second - 5} s within 120 s (heard up to {fdi_at[0]} s)")
            second += 1
            if args.housekeeping:   # the driver's: the bus it sees at each wheel, one thermistor for the set
                for j in joints:
                    pub_bus.publish(BatteryState(header=Header(stamp=time_msg(int(round(t * 1e9))), frame_id=j),
                                                 voltage=8.0))
                pub_temperature.publish(Temperature(header=Header(stamp=time_msg(int(round(t * 1e9)))),
                                                    temperature=23.0))
        (pub_command if kind == 0 else pub_speed).publish(joint_state(t, "effort" if kind == 0 else "velocity",
                                                                      values))
    last = int(speeds[-1][0])
    wait(lambda: any(h[0] >= last for h in heard), 60.0)
    pub_done.publish(Header(stamp=time_msg(int(round(speeds[-1][0] * 1e9))), frame_id="completed"))
    wait(lambda: False, 1.0)
    with open(args.out, "w") as fh:
        json.dump({"heard": heard, "fdi_at": fdi_at[0], "housekeeping": carried}, fh)
    node.destroy_node()
    rclpy.shutdown()


if __name__ == "__main__":
    main()
