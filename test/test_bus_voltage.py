"""The wheel's bus voltage is a field of the wheel type (issue 55): a wheel on a 12-V bus is healthy at 12 V in
the plant, its nominal model is the 12-V wheel's, a bus drop on it is identified in its own volts, and the
vehicle file takes the field with its unit, defaulting to the Type A's 8 V."""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from rw_fdi_ros.core.fdi import identification as idf
from rw_fdi_ros.core.fdi.telemetry import model_reaction_torque
from rw_fdi_ros.core.mission.vehicle import VehicleError, load_vehicle
from rw_fdi_ros.core.physics import wheel as wm
from rw_fdi_ros.core.physics.faults import Fault, nominal_values, operating_points
from rw_fdi_ros.paths import config_dir

P12 = replace(wm.WheelParams(), bus_voltage=12.0)


def test_the_type_as_8_volt_wheel_keeps_the_thesis_values_exactly():
    from rw_fdi_ros.core.physics.faults import NOMINAL_VALUES
    assert nominal_values(wm.WheelParams()) == NOMINAL_VALUES and wm.nominal_point() == wm.NOMINAL
    assert idf.bus_voltage_grid(wm.WheelParams().bus_voltage) is idf.BUS_VOLTAGE_GRID   # the very grid, not a copy
    values = idf.Identification("bus_voltage", 5.5, 5.4, 5.6).values()
    assert "fault_bus_nominal_v" not in values and values["fault_size"] == "5.5"   # /diagnostics as before on 8 V


def test_a_12_volt_wheel_is_healthy_at_12_volts_and_its_model_is_the_12_volt_wheels():
    assert wm.nominal_point(P12).bus_voltage == 12.0 and nominal_values(P12)["bus_voltage"] == 12.0
    op = operating_points([[Fault("current_limiter", 1, 10.0, 0.5)]], 5.0, 3, nominal_values(P12))
    assert np.all(op["bus_voltage"] == 12.0)
    ramp = Fault("bus_voltage", 0, 0.0, 9.0, ramp=10.0)
    assert ramp.value_at(5.0, nominal_values(P12)) == pytest.approx(10.5)   # halfway from 12 V, not from 8 V
    # at high speed and full command the 8-V bridge clips where the 12-V one does not: the nominal model follows
    u, w = np.array([5.0]), np.array([180.0])
    reaction, tau_m, _ = model_reaction_torque(u, w, P12)
    expected = P12.torque_constant * wm.motor_current(u, w, 12.0, 1.0, P12)
    assert tau_m == pytest.approx(expected) and tau_m > P12.torque_constant * wm.motor_current(u, w, 8.0, 1.0, P12)
    assert wm.top_speed(P12) > wm.top_speed(wm.WheelParams())   # more headroom against the back-EMF


def test_a_bus_drop_on_a_12_volt_wheel_is_identified_in_its_own_volts():
    grid = idf.bus_voltage_grid(12.0)
    assert grid[0] == 12.0 and grid.size == idf.BUS_VOLTAGE_GRID.size and idf.bus_voltage_grid(8.0) is \
        idf.BUS_VOLTAGE_GRID
    rng = np.random.default_rng(3)
    n, value = 60, 8.25
    u, w = rng.uniform(-1.0, 4.5, n), rng.uniform(60.0, 120.0, n)   # where 8.25 V of 12 clips some commands
    tau_m = P12.torque_constant * wm.motor_current(u, w, value, 1.0, P12)
    friction = wm.friction_torque(w, 23.0, P12)
    nominal_m = P12.torque_constant * wm.motor_current(u, w, 12.0, 1.0, P12)
    bus = idf.bus_motor_torque(u, w, P12)
    ident = idf.FaultIdentifier(("x",), params=P12)
    out = None
    for k in range(n):
        sample = SimpleNamespace(reaction_torque=np.array([-(tau_m[k] - friction[k])]),
                                 motor_torque=np.array([nominal_m[k]]), friction_torque=np.array([friction[k]]),
                                 wheel_speed=np.array([w[k]]), bus_motor_torque=bus[k][None],
                                 ripple_phasor=np.array([0j]), model_torque=np.array([-(nominal_m[k] - friction[k])]),
                                 free_motor_torque=None, tcv=np.array([u[k]]))
        out = ident.update(sample, {"x": True})
    found = out["x"]
    assert found.kind == "bus_voltage", found
    assert found.size == pytest.approx(value, abs=0.02) and found.low <= value <= found.high
    assert found.bus_nominal == 12.0 and found.message().startswith("bus voltage 8.25 V")
    back = idf.Identification.from_values(found.values())
    assert back.bus_nominal == 12.0 and back.size == pytest.approx(found.size, rel=1e-5)


def _vehicle_text(**wheel_lines):
    text = (config_dir() / "vehicles" / "maksat.yaml").read_text()
    for field, line in wheel_lines.items():
        old = next(x for x in text.splitlines() if x.strip().startswith(f"{field}:"))
        text = text.replace(old, f"  {field}: {line}" if line is not None else "")
    return text


def test_a_vehicle_file_takes_the_bus_voltage_with_its_unit_and_defaults_to_the_type_as_8_volts(tmp_path):
    path = tmp_path / "v.yaml"
    path.write_text(_vehicle_text(bus_voltage="12 V"))
    vehicle = load_vehicle(str(path))
    assert vehicle.wheel.bus_voltage == 12.0
    assert dict(vehicle.dispersions.fault_sizes)["bus_voltage"] == (4.0, 5.5)   # the file's own drops kept
    path.write_text(_vehicle_text(bus_voltage=None))
    assert load_vehicle(str(path)).wheel.bus_voltage == 8.0
    path.write_text(_vehicle_text(bus_voltage="50 V"))
    with pytest.raises(VehicleError, match="bus_voltage: 50 V is beyond"):
        load_vehicle(str(path))
    path.write_text(_vehicle_text(bus_voltage="5 V"))   # the file's bus drops of 4-5.5 V are not drops of 5 V
    with pytest.raises(VehicleError, match="fault_sizes.bus_voltage: a drop is below the wheel's bus"):
        load_vehicle(str(path))


def test_a_benchs_bus_drops_keep_their_share_of_a_12_volt_bus(tmp_path):
    """The benches' bus cells are written for the Type A's 8-V bus: on a 12-V wheel a 5.5-V drop flies at 8.25 V
    (the same 31 % lost) and its row says so, and the other cells are untouched."""
    from rw_fdi_ros.tools.benches import detection_bench, identification_bench, kit, recovery_bench
    path = tmp_path / "v.yaml"
    path.write_text(_vehicle_text(bus_voltage="12 V"))
    cells = detection_bench.cells_of(str(path))
    bus = next(c for c in cells if c.kind == "bus_voltage")
    assert bus.name == "bus 8.25 V (3.75 V off)" and bus.value == pytest.approx(8.25)
    others = [c for c in detection_bench.CELLS if c.kind != "bus_voltage"]
    assert [c for c in cells if c.kind != "bus_voltage"] == others
    assert kit.cell_scenarios(bus, 1, 7, vehicle=str(path))[0].faults[0].value == pytest.approx(8.25)
    name, kind, span = identification_bench.cells_of(str(path), units=True)[2]
    assert (name, kind) == ("bus 6-8.25 V", "bus_voltage") and span == pytest.approx((6.0, 8.25))
    first = recovery_bench.vehicle_cell(recovery_bench.CELLS[0], str(path))
    assert first.name.startswith("bus 6 V") and first.value == pytest.approx(6.0)
    assert detection_bench.cells_of() == detection_bench.CELLS   # the thesis' vehicle: as written
