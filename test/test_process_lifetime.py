"""The graph's processes die with the `rw-fdi` that started them (issue 39): kill -9 of it leaves none behind."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path


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


def test_kill_9_of_rw_fdi_leaves_no_process_of_its_run_after_2_s(tmp_path):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    run = subprocess.Popen([str(Path(sys.executable).parent / "rw-fdi"), "run", "--scenario", "operations_hours",
                            "--no-fdi", "--out", str(tmp_path / "bags")], env=env, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 60.0
        while not list((tmp_path / "bags").rglob("*.mcap")) and time.monotonic() < deadline and run.poll() is None:
            time.sleep(0.1)
        time.sleep(3.0)   # killed while it records
        nodes = processes_of(run.pid)
        assert nodes, "the graph did not start"
        run.kill()
        run.wait(timeout=10)
        time.sleep(2.0)
        left = processes_of(run.pid)
        assert not left, f"{len(left)} of the run's {len(nodes)} processes still running 2 s after kill -9"
        from rw_fdi_ros.storage.bag import message_counts
        bags = [p.parent for p in (tmp_path / "bags").rglob("*.mcap")]
        assert len(bags) == 1 and sum(message_counts(bags[0]).values()) > 0   # what was recorded is readable
    finally:
        for pid in processes_of(run.pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        if run.poll() is None:
            run.kill()
