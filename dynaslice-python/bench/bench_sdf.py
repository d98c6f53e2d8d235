"""Model.sdf's rate against the Rust batch rate on the same points, in the same process.

The Rust rate is `_bench_rust_batch`: the parallel batch function `Model.sdf` calls, on packed
float32 points in Rust memory, timed inside Rust. The Python rate is `Model.sdf` called from
Python on the same points (a C-contiguous float32 array, then float64 and a strided view),
timed around the call: argument checks, GIL release, output allocation and the NumPy hand-back
included. Best of `--repeats` runs each.

    python bench/bench_sdf.py [--n 1000000] [--widths 256,256,256,256] [--classes 4]
"""

import argparse
import time

import numpy as np

import dynaslice


def best_of(repeats, fn):
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--widths", default="256,256,256,256", help="hidden widths (the paper's)")
    ap.add_argument("--classes", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--min-ratio", type=float, default=0.0,
                    help="exit 1 if the float32 ratio is below this (e.g. 0.8)")
    a = ap.parse_args()
    model = dynaslice.random_model([int(w) for w in a.widths.split(",")], a.classes, seed=1)
    t = 0.5
    rust_s, points = dynaslice._dynaslice._bench_rust_batch(model._m, a.n, t, a.repeats)
    model.sdf(points[:1000], t)  # warm-up: thread pool and per-thread scratch
    py32 = best_of(a.repeats, lambda: model.sdf(points, t))
    p64 = points.astype(np.float64)
    py64 = best_of(a.repeats, lambda: model.sdf(p64, t))
    wide = np.zeros((a.n, 4), np.float32)
    wide[:, :3] = points
    strided = best_of(a.repeats, lambda: model.sdf(wide[:, :3], t))
    print("model: widths %s, K = %d; kernels %s; N = %d points" % (a.widths, a.classes, dynaslice.kernel_name(), a.n))
    rate = lambda s: a.n / s / 1e6
    print("rust batch          %8.3f s  %8.2f M points/s" % (rust_s, rate(rust_s)))
    for name, s in (("sdf float32 packed", py32), ("sdf float64", py64), ("sdf float32 strided", strided)):
        print("%-19s %8.3f s  %8.2f M points/s  ratio %.3f" % (name, s, rate(s), rust_s / s))
    ratio = rust_s / py32
    print("ratio (python float32 / rust) = %.3f" % ratio)
    if ratio < a.min_ratio:
        raise SystemExit("ratio %.3f below %.2f" % (ratio, a.min_ratio))


if __name__ == "__main__":
    main()
