"""C-ABI example: a ctypes binding of the DynaSlice C library (libdynaslice), no dependencies.

This is not the Python package. For NumPy batch queries, gradients, ∂f/∂t, meshes, label
volumes and training, install the package instead: ``pip install ./dynaslice-python``
(docs/python.md). This file stays as the C ABI's Python example, for hosts that can load a
shared library but not install a wheel, and the C ABI's tests run it (dynaslice-ffi/tests).
Do not put this folder on ``sys.path`` next to the installed package: both are ``dynaslice``.

Loadable from any Python 3 (3D Slicer's Python console included)::

    import sys; sys.path.append("/path/to/dynaslice/examples/python")
    import dynaslice
    with dynaslice.Model("heart.dsm") as m:
        print(m.classes)                    # [(name, source label), ...]
        print(m.eval((12.0, -3.5, 40.0), 0.3))    # K signed distances, world units
        print(m.label((12.0, -3.5, 40.0), 0.3))   # 0 background, k class k

The library is found through the DYNASLICE_LIBRARY environment variable (a path), else the
system loader's search (an installed libdynaslice), else a workspace build next to this file
(target/release, then target/debug). Every failure raises DynaSliceError with the C code and the
library's detail message. Every query at a time outside the model's `time_range` (NaN and
infinities included) raises DynaSliceError with code E_TIME_OUT_OF_RANGE, as the C library
refuses it. See docs/c-api.md for units, ownership, threading and the time rule.
"""

import ctypes
import ctypes.util
import os

__all__ = ["DynaSliceError", "Model", "LABEL_UNDEFINED", "E_TIME_OUT_OF_RANGE", "load_library"]

#: The label reported for NaN or infinite points (DS_LABEL_UNDEFINED).
LABEL_UNDEFINED = 0xFFFFFFFF

#: DynaSliceError.code of a query at a time outside the model's time range
#: (DS_E_TIME_OUT_OF_RANGE).
E_TIME_OUT_OF_RANGE = -11

_c_float_p = ctypes.POINTER(ctypes.c_float)
_c_uint32_p = ctypes.POINTER(ctypes.c_uint32)


