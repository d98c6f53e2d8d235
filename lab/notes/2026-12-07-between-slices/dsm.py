"""A DynaSlice model file (docs/model-format.md) evaluated with NumPy: f of every channel, in
world units, at many world points at once (`dynaslice query` answers one point a process).
Checked against `dynaslice query` by `check` below.

    python3 dsm.py check MODEL X Y Z T      # prints f per channel; compare with dynaslice query
"""
import struct
import sys

import numpy as np


class Model:
    def __init__(self, path):
        b = open(path, "rb").read()
        assert b[:8] == b"DYNSLICE", path
        dtype, k, nl = struct.unpack_from("<III", b, 24)
        widths = struct.unpack_from("<8I", b, 40)[:nl]
        self.center = np.array(struct.unpack_from("<3f", b, 72), np.float64)
        self.scale = np.array(struct.unpack_from("<3f", b, 84), np.float64)
        self.t0, self.tspan, self.sigma, self.wt_max = struct.unpack_from("<4f", b, 96)
        woff, n = struct.unpack_from("<QQ", b, 136)
        w = np.frombuffer(b, np.float16 if dtype else np.float32, n, woff).astype(np.float64)
        self.layers = []
        fan_in, o = 4, 0
        for fan_out in list(widths) + [k]:
            wt = w[o : o + fan_in * fan_out].reshape(fan_in, fan_out).copy()
            o += fan_in * fan_out
            bias = w[o : o + fan_out]
            o += fan_out
            self.layers.append((wt, bias))
            fan_in = fan_out
        wt0 = self.layers[0][0]
        wt0[3] = np.clip(wt0[3], -self.wt_max, self.wt_max)  # Eq. 4's clamp of ω_t
        self.k = k

    def f(self, xyz, t):
        """f (world units) of every channel at world points `xyz` (N × 3) and time `t`."""
        xn = (np.asarray(xyz, np.float64) - self.center) / self.scale
        tn = np.full((xn.shape[0], 1), (t - self.t0) / self.tspan)
        h = np.hstack([xn, tn])
        for wt, b in self.layers[:-1]:
            h = np.sin(h @ wt + b)
        wt, b = self.layers[-1]
        return self.sigma * (h @ wt + b)


if __name__ == "__main__":
    if len(sys.argv) == 7 and sys.argv[1] == "check":
        m = Model(sys.argv[2])
        x = [float(v) for v in sys.argv[3:6]]
        print(m.f(np.array([x]), float(sys.argv[6]))[0])
    else:
        sys.exit(__doc__)
