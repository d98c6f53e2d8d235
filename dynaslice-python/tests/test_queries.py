"""Batch queries: shapes, dtypes, input layouts, t as a number or an array, errors."""

import threading
import time

import numpy as np
import pytest

import dynaslice
from conftest import points_in

N = 10_000  # crosses several 4096-point chunks and a partial one


def test_description(model, model_path):
    loaded = dynaslice.Model.load(model_path)
    assert loaded.num_classes == 2
    assert loaded.classes == [(name, label, None) for name, label, _ in model.classes]
    assert len(loaded.classes) == 2 and all(c[2] is None for c in loaded.classes)
    # No recorded colours: the palette's first two (Tableau 10), as the command line shows them.
    assert loaded.class_colors == [(0x1F, 0x77, 0xB4), (0xFF, 0x7F, 0x0E)]
    lo, hi = loaded.bounds
    assert len(lo) == len(hi) == 3 and all(a < b for a, b in zip(lo, hi))
    t0, t1 = loaded.time_range
    assert t0 < t1
    assert loaded.frame == "RAS"
    assert "random" in loaded.metadata
    assert dynaslice.Model.from_bytes(model_path.read_bytes()).to_bytes() == model_path.read_bytes()


def test_shapes_and_dtypes(model):
    p = points_in(model, N)
    f = model.sdf(p, 0.3)
    assert f.shape == (N, 2) and f.dtype == np.float32
    g = model.gradient(p, 0.3)
    assert g.shape == (N, 2, 3) and g.dtype == np.float32
    d = model.dfdt(p, 0.3)
    assert d.shape == (N, 2) and d.dtype == np.float32
    lab = model.labels(p, 0.3)
    assert lab.shape == (N,) and lab.dtype == np.int32
    assert model.sdf(np.zeros((0, 3)), 0.0).shape == (0, 2)
    assert model.labels(np.zeros((0, 3)), 0.0).shape == (0,)


def test_layouts_give_identical_values(model):
    p32 = points_in(model, N)
    reference = model.sdf(p32, 0.25)
    # float64 holding exactly the float32 values, and strided views of both.
    p64 = p32.astype(np.float64)
    wide = np.zeros((N, 6), dtype=np.float32)
    wide[:, ::2] = p32
    fortran = np.asfortranarray(p32)
    for p in (p64, wide[:, ::2], fortran, p64[::-1][::-1], p32.tolist()):
        np.testing.assert_array_equal(model.sdf(p, 0.25), reference)
    np.testing.assert_array_equal(model.sdf(p32[::2], 0.25), reference[::2])


def test_t_scalar_and_array_agree(model):
    p = points_in(model, N)
    t = 0.4
    f = model.sdf(p, t)
    for ts in (np.full(N, t, np.float32), np.full(N, t, np.float64), np.full(2 * N, t)[::2],
               np.float32(t), np.array(t), [t] * N):
        np.testing.assert_array_equal(model.sdf(p, ts), f)
    # A time per point: each row as if queried alone at its time.
    times = np.linspace(0.0, 1.0, N)
    f_mixed = model.sdf(p, times)
    for i in (0, 4095, 4096, N - 1):
        np.testing.assert_array_equal(f_mixed[i], model.sdf(p[i:i + 1], times[i])[0])
    np.testing.assert_array_equal(model.dfdt(p, times)[17], model.dfdt(p[17:18], times[17])[0])


def test_derivatives_match_finite_differences(model):
    p = points_in(model, 50, seed=3).astype(np.float64)
    t, h = 0.5, 1e-3
    g = model.gradient(p, t)
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        fd = (model.sdf(p + e, t).astype(np.float64) - model.sdf(p - e, t)) / (2 * h)
        np.testing.assert_allclose(g[:, :, a], fd, atol=2e-2 * max(1.0, np.abs(fd).max()))
    fd_t = (model.sdf(p, t + h).astype(np.float64) - model.sdf(p, t - h)) / (2 * h)
    np.testing.assert_allclose(model.dfdt(p, t), fd_t, atol=2e-2 * max(1.0, np.abs(fd_t).max()))