class DynaSliceError(RuntimeError):
    """A failed library call: `code` is the negative DS_E_* value."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


def _candidates():
    env = os.environ.get("DYNASLICE_LIBRARY")
    if env:
        return [env]
    found = ctypes.util.find_library("dynaslice")
    here = os.path.dirname(os.path.abspath(__file__))
    names = {"nt": "dynaslice.dll", "posix": "libdynaslice.so"}
    name = names.get(os.name, "libdynaslice.dylib")
    built = [os.path.join(here, "..", "..", "target", p, name) for p in ("release", "debug")]
    return ([found] if found else []) + built


def load_library(path=None):
    """Loads libdynaslice (see the module docstring for where it is looked for)."""
    errors = []
    for candidate in [path] if path else _candidates():
        try:
            lib = ctypes.CDLL(candidate)
            break
        except OSError as e:
            errors.append("%s: %s" % (candidate, e))
    else:
        raise OSError("libdynaslice not found (set DYNASLICE_LIBRARY): " + "; ".join(errors))
    model_p = ctypes.c_void_p
    sigs = {
        "ds_model_open": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(model_p)]),
        "ds_model_from_bytes": (
            ctypes.c_int,
            [ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(model_p)],
        ),
        "ds_model_free": (None, [model_p]),
        "ds_num_classes": (ctypes.c_uint32, [model_p]),
        "ds_class_name": (
            ctypes.c_int,
            [model_p, ctypes.c_uint32, ctypes.c_char_p, ctypes.c_size_t],
        ),
        "ds_class_label": (
            ctypes.c_int,
            [model_p, ctypes.c_uint32, ctypes.POINTER(ctypes.c_int32)],
        ),
        "ds_metadata": (ctypes.c_int, [model_p, ctypes.c_char_p, ctypes.c_size_t]),
        "ds_time_range": (ctypes.c_int, [model_p, _c_float_p, _c_float_p]),
        "ds_bounds": (ctypes.c_int, [model_p, _c_float_p, _c_float_p]),
        "ds_eval": (
            ctypes.c_int,
            [model_p, _c_float_p, ctypes.c_float, _c_float_p, ctypes.c_size_t],
        ),
        "ds_eval_grad": (
            ctypes.c_int,
            [model_p, _c_float_p, ctypes.c_float, _c_float_p, _c_float_p, ctypes.c_size_t],
        ),
        "ds_label": (ctypes.c_int, [model_p, _c_float_p, ctypes.c_float, _c_uint32_p]),
        "ds_displacement": (ctypes.c_int, [model_p, _c_float_p, ctypes.c_float, _c_float_p]),
        "ds_eval_batch": (
            ctypes.c_int,
            [model_p, ctypes.c_size_t, _c_float_p, _c_float_p, _c_float_p],
        ),
        "ds_label_batch": (
            ctypes.c_int,
            [model_p, ctypes.c_size_t, _c_float_p, _c_float_p, _c_uint32_p],
        ),
        "ds_error_string": (ctypes.c_char_p, [ctypes.c_int]),
        "ds_last_error_message": (ctypes.c_char_p, []),
        "ds_version": (ctypes.c_char_p, []),
    }
    for name, (restype, argtypes) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = restype
        fn.argtypes = argtypes
    return lib


class Model:
    """A loaded model: from a file path, or from `data` (bytes) when `path` is None.

    Immutable: one Model may be queried from many Python threads (ctypes releases the GIL
    during each call). Close it with close() or a `with` block; queries after that raise.
    """

    def __init__(self, path=None, data=None, library=None):
        self._lib = library or load_library()
        handle = ctypes.c_void_p()
        if path is not None:
            rc = self._lib.ds_model_open(os.fsencode(path), ctypes.byref(handle))
        elif data is not None:
            data = bytes(data)
            rc = self._lib.ds_model_from_bytes(data, len(data), ctypes.byref(handle))
        else:
            raise ValueError("give a path or data")
        self._check(rc)
        self._handle = handle
        self.num_classes = self._lib.ds_num_classes(handle)

    # -- lifetime -----------------------------------------------------------------------------
    def close(self):
        """Frees the model (idempotent)."""
        handle, self._handle = getattr(self, "_handle", None), None
        if handle:
            self._lib.ds_model_free(handle)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()

    def _model(self):
        if not self._handle:
            raise ValueError("the model is closed")
        return self._handle

    def _check(self, rc):
        if rc < 0:
            detail = self._lib.ds_last_error_message().decode("utf-8", "replace")
            raise DynaSliceError(rc, detail or self._lib.ds_error_string(rc).decode())
        return rc

    # -- description --------------------------------------------------------------------------
    def _string(self, fn, *args):
        n = self._check(fn(self._model(), *args, None, 0))
        buf = ctypes.create_string_buffer(n + 1)
        self._check(fn(self._model(), *args, buf, n + 1))
        return buf.value.decode("utf-8")

    @property
    def classes(self):
        """[(name, source label value)] for classes 1..K."""
        out = []
        for k in range(1, self.num_classes + 1):
            label = ctypes.c_int32()
            self._check(self._lib.ds_class_label(self._model(), k, ctypes.byref(label)))
            out.append((self._string(self._lib.ds_class_name, k), label.value))
        return out

    @property
    def metadata(self):
        """The trainer's free-form metadata (UTF-8 text)."""
        return self._string(self._lib.ds_metadata)

    @property
    def bounds(self):
        """((xmin, ymin, zmin), (xmax, ymax, zmax)) in world units."""
        lo, hi = (ctypes.c_float * 3)(), (ctypes.c_float * 3)()
        self._check(self._lib.ds_bounds(self._model(), lo, hi))
        return tuple(lo), tuple(hi)

    @property
    def time_range(self):
        """(t_min, t_max) in world time units: the times queries are answered at (to a rounding
        slack of 1e-4 of the range); any other time raises E_TIME_OUT_OF_RANGE."""
        t0, t1 = ctypes.c_float(), ctypes.c_float()
        self._check(self._lib.ds_time_range(self._model(), ctypes.byref(t0), ctypes.byref(t1)))
        return t0.value, t1.value

    # -- queries ------------------------------------------------------------------------------
    def eval(self, xyz, t):
        """The K signed distances at world point xyz (3 numbers) and time t."""
        f = (ctypes.c_float * self.num_classes)()
        self._check(self._lib.ds_eval(self._model(), (ctypes.c_float * 3)(*xyz), t, f, len(f)))
        return list(f)

    def eval_grad(self, xyz, t):
        """(distances, gradients): K values and K (dx, dy, dz) tuples, world units."""
        k = self.num_classes
        f, g = (ctypes.c_float * k)(), (ctypes.c_float * (3 * k))()
        point = (ctypes.c_float * 3)(*xyz)
        self._check(self._lib.ds_eval_grad(self._model(), point, t, f, g, k))
        return list(f), [tuple(g[3 * i : 3 * i + 3]) for i in range(k)]

    def label(self, xyz, t):
        """Eq. 11 label: 0 background, k class k, LABEL_UNDEFINED for NaN/inf points."""
        out = ctypes.c_uint32()
        point = (ctypes.c_float * 3)(*xyz)
        self._check(self._lib.ds_label(self._model(), point, t, ctypes.byref(out)))
        return out.value

    def displacement(self, xyz, t):
        """A motion model's displacement u at (xyz, t), world units: xyz + u is the point's
        canonical (reference-shape) position. (0, 0, 0) for a model without motion."""
        out = (ctypes.c_float * 3)()
        point = (ctypes.c_float * 3)(*xyz)
        self._check(self._lib.ds_displacement(self._model(), point, t, out))
        return tuple(out)

    @staticmethod
    def _batch_inputs(points, times):
        points = [tuple(p) for p in points]
        times = list(times)
        if len(times) != len(points) or any(len(p) != 3 for p in points):
            raise ValueError("points must be (x, y, z) triples, one time per point")
        xyz = (ctypes.c_float * (3 * len(points)))(*[c for p in points for c in p])
        return len(points), xyz, (ctypes.c_float * len(times))(*times)

    def eval_batch(self, points, times):
        """Distances at many points: a list of K-value lists, one per (point, time). One time
        outside the range refuses the whole batch (E_TIME_OUT_OF_RANGE)."""
        n, xyz, t = self._batch_inputs(points, times)
        k = self.num_classes
        f = (ctypes.c_float * (n * k))()
        self._check(self._lib.ds_eval_batch(self._model(), n, xyz, t, f))
        return [list(f[i * k : (i + 1) * k]) for i in range(n)]

    def label_batch(self, points, times):
        """Eq. 11 labels at many points."""
        n, xyz, t = self._batch_inputs(points, times)
        out = (ctypes.c_uint32 * n)()
        self._check(self._lib.ds_label_batch(self._model(), n, xyz, t, out))
        return list(out)

