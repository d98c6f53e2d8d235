"""Checks examples/python/dynaslice.py against Rust answers (run by dynaslice-ffi/tests/hosts.rs).

Usage: check_binding.py MODEL.dsm EXPECTED.json   (DYNASLICE_LIBRARY names the library)

EXPECTED.json holds the class table and a few points with their distances, gradients,
displacements (IEEE float32 bit patterns) and labels; every value must match bit for bit.
"""

import json
import math
import struct
import sys

import dynaslice


def f32(bits):
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def refused(call, *args):
    """True when call(*args) raises DynaSliceError for a time outside the model's range."""
    try:
        call(*args)
    except dynaslice.DynaSliceError as e:
        assert e.code == dynaslice.E_TIME_OUT_OF_RANGE, (e.code, str(e))
        assert "is outside the model's time range" in str(e), str(e)
        return True
    return False


def check_time_rule(m, xyz):
    """Both edges of the time range are answered; times outside it, NaN and infinities are
    refused by every query, batches included."""
    t0, t1 = m.time_range
    span = t1 - t0
    for t in (t0, t1):
        assert all(math.isfinite(v) for v in m.eval(xyz, t))
        assert m.label(xyz, t) <= m.num_classes
    assert len(m.eval_batch([xyz, xyz], [t0, t1])) == 2
    for t in (t0 - 0.01 * span, t1 + 0.01 * span, 1e30, -math.inf, math.inf, math.nan):
        for call in (m.eval, m.eval_grad, m.label, m.displacement):
            assert refused(call, xyz, t), (call.__name__, t)
        for call in (m.eval_batch, m.label_batch):
            assert refused(call, [xyz, xyz, xyz], [t0, t, t1]), (call.__name__, t)


def main(model_path, expected_path):
    with open(expected_path) as f:
        expected = json.load(f)
    with open(model_path, "rb") as f:
        data = f.read()
    with dynaslice.Model(model_path) as m, dynaslice.Model(data=data) as from_bytes:
        assert m.classes == [tuple(c) for c in expected["classes"]], m.classes
        assert from_bytes.classes == m.classes
        lo, hi = m.bounds
        assert all(a < b for a, b in zip(lo, hi)), m.bounds
        t0, t1 = m.time_range
        assert t0 < t1
        points, times = [], []
        for case in expected["cases"]:
            xyz = [f32(b) for b in case["xyz"]]
            t = f32(case["t"])
            want_f = [f32(b) for b in case["f"]]
            want_g = [f32(b) for b in case["grad"]]
            assert m.eval(xyz, t) == want_f, (m.eval(xyz, t), want_f)
            f, g = m.eval_grad(xyz, t)
            assert f == want_f and [c for row in g for c in row] == want_g, (f, g)
            assert m.label(xyz, t) == case["label"]
            want_u = tuple(f32(b) for b in case["displacement"])
            assert m.displacement(xyz, t) == want_u, (m.displacement(xyz, t), want_u)
            assert from_bytes.eval(xyz, t) == want_f
            points.append(xyz)
            times.append(t)
        batch = m.eval_batch(points, times)
        for row, case in zip(batch, expected["cases"]):
            for got, want in zip(row, case["f"]):
                assert abs(got - f32(want)) <= 2e-4 * max(1.0, abs(f32(want))), (got, want)
        assert m.label_batch(points, times) == [c["label"] for c in expected["cases"]]
        assert m.label((math.nan, 0.0, 0.0), t0) == dynaslice.LABEL_UNDEFINED
        check_time_rule(m, points[0])
        try:
            m.eval_batch(points, times[:-1])
        except ValueError:
            pass
        else:
            raise AssertionError("mismatched batch lengths accepted")
    try:
        dynaslice.Model(data=data[: len(data) // 2])
    except dynaslice.DynaSliceError as e:
        assert e.code == -3 and "truncated" in str(e), (e.code, str(e))
    else:
        raise AssertionError("a truncated model loaded")
    try:
        m.eval(points[0], times[0])
    except ValueError:
        pass
    else:
        raise AssertionError("a closed model answered")
    print("python binding: ok (%d classes, %d points)" % (len(expected["classes"]), len(points)))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
