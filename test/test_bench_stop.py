"""A bench stops on SIGTERM (issue 38): its queued work dropped, its workers ended, in seconds, not after the
whole queue (ten minutes after SIGTERM, `rw-fdi bench detection` was still running)."""
import pytest
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)


def children_of(pid: int) -> list:
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1]) == pid:
                    out.append(int(entry.name))
            except (OSError, ValueError, IndexError):
                continue
    return out


def test_sigterm_stops_a_bench_and_its_workers_within_seconds(tmp_path):
    bench = subprocess.Popen([str(Path(sys.executable).parent / "rw-fdi"), "bench", "service", "--service-runs", "200",
                              "--fault-free-runs", "1", "--seed-set", "tuning", "--max-hours", "0.2",
                              "--out", str(tmp_path)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             env=dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"), start_new_session=True)
    workers = []
    try:
        deadline = time.monotonic() + 60.0
        while len(workers) < 2 and time.monotonic() < deadline and bench.poll() is None:
            time.sleep(0.2)
            workers = children_of(bench.pid)
        assert len(workers) >= 2, "the bench's workers did not start"
        time.sleep(2.0)   # working on their first batches, the rest queued
        t0 = time.monotonic()
        bench.send_signal(signal.SIGTERM)
        code = bench.wait(timeout=30)
        took = time.monotonic() - t0
        time.sleep(0.5)
        left = [w for w in workers if Path(f"/proc/{w}").exists()
                and "Z" not in (Path(f"/proc/{w}/stat").read_text().rsplit(")", 1)[1].split()[0])]
        assert code != 0 and took < 10.0 and not left, (code, took, left)
        assert "interrupted" in bench.stderr.read().decode()
        assert not (tmp_path / "service.json").exists()   # no report of a run cut short
    finally:
        for pid in [bench.pid, *workers]:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
