"""Two spacecraft in one ROS graph: every topic is relative, so each graph under its own namespace keeps to
itself (issue 38: ROS 2 habits).

Two whole graphs with the FDI and FDIR, one with a bus drop on wheel x and one without a fault, run at once in
one ROS domain under /sc1 and /sc2; each records exactly the bag the same run records alone without a
namespace. Cross-talk of any topic (the controllers taking the other's attitude, FDIR the other's verdict on
/diagnostics, the recorder the other's messages) would change it."""
import threading

import pytest

from rw_fdi_ros.runner.launcher import DomainLease
from rw_fdi_ros.storage.bag import bag_custom_data, read_bag
from rw_fdi_ros.storage.compare import bag_differences
from rw_fdi_ros.runner.fdi_run import run_with_fdi

pytestmark = pytest.mark.graph   # run beside the other tests, one graph test at a time (scripts/run_tests.sh)

SCENARIO = """name: {name}
duration: 60.0
seed: {seed}
faults: [{faults}]
"""
CASES = {"sc1": ("bus_x", 23_000_001, "{kind: bus_voltage, wheel: x, onset: 20.0, value: 4.0}"),
         "sc2": ("quiet", 23_000_002, "")}   # seeds disjoint from every other range


def test_two_spacecraft_share_a_ros_graph_under_namespaces_without_cross_talk(tmp_path):
    paths = {}
    for ns, (name, seed, faults) in CASES.items():
        paths[ns] = tmp_path / f"{name}.yaml"
        paths[ns].write_text(SCENARIO.format(name=name, seed=seed, faults=faults))
    together = {}
    with DomainLease() as lease:
        threads = [threading.Thread(target=lambda ns=ns: together.update({ns: run_with_fdi(
            str(paths[ns]), out_dir=tmp_path / ns, namespace=ns, domain_id=lease.domain_id)})) for ns in CASES]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=300)
    for ns in CASES:
        assert together[ns].ok, (ns, together[ns].reason)
        alone = run_with_fdi(str(paths[ns]), out_dir=tmp_path / "alone" / ns)
        assert alone.ok, alone.reason
        assert bag_differences(together[ns].bag, alone.bag) == [], ns
        assert bag_custom_data(together[ns].bag)["namespace"] == f"/{ns}"
    fdir = {ns: read_bag(together[ns].bag, topics=["/fdir/wheels"]).last("/fdir/wheels") for ns in CASES}
    states = {ns: {s.hardware_id: s.values[0].value for s in msg.status} for ns, msg in fdir.items()}
    assert states["sc1"]["reaction_wheel_x"] != "in_use"   # sc1 acted on its fault ...
    assert set(states["sc2"].values()) == {"in_use", "standby"}   # ... and sc2 on nothing
