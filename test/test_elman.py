"""Elman network: numpy recall mode equals torch; model files are data, and bad ones fail clearly."""
import json

import numpy as np
import pytest
import torch

from rw_fdi_ros.core.fdi.elman import ElmanObserver, ElmanWeights, ModelError, recall_series
from rw_fdi_ros.tools.design.train import torch_forward, train_axis


def weights(seed=0):
    return ElmanWeights.random(np.random.default_rng(seed), 25, scale=0.5, tcv_scale=5.0, torque_scale=0.03)


def as_torch(w):
    return [torch.tensor(getattr(w, k), dtype=torch.float64) for k in ("w_ih", "w_hh", "b_h", "w_ho", "b_o")]


def test_numpy_recall_equals_torch_recall():
    w = weights(1)
    rng = np.random.default_rng(2)
    u = rng.uniform(-5, 5, (3, 120))
    r0 = rng.uniform(-0.02, 0.02, 3)
    r = np.zeros((3, 120))
    r[:, 0] = r0
    with torch.no_grad():
        expected = torch_forward(as_torch(w), torch.tensor(u / 5.0), torch.tensor(r / 0.03), "recall").numpy() * 0.03
    got = np.stack([recall_series(w, u[b], r0[b]) for b in range(3)])
    np.testing.assert_allclose(got, expected, atol=1e-6, rtol=0)
    assert np.abs(got).max() > 1e-3   # not a trivially zero network


def test_numpy_teacher_mode_equals_torch_teacher_mode():
    w = weights(3)
    rng = np.random.default_rng(4)
    u, r = rng.uniform(-5, 5, 80), rng.uniform(-0.03, 0.03, 80)
    with torch.no_grad():
        expected = torch_forward(as_torch(w), torch.tensor(u[None] / 5), torch.tensor(r[None] / 0.03),
                                 "teacher").numpy()[0] * 0.03
    obs = ElmanObserver(w)
    obs.reset(r[0])
    got = [obs.update(u[0])] + [obs.update(u[k], r[k - 1]) for k in range(1, 80)]
    np.testing.assert_allclose(got, expected, atol=1e-6, rtol=0)


def test_training_learns_a_wheel_like_response():
    """Synthetic first-order wheel torque r = F_w(u) sampled at 1 s: both modes cut the MSE."""
    rng = np.random.default_rng(5)
    u = np.repeat(rng.uniform(-3, 3, (4, 12)), 10, axis=1)
    r = np.zeros_like(u)
    for k in range(1, u.shape[1]):
        r[:, k] = 0.95 * r[:, k - 1] - 0.004 * (u[:, k] - u[:, k - 1])
    for mode in ("teacher", "recall"):
        w, losses = train_axis(u, r, mode=mode, epochs=60, lr=0.02)
        assert losses[-1] < 0.5 * losses[0], (mode, losses[0], losses[-1])
        assert w.w_hh.shape == (25, 25)


def test_the_design_choices_size_and_loss():
    """`defaults --service --hidden N --loss huber`: the network has N hidden units, and the Huber loss is the
    squared error within HUBER_DELTA of the scaled torque and linear beyond (its first epoch's value checked
    against that, from the same start as the squared error's)."""
    from rw_fdi_ros.tools.design.train import HUBER_DELTA
    rng = np.random.default_rng(6)
    u = np.repeat(rng.uniform(-3, 3, (3, 10)), 10, axis=1)
    r = np.cumsum(-0.004 * np.diff(u, axis=1, prepend=0.0), axis=1)
    w, mse = train_axis(u, r, mode="recall", epochs=2, hidden=10)
    assert w.w_hh.shape == (10, 10) and w.w_ih.shape == (10, 2)
    _, huber = train_axis(u, r, mode="recall", epochs=2, hidden=10, loss="huber")
    # the same start (seed 0): the first epoch's e from the squared error, e^2 mean = mse[0]
    e_sq = mse[0]
    assert huber[0] <= 0.5 * e_sq + 1e-12          # 0.5 e^2 within the band, less beyond it
    assert torch.nn.functional.huber_loss(torch.tensor([2 * HUBER_DELTA]), torch.zeros(1),
                                          delta=HUBER_DELTA).item() == pytest.approx(1.5 * HUBER_DELTA**2)
    with pytest.raises(ValueError, match="loss 'l1': one of mse, huber"):
        train_axis(u, r, mode="recall", epochs=1, loss="l1")


def test_wheels_trained_at_once_are_the_trainings_one_at_a_time():
    """train_networks steps W networks together (one Python loop for all, the `defaults` training 4x shorter):
    each wheel's losses and weights are those of training it alone, in both modes, and progress comes once an
    epoch with the largest wheel loss."""
    from rw_fdi_ros.tools.design.train import train_networks
    rng = np.random.default_rng(7)
    u = np.repeat(rng.uniform(-3, 3, (3, 3, 10)), 10, axis=2)
    r = np.cumsum(-0.004 * np.diff(u, axis=2, prepend=0.0), axis=2) * np.array([1.0, 2.0, 0.5])[:, None, None]
    speed = np.abs(u) + np.array([20.0, 25.0, 30.0])[:, None, None]
    for mode, w in (("recall", speed), ("teacher", None)):
        ticks = []
        together = train_networks(u, r, mode, 6, seeds=(4, 5, 6), wheel_speed=w,
                                  progress=lambda k, loss: ticks.append(loss))
        assert len(ticks) == 6
        for i, (weights, losses) in enumerate(together):
            alone, alone_losses = train_axis(u[i], r[i], mode, 6, seed=4 + i,
                                             wheel_speed=None if w is None else w[i])
            np.testing.assert_allclose(losses, alone_losses, rtol=1e-9)
            np.testing.assert_allclose(weights.w_hh, alone.w_hh, rtol=1e-9, atol=1e-12)
            assert weights.torque_scale == alone.torque_scale
        assert ticks == [max(step) for step in zip(*(losses for _, losses in together))]


