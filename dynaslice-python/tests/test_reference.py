"""The same model through the command line (`dynaslice query`) and the C ABI (libdynaslice):
the bindings give their values."""

import ctypes
import subprocess

import numpy as np
import pytest

from conftest import built, points_in


def cli():
    path = built("DYNASLICE_BIN", "dynaslice")
    if path is None:
        pytest.skip("no built `dynaslice` binary (cargo build -p dynaslice-cli, or set DYNASLICE_BIN)")
    return path


def parse_query(text, k):
    """f, grad (K, 3), dfdt and the label line of `dynaslice query`'s table."""
    lines = text.strip().splitlines()
    rows = [line.split() for line in lines[1:1 + k]]
    f = np.array([float(r[-5]) for r in rows])
    grad = np.array([[float(v) for v in r[-4:-1]] for r in rows])
    dfdt = np.array([float(r[-1]) for r in rows])
    return f, grad, dfdt, lines[1 + k]


def test_values_match_the_command_line_query(model, model_path):
    exe = cli()
    pts = points_in(model, 12, seed=11)
    times = np.linspace(0.0, 1.0, 12, dtype=np.float32)
    f, g, d = model.jacobian(pts, times)
    labels = model.labels(pts, times, index=True)
    for i, (p, t) in enumerate(zip(pts, times)):
        args = [str(exe), "query", str(model_path)] + ["%r" % float(v) for v in p] + ["%r" % float(t)]
        out = subprocess.run(args, capture_output=True, text=True, check=True).stdout
        cf, cg, cd, label_line = parse_query(out, 2)
        # The command prints 6 decimals; batch and single-point kernels agree to a few ulps.
        tol = lambda v: 6e-7 + 1e-5 * np.abs(v)
        assert (np.abs(f[i] - cf) <= tol(cf)).all(), (i, f[i], cf)
        assert (np.abs(g[i] - cg) <= tol(cg)).all(), (i, g[i], cg)
        assert (np.abs(d[i] - cd) <= tol(cd)).all(), (i, d[i], cd)
        assert label_line.startswith("label %d " % labels[i]), (label_line, labels[i])


def library():
    path = built("DYNASLICE_LIBRARY", "libdynaslice.so", "libdynaslice.dylib", "dynaslice.dll")
    if path is None:
        pytest.skip("no built libdynaslice (cargo build -p dynaslice-ffi, or set DYNASLICE_LIBRARY)")
    lib = ctypes.CDLL(str(path))
    vp, fp = ctypes.c_void_p, ctypes.POINTER(ctypes.c_float)
    lib.ds_model_from_bytes.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(vp)]
    lib.ds_model_free.argtypes = [vp]
    lib.ds_eval_batch.argtypes = [vp, ctypes.c_size_t, fp, fp, fp]
    lib.ds_eval_grad_batch.argtypes = [vp, ctypes.c_size_t, fp, fp, fp, fp]
    lib.ds_label_batch.argtypes = [vp, ctypes.c_size_t, fp, fp, ctypes.POINTER(ctypes.c_uint32)]
    return lib


def test_values_match_the_c_abi_bit_for_bit(model):
    lib = library()
    data = model.to_bytes()
    handle = ctypes.c_void_p()
    assert lib.ds_model_from_bytes(data, len(data), ctypes.byref(handle)) == 0
    try:
        n = 9000  # several of the bindings' 4096-point chunks
        pts = points_in(model, n, seed=2)
        times = np.linspace(0.0, 1.0, n, dtype=np.float32)
        ptr = lambda a: a.ctypes.data_as(ctypes.POINTER(ctypes.c_float))
        f = np.empty((n, 2), np.float32)
        assert lib.ds_eval_batch(handle, n, ptr(pts), ptr(times), ptr(f)) == 0
        np.testing.assert_array_equal(model.sdf(pts, times), f)
        # float64 input rounds to the same float32 points.
        np.testing.assert_array_equal(model.sdf(pts.astype(np.float64), times.astype(np.float64)), f)
        f2, g = np.empty((n, 2), np.float32), np.empty((n, 2, 3), np.float32)
        assert lib.ds_eval_grad_batch(handle, n, ptr(pts), ptr(times), ptr(f2), ptr(g)) == 0
        np.testing.assert_array_equal(model.gradient(pts, times), g)
        labels = np.empty(n, np.uint32)
        out = labels.ctypes.data_as(ctypes.POINTER(ctypes.c_uint32))
        assert lib.ds_label_batch(handle, n, ptr(pts), ptr(times), out) == 0
        np.testing.assert_array_equal(model.labels(pts, times, index=True), labels.astype(np.int32))
    finally:
        lib.ds_model_free(handle)
