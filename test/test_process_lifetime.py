"""The graph's processes die with the `rw-fdi` that started them (issue 39): kill -9 of it leaves none behind."""
import pytest
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


def processes_of(parent: int) -> list:
    """PIDs whose environment names ``parent`` as the launcher that started them (launcher.ros_environment)."""
    mark = f"RW_FDI_PARENT_PID={parent}".encode()
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if mark in (entry / "environ").read_bytes().split(b"\0"):
                out.append(int(entry.name))
        except OSError:   # gone, or not ours to read
            continue
    return out


def recording_run(tmp_path, settle: float):
    """`rw-fdi run` of a long scenario, returned ``settle`` seconds after its bag appeared (it records)."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    run = subprocess.Popen([str(Path(sys.executable).parent / "rw-fdi"), "run", "--scenario", "operations_hours",
                            "--no-fdi", "--out", str(tmp_path / "bags")], env=env, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + 60.0
    while not _flushed(tmp_path / "bags") and time.monotonic() < deadline and run.poll() is None:
        time.sleep(0.2)   # a chunk on disk (every 10 s of sim time): the run records, however loaded the machine
    time.sleep(settle)
    return run


def _flushed(bags: Path) -> bool:
    from rw_fdi_ros.storage.bag import BagError, bag_info
    for mcap in bags.rglob("*.mcap"):
        try:
            return sum(bag_info(mcap.parent).counts.values()) > 0
        except BagError:   # nothing flushed yet
            return False
    return False


def test_kill_9_of_rw_fdi_leaves_no_process_of_its_run_after_2_s(tmp_path):
    run = recording_run(tmp_path, settle=1.0)   # killed while it records
    try:
        nodes = processes_of(run.pid)
        assert nodes, "the graph did not start"
        run.kill()
        run.wait(timeout=10)
        time.sleep(2.0)
        left = processes_of(run.pid)
        assert not left, f"{len(left)} of the run's {len(nodes)} processes still running 2 s after kill -9"
        from rw_fdi_ros.storage.bag import bag_info
        bags = [p.parent for p in (tmp_path / "bags").rglob("*.mcap")]
        assert len(bags) == 1 and sum(bag_info(bags[0]).counts.values()) > 0   # what was recorded is readable
    finally:
        for pid in processes_of(run.pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        if run.poll() is None:
            run.kill()


def sockets_of(pids) -> list:
    """(pid, local address, port) of every UDP/TCP socket of ``pids`` (ss -tuanp)."""
    out = subprocess.run(["ss", "-tuanp"], capture_output=True, text=True, check=True).stdout
    found = []
    for line in out.splitlines()[1:]:
        for pid in pids:
            if f"pid={pid}," in line:
                address, _, port = line.split()[4].rpartition(":")
                found.append((pid, address.strip("[]"), int(port)))
    return found


def dds_listening_ports(domain: int, sockets) -> dict:
    """pid -> the ports its participant listens on in ``domain`` (RTPS 2.2 sec. 9.6.1.1: PB 7400, DG 250, PG 2,
    d0..d3 0, 10, 1, 11): discovery multicast, and the unicast pair of its participant id p, read from the pair
    it holds on loopback. Per process and per id, so that an ephemeral send port of another socket that happens
    to fall in the domain's range is not taken for a listener."""
    base = 7400 + 250 * domain
    out = {}
    for pid, address, port in sockets:
        p, odd = divmod(port - base - 10, 2)
        if address == "127.0.0.1" and 0 <= p < 120 and not odd:
            out.setdefault(pid, {base, base + 1}).update({base + 10 + 2 * p, base + 11 + 2 * p})
    return out


def test_the_graph_listens_on_loopback_only(tmp_path):
    """config/fastdds.xml: shared memory and UDP on the loopback interface (issue 39). Every port DDS listens on
    is bound to 127.0.0.1; what is left elsewhere is at most the two send sockets kilted's rmw_fastrtps adds of
    its own in LOCALHOST discovery (an unrestricted UDP transport it appends, sending to 127.0.0.1 only)."""
    run = recording_run(tmp_path, settle=1.0)
    try:
        pids = processes_of(run.pid)
        assert pids, "the graph did not start"
        domain = int(dict(line.split("=", 1) for line in Path(f"/proc/{pids[0]}/environ").read_bytes()
                          .decode(errors="replace").split("\0") if "=" in line)["ROS_DOMAIN_ID"])
        sockets = sockets_of(pids)
        listening = dds_listening_ports(domain, sockets)
        assert listening, f"no DDS port on loopback: {sockets}"
        off_loopback = [s for s in sockets if s[1] != "127.0.0.1" and s[2] in listening.get(s[0], ())]
        assert not off_loopback, off_loopback
        elsewhere = [s for s in sockets if s[1] != "127.0.0.1"]
        assert len(elsewhere) <= 2 * len(pids), elsewhere
    finally:
        run.send_signal(signal.SIGTERM)
        try:
            run.wait(timeout=20)
        except subprocess.TimeoutExpired:
            run.kill()
        for pid in processes_of(run.pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
