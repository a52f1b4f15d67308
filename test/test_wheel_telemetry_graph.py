"""The FDI graph on wheels that are not our plant (issue 57): the wheel_telemetry node makes the FDI telemetry from
a driver's JointState streams (its own joint names, 25 Hz with jitter and lost messages, no torque reported), the
shipped FDI judges it, and /diagnostics says which wheel failed, as with our plant."""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from rw_fdi_ros.fdi_config import FdiConfig
from rw_fdi_ros.core.mission.plant_choices import DEFAULT
from rw_fdi_ros.graph import topics as T
from rw_fdi_ros.runner.graph import NodeSpec, fdi_nodes, with_reader_counts
from rw_fdi_ros.runner.launcher import DomainLease, GraphProcesses, stop_processes

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

DRIVER = Path(__file__).with_name("foreign_wheels.py")
ONSET = 150.0


def test_the_fdi_names_the_failed_wheel_of_a_stream_that_is_not_our_plants(tmp_path):
    telemetry = NodeSpec("wheel_telemetry", "wheel_telemetry",
                         {"wheel_set": DEFAULT.wheel_set, "joint_names": ["rw1", "rw2", "rw3", "rw4"]})
    nodes = with_reader_counts([telemetry, *fdi_nodes(FdiConfig(), DEFAULT)])
    next(n for n in nodes if n.name == "isolation").parameters["diagnostics_readers"] = 1   # the driver
    out = tmp_path / "heard.json"
    with DomainLease() as lease:
        procs = GraphProcesses(nodes, lease.domain_id, Path(tempfile.mkdtemp(prefix="rw_fdi_test_")),
                               grouping="loop_fdi").start()
        driver = subprocess.Popen([sys.executable, str(DRIVER), str(out), "--duration", "300", "--onset", str(ONSET)],
                                  env=procs.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  start_new_session=True)
        try:
            log = driver.communicate(timeout=600)[0].decode()
            assert driver.returncode == 0, log[-2000:]
            # the FDI nodes end with the run the driver said done
            result = procs.run(main="isolation", watchdog=60, finisher=None)
            assert result.ok, result.reason
        finally:
            stop_processes([driver])
            procs.stop_all()
    heard = json.loads(out.read_text())["heard"]
    verdicts = [h for h in heard if h[1].startswith(T.VERDICT_STATUS)]
    assert max(h[0] for h in verdicts) >= 299.0   # judged to the end
    alarmed = {}
    for t, _, wheel, level, message, _ in verdicts:
        if level == 2:   # ERROR: faulty
            alarmed.setdefault(wheel, t)
    # the wheel that lost half its current, within a minute of the onset; no other wheel, never before
    assert set(alarmed) == {"reaction_wheel_y"}, alarmed
    assert ONSET < alarmed["reaction_wheel_y"] <= ONSET + 60.0, alarmed
    kinds = {h[5].get("fault_kind") for h in heard if h[1] == "rw_fdi: identification wheel y"}
    assert kinds & {"current_limiter", "current_loss"}, kinds   # what it is, from the speed alone