def test_jacobian_agrees_with_single_queries(model):
    p = points_in(model, N, seed=5)
    f, g, d = model.jacobian(p, 0.7)
    np.testing.assert_allclose(f, model.sdf(p, 0.7), rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(d, model.dfdt(p, 0.7))
    np.testing.assert_allclose(g, model.gradient(p, 0.7), rtol=1e-5, atol=1e-6)


def test_labels_are_eq11_argmin_with_label_values(model):
    p = points_in(model, N, seed=9)
    f = model.sdf(p, 0.1)
    expected_index = np.where(f.min(axis=1) < 0, f.argmin(axis=1) + 1, 0)
    # Ties between the background's 0 and a channel are measure-zero here.
    index = model.labels(p, 0.1, index=True)
    np.testing.assert_array_equal(index, expected_index)
    values = np.array([0] + [label for _, label, _ in model.classes], dtype=np.int32)
    np.testing.assert_array_equal(model.labels(p, 0.1), values[index])
    assert set(np.unique(index)) == {0, 1, 2}, "the fixture should show every label"


def test_displacement_of_both_kinds(model):
    p = points_in(model, N, seed=11)
    # Without motion: zero everywhere.
    u = model.displacement(p, 0.3)
    assert u.shape == (N, 3) and u.dtype == np.float32
    assert not u.any()
    # A motion model: the offset to the canonical position, per point and time, every chunk
    # as if queried alone; its distances and derivatives through the same calls.
    moving = dynaslice.random_model([32, 32], 2, seed=7, motion_widths=[16, 16])
    times = np.linspace(0.0, 1.0, N)
    u = moving.displacement(p, times)
    assert u.shape == (N, 3) and np.isfinite(u).all() and np.abs(u).max() > 1e-3
    for i in (0, 4095, 4096, N - 1):
        np.testing.assert_array_equal(u[i], moving.displacement(p[i:i + 1], times[i])[0])
    f, g, d = moving.jacobian(p, 0.4)
    assert f.shape == (N, 2) and g.shape == (N, 2, 3) and d.shape == (N, 2)
    assert moving.displacement(np.zeros((0, 3)), 0.0).shape == (0, 3)
    with pytest.raises(ValueError, match="outside the model's time range"):
        moving.displacement(p, 2.0)


def test_bad_inputs_raise_value_errors(model):
    p = points_in(model, 10)
    with pytest.raises(ValueError, match=r"shape \(N, 3\), not \[10, 2\]"):
        model.sdf(p[:, :2], 0.0)
    with pytest.raises(ValueError, match=r"shape \(N, 3\), not \[30\]"):
        model.sdf(p.ravel(), 0.0)
    with pytest.raises(ValueError, match="points must be float32 or float64, not int64"):
        model.sdf(p.astype(np.int64), 0.0)
    with pytest.raises(ValueError, match=r"shape \(10,\), one time per point, not \[9\]"):
        model.sdf(p, np.zeros(9))
    with pytest.raises(ValueError, match="t must be float32 or float64"):
        model.sdf(p, np.zeros(10, dtype=np.int32))
    with pytest.raises(ValueError, match="t must be a number"):
        model.sdf(p, "soon")
    nan = p.copy()
    nan[4, 1] = np.nan
    assert np.isnan(model.sdf(nan, 0.0)[4]).all()
    with pytest.raises(ValueError, match="no label at point 4"):
        model.labels(nan, 0.0)


def test_file_errors_are_dynaslice_errors(tmp_path):
    with pytest.raises(dynaslice.DynasliceError, match="cannot read model .*missing.dsm"):
        dynaslice.Model.load(tmp_path / "missing.dsm")
    bad = tmp_path / "bad.dsm"
    bad.write_bytes(b"not a model at all" * 10)
    with pytest.raises(dynaslice.DynasliceError, match="bad.dsm: "):
        dynaslice.Model.load(bad)
    with pytest.raises(dynaslice.DynasliceError, match="model bytes: "):
        dynaslice.Model.from_bytes(b"\0" * 64)
    assert issubclass(dynaslice.DynasliceError, Exception)


def test_the_gil_is_released_during_a_query():
    model = dynaslice.random_model([256, 256, 256], 4, seed=1)
    p = points_in(model, 400_000)
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    thread = threading.Thread(target=count)
    thread.start()
    time.sleep(0.01)
    start = time.perf_counter()
    model.sdf(p, 0.5)
    end = time.perf_counter()
    done.set()
    thread.join()
    during = [x for x in ticks if start < x < end]
    # Holding the GIL would starve the counter for the whole call (switch interval 5 ms).
    assert end - start > 0.05, "the query should take long enough to tell"
    assert len(during) >= 5, "%d ticks in %.3f s" % (len(during), end - start)