def test_save_load_roundtrip_is_npz_without_pickle(tmp_path):
    w = weights()
    w.save(tmp_path / "m.npz", {"axis": "x"})
    back = ElmanWeights.load(tmp_path / "m.npz")
    np.testing.assert_array_equal(back.w_hh, w.w_hh)
    assert json.loads((tmp_path / "m.json").read_text())["axis"] == "x"
    # the file itself: every array header names a plain dtype (no pickled objects to load)
    import zipfile
    with zipfile.ZipFile(tmp_path / "m.npz") as z:
        names = z.namelist()
        for name in names:
            with z.open(name) as f:
                major, _ = np.lib.format.read_magic(f)
                read = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
                _, _, dtype = read(f)
                assert not dtype.hasobject, name
    assert {"w_ih.npy", "w_hh.npy", "w_ho.npy"} <= set(names)


def test_bad_model_files(tmp_path):
    with pytest.raises(ModelError, match="model file not found.*rw-fdi train"):
        ElmanWeights.load(tmp_path / "nope.npz")
    (tmp_path / "corrupt.npz").write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(ModelError, match="not a readable Elman model.*rw-fdi train"):
        ElmanWeights.load(tmp_path / "corrupt.npz")
    w = weights()
    np.savez(tmp_path / "shape.npz", w_ih=np.zeros((25, 3)), w_hh=w.w_hh, b_h=w.b_h, w_ho=w.w_ho, b_o=w.b_o,
             tcv_scale=np.array(5.0), torque_scale=np.array(0.03))
    with pytest.raises(ModelError, match=r"w_ih has shape \(25, 3\), expected \(25, 2\)"):
        ElmanWeights.load(tmp_path / "shape.npz")
    np.savez(tmp_path / "pickled.npz", w_ih=np.array([object()], dtype=object))
    with pytest.raises(ModelError, match="not a readable"):
        ElmanWeights.load(tmp_path / "pickled.npz")


def test_speed_aware_network_numpy_recall_equals_torch_and_roundtrips(tmp_path):
    """Three inputs (u, own previous output, wheel speed): numpy == torch; the file keeps speed_scale."""
    w = ElmanWeights.random(np.random.default_rng(6), 25, scale=0.5, tcv_scale=5.0, torque_scale=0.03,
                            speed_scale=33.0)
    assert w.inputs == 3 and w.w_ih.shape == (25, 3)
    rng = np.random.default_rng(7)
    u, speed = rng.uniform(-5, 5, (2, 90)), rng.uniform(20, 30, (2, 90))
    r0 = rng.uniform(-0.02, 0.02, 2)
    r = np.zeros((2, 90))
    r[:, 0] = r0
    with torch.no_grad():
        expected = torch_forward(as_torch(w), torch.tensor(u / 5.0), torch.tensor(r / 0.03), "recall",
                                 torch.tensor(speed / 33.0)).numpy() * 0.03
    got = np.stack([recall_series(w, u[b], r0[b], speed[b]) for b in range(2)])
    np.testing.assert_allclose(got, expected, atol=1e-6, rtol=0)
    w.save(tmp_path / "m.npz")
    back = ElmanWeights.load(tmp_path / "m.npz")
    assert back.speed_aware and back.speed_scale == 33.0
    with pytest.raises(ValueError, match="needs the wheel speed"):
        ElmanObserver(back).update(1.0)


def test_speed_aware_network_starts_in_its_steady_state():
    """Constant inputs from t = 0 (the wheel held before the run): the first output already is the
    network's steady state, so the residual window does not carry a start-up transient."""
    from rw_fdi_ros.core.fdi.elman import ElmanWeights, recall_series
    w = ElmanWeights.random(np.random.default_rng(5), scale=0.3, speed_scale=33.0, torque_scale=0.03)
    out = recall_series(w, np.full(30, 1.2), 0.0, np.full(30, 25.0))
    assert abs(out[0]) > 1e-4                      # not the zero-state start the thesis network has
    np.testing.assert_allclose(out, out[-1], rtol=1e-5)   # a zero-state start is off by O(1)


def test_each_wheel_runs_its_own_network_or_its_types(tmp_path):
    """A model set names the wheels it has networks for (its card's ``wheels``); a wheel without one (a
    standby wheel, at rest while they were trained) runs the first of them; a set without the list is x, y, z."""
    from rw_fdi_ros.core.fdi.elman import network_path, network_wheel, network_wheels
    assert network_wheels(tmp_path) == ("x", "y", "z")
    assert network_path(tmp_path, "s").name == "elman_x.npz" and network_path(tmp_path, "z").name == "elman_z.npz"
    (tmp_path / "model_set.json").write_text(json.dumps({"wheels": ["p1", "p2", "p3", "p4"]}))
    assert network_wheels(tmp_path) == ("p1", "p2", "p3", "p4")
    assert network_path(tmp_path, "p3").name == "elman_p3.npz"
    assert network_wheel("s", ("p1", "p2")) == "p1"
    (tmp_path / "model_set.json").write_text("{not json")
    with pytest.raises(ModelError, match="not a readable model card"):
        network_wheels(tmp_path)
