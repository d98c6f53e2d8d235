"""DynaSlice from Python: query, mesh and train 4D multi-class neural signed distance functions.

A DynaSlice model is one network f: R³ × [t₀, t₁] → R^K with one signed distance per anatomical
structure (negative inside), in the world frame of the images it was trained on (NIfTI's RAS,
millimetres as a rule). This package wraps the Rust libraries the ``dynaslice`` command line
uses; every batch call releases the GIL and runs on all cores::

    import numpy as np, dynaslice
    model = dynaslice.Model.load("heart.dsm")
    f = model.sdf(np.array([[12.0, -3.5, 40.0]]), t=0.3)        # (1, K) float32
    labels = model.labels(points, t)                              # (N,) int32 label values
    v, faces, vn = model.mesh(0.3, cls="LV")                      # arrays, or .to_trimesh()
    vol = model.label_volume(like="frame.nii.gz")                 # (x, y, z[, t]) int32
    model = dynaslice.train("sections.json", "heart.dsm", steps=3000)

See docs/python.md for the whole API.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import threading
from typing import Any, Callable, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _dynaslice
from ._dynaslice import DynasliceError, kernel_name

__all__ = [
    "DynasliceError",
    "Mesh",
    "Model",
    "kernel_name",
    "random_model",
    "train",
    "__version__",
]

__version__: str = _dynaslice.__version__

PathLike = Union[str, "os.PathLike[str]"]
ArrayLike = Any  # an (N, 3) float32/float64 array, or anything np.asarray accepts


def _points(points: ArrayLike) -> np.ndarray:
    """NumPy arrays go to Rust as they are (any strides, float32 or float64; other dtypes are
    refused there with a ValueError); lists and tuples become float64 arrays."""
    if isinstance(points, np.ndarray):
        return points
    return np.asarray(points, dtype=np.float64)


def _times(t: Union[float, ArrayLike]) -> Any:
    """Lists and tuples become float64 arrays; anything else goes to Rust as it is (numbers,
    arrays; other types are refused there with a ValueError)."""
    if isinstance(t, (list, tuple)):
        return np.asarray(t, dtype=np.float64)
    return t


class Mesh:
    """One class's surface at one time, in world coordinates.

    Attributes: ``vertices`` (V, 3) float32, ``faces`` (F, 3) int64 (counter-clockwise seen
    from outside), ``normal_velocity`` (V,) float32 (world units per time unit, positive where
    the surface moves outwards), ``normals`` (V, 3) float32 (unit, outwards), ``name`` and
    ``label`` of the class, ``time``, and ``color``, the class's display colour (r, g, b)
    (:attr:`Model.class_colors`). Unpacks as ``vertices, faces, normal_velocity``.
    """

    def __init__(
        self,
        name: str,
        label: int,
        time: float,
        vertices: np.ndarray,
        faces: np.ndarray,
        normals: np.ndarray,
        normal_velocity: np.ndarray,
        color: Tuple[int, int, int] = (128, 128, 128),
    ) -> None:
        self.name = name
        self.label = label
        self.time = time
        self.vertices = vertices
        self.faces = faces
        self.normals = normals
        self.normal_velocity = normal_velocity
        self.color = color

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.vertices, self.faces, self.normal_velocity))

    def __repr__(self) -> str:
        return "<dynaslice.Mesh %r (label %d) at t=%g: %d vertices, %d faces>" % (
            self.name,
            self.label,
            self.time,
            len(self.vertices),
            len(self.faces),
        )

    def to_trimesh(self) -> Any:
        """A ``trimesh.Trimesh`` with the normals, ``vertex_attributes['normal_velocity']`` and
        the class colour as vertex colours (needs ``pip install trimesh``)."""
        try:
            import trimesh
        except ImportError as e:
            raise ImportError("Mesh.to_trimesh needs trimesh: pip install trimesh") from e
        return trimesh.Trimesh(
            vertices=self.vertices,
            faces=self.faces,
            vertex_normals=self.normals,
            vertex_attributes={"normal_velocity": self.normal_velocity},
            vertex_colors=np.tile(np.array([*self.color, 255], dtype=np.uint8),
                                  (len(self.vertices), 1)),
            process=False,
        )

    def to_pyvista(self) -> Any:
        """A ``pyvista.PolyData`` with point data ``Normals``, ``normal_velocity`` and
        ``Colors`` (the class colour, uint8 RGB: ``plotter.add_mesh(poly, rgb=True)`` shows
        it) (needs ``pip install pyvista``)."""
        try:
            import pyvista
        except ImportError as e:
            raise ImportError("Mesh.to_pyvista needs pyvista: pip install pyvista") from e
        cells = np.hstack([np.full((len(self.faces), 1), 3, dtype=np.int64), self.faces])
        poly = pyvista.PolyData(np.asarray(self.vertices, dtype=np.float32), cells.ravel())
        poly.point_data["Normals"] = self.normals
        poly.point_data["normal_velocity"] = self.normal_velocity
        poly.point_data["Colors"] = np.tile(np.array(self.color, dtype=np.uint8),
                                            (len(self.vertices), 1))
        return poly


class Model:
    """A DynaSlice model (a ``.dsm`` file): K signed distances over space and time.

    Make one with :meth:`Model.load`, :meth:`Model.from_bytes` or :func:`train`. Immutable and
    thread-safe. Queries take points as an (N, 3) float32 or float64 array (any strides; a
    C-contiguous float32 array is read in place) and a time ``t``: one number for all points
    or an (N,) array. The GIL is released while they run, on all cores (cap them with the
    ``RAYON_NUM_THREADS`` environment variable before the first query).
    """

    #: The world frame of the model's coordinates: NIfTI's RAS+ (x increases to the patient's
    #: right, y to anterior, z to superior), the frame nibabel's ``affine`` maps voxels into.
    frame = "RAS"

    def __init__(self, native: "_dynaslice.Model") -> None:
        """Wraps a native model; use :meth:`load`, :meth:`from_bytes` or :func:`train`."""
        self._m = native

    @classmethod
    def load(cls, path: PathLike) -> "Model":
        """Reads and validates a model file; DynasliceError names the file and the problem."""
        return cls(_dynaslice.Model.load(os.fspath(path)))

    @classmethod
    def from_bytes(cls, data: bytes) -> "Model":
        """Validates a model file's bytes."""
        return cls(_dynaslice.Model.from_bytes(bytes(data)))

    def to_bytes(self) -> bytes:
        """The model file's bytes (what :meth:`from_bytes` takes)."""
        return self._m.to_bytes()

    def save(self, path: PathLike) -> None:
        """Writes the model file to ``path``."""
        with open(path, "wb") as f:
            f.write(self._m.to_bytes())

    # -- description ---------------------------------------------------------------------
    @property
    def num_classes(self) -> int:
        """K, the number of classes."""
        return self._m.num_classes

    @property
    def classes(self) -> List[Tuple[str, int, Optional[Tuple[int, int, int]]]]:
        """``[(name, label value, colour)]`` for classes 1..K in channel order. The label value
        is the class's number in its source segmentation; the colour (r, g, b) is the one the
        training input gave the class (an RTSTRUCT ROI Display Color, a ``.seg.nrrd`` segment
        colour, a ``color`` in native JSON), or None where it gave none."""
        return self._m.class_records

    @property
    def class_colors(self) -> List[Tuple[int, int, int]]:
        """``[(r, g, b)]`` for classes 1..K: the colour each class is shown in, its input's
        colour (:attr:`classes`) or else DynaSlice's palette colour for its channel; the
        colours of the command line's mesh files, colour tables and pictures."""
        return self._m.class_colors

    @property
    def bounds(self) -> Tuple[Tuple[float, float, float], Tuple[float, float, float]]:
        """``((xmin, ymin, zmin), (xmax, ymax, zmax))``: the training domain, world units."""
        lo, hi = self._m.bounds
        return tuple(lo), tuple(hi)  # type: ignore[return-value]

    @property
    def time_range(self) -> Tuple[float, float]:
        """``(t_min, t_max)``: the times the model was trained on; ``(t, t)`` for a static
        model, which answers any time at its one time t."""
        return self._m.time_range

    @property
    def is_static(self) -> bool:
        """Whether the model is static: trained on one timestep, the same at every time. It
        has no time axis: queries, meshes and label volumes at any time are computed at its
        one time (one frame), with a note on the ``_dynaslice.model`` logger."""
        return self._m.is_static

    @property
    def metadata(self) -> str:
        """The trainer's record of the run (``key = value`` lines)."""
        return self._m.metadata

    def __repr__(self) -> str:
        return repr(self._m)

    # -- batch queries -------------------------------------------------------------------
    def sdf(self, points: ArrayLike, t: Union[float, ArrayLike]) -> np.ndarray:
        """Signed distances f: (N, K) float32, world units, negative inside class k."""
        return self._m.sdf(_points(points), _times(t))

    def gradient(self, points: ArrayLike, t: Union[float, ArrayLike]) -> np.ndarray:
        """Exact spatial gradients ∇ₓf: (N, K, 3) float32."""
        return self._m.gradient(_points(points), _times(t))

    def dfdt(self, points: ArrayLike, t: Union[float, ArrayLike]) -> np.ndarray:
        """Exact time derivatives ∂f/∂t: (N, K) float32, world units per time unit."""
        return self._m.dfdt(_points(points), _times(t))

    def jacobian(
        self, points: ArrayLike, t: Union[float, ArrayLike]
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(f, ∇ₓf, ∂f/∂t)`` in one pass: (N, K), (N, K, 3), (N, K) float32."""
        return self._m.jacobian(_points(points), _times(t))

    def displacement(self, points: ArrayLike, t: Union[float, ArrayLike]) -> np.ndarray:
        """A motion model's displacement u: (N, 3) float32, world units, the offset that
        carries each point at its time to its canonical (reference-shape) position, where the
        model's one shape is read (f(x, t) = g(x + u, t)). Zero for a model without motion."""
        return self._m.displacement(_points(points), _times(t))

    def labels(
        self, points: ArrayLike, t: Union[float, ArrayLike], *, index: bool = False
    ) -> np.ndarray:
        """Eq. 11 labels, (N,) int32: argmin over (0, f¹, …, f^K), as the classes' label
        values (0 for background). ``index=True`` gives class numbers 0..K instead. A
        ValueError names the first point where the model is not finite (NaN input)."""
        return self._m.labels(_points(points), _times(t), index)

    # -- surfaces and volumes ------------------------------------------------------------
    def mesh(
        self,
        t: float,
        cls: Union[None, int, str, Sequence[Union[int, str]]] = None,
        resolution: int = _dynaslice.DEFAULT_RESOLUTION,
        *,
        non_overlapping: bool = False,
        newton_steps: int = 1,
        safety: float = 1.5,
        dense: bool = False,
        threads: Optional[int] = None,
    ) -> Union[Mesh, List[Mesh]]:
        """Closed surfaces at time ``t``, as ``dynaslice mesh`` extracts them.

        ``cls``: a class number (1..K) or name gives one :class:`Mesh`; None (every class) or
        a list gives a list in that order. ``resolution``: lattice cells along the longest
        side of the model's bounds. ``non_overlapping``: the boundaries of the Eq. 11
        partition instead of each class's own surface. ``newton_steps``, ``safety``,
        ``dense``: as the command's options (docs/meshing.md). ``threads``: worker threads
        (default one per core).
        """
        single = isinstance(cls, (int, str, np.integer))
        if cls is None:
            keys: List[str] = []
        elif single:
            keys = [str(cls)]
        else:
            keys = [str(c) for c in cls]  # type: ignore[union-attr]
        names = self._m.class_records
        colors = self.class_colors
        meshes = [
            Mesh(names[k - 1][0], names[k - 1][1], float(t), v, f, n, vn, colors[k - 1])
            for k, v, f, n, vn in self._m.mesh(
                float(t),
                keys,
                resolution,
                non_overlapping,
                newton_steps,
                safety,
                dense,
                threads,
            )
        ]
        return meshes[0] if single else meshes

    def label_volume(
        self,
        like: Any,
        times: Union[None, float, Sequence[float]] = None,
        *,
        output: Optional[PathLike] = None,
        threads: Optional[int] = None,
    ) -> np.ndarray:
        """The Eq. 11 label volume on a reference image's grid, as ``dynaslice labels``.

        ``like``: a NIfTI path, or a nibabel image (its ``affine``, shape and, for 4D, frame
        interval ``pixdim[4]``). Frames are at the reference's frame times (frame f at
        f · interval, as when training on it) unless ``times`` gives them. Returns int32 label
        values with shape (x, y, z) for a single frame (3D reference, or one time given as a
        number), else (x, y, z, t) — index as nibabel does. With ``output`` (.nii or
        .nii.gz) the volume is also written there, the file the command writes (times must
        then be evenly spaced).
        """
        out = os.fspath(output) if output is not None else None
        time_list = None if times is None else [float(x) for x in np.atleast_1d(times)]
        if isinstance(like, (str, os.PathLike)):
            flat, dims, frames = self._m.label_volume_like(os.fspath(like), time_list, out, threads)
            four_d = frames > 1 or (times is not None and np.ndim(times) > 0)
        else:
            affine = np.asarray(getattr(like, "affine", None), dtype=np.float64)
            if affine.shape != (4, 4):
                raise ValueError(
                    "like must be a NIfTI path or a nibabel image (with a 4x4 affine), not %s"
                    % type(like).__name__
                )
            shape = tuple(int(s) for s in like.shape)
            if len(shape) not in (3, 4):
                raise ValueError("like must be a 3D or 4D image, not of shape %r" % (shape,))
            if time_list is None:
                count = shape[3] if len(shape) == 4 else 1
                zooms = like.header.get_zooms()
                dt = float(zooms[3]) if len(zooms) > 3 and zooms[3] > 0 else 1.0
                time_list = [f * dt for f in range(count)]
            flat, dims, frames = self._m.label_volume_grid(
                shape[:3], affine[:3].tolist(), time_list, out, threads
            )
            four_d = frames > 1 or len(shape) == 4 or (times is not None and np.ndim(times) > 0)
        volume = flat.reshape(tuple(dims) + (frames,), order="F")
        return volume if four_d else volume[..., 0]

    # -- what `dynaslice info`, `measure` and `report` give -------------------------------
    def describe(self) -> List[str]:
        """The lines ``dynaslice info`` prints of the model: size, layer widths, cost per
        point, world bounds, time range (or that it is static), classes and metadata."""
        return list(_dynaslice.description(self._m))

    def measure(self, times: Union[None, str, float, Sequence[float]] = None,
                resolution: int = _dynaslice.DEFAULT_RESOLUTION) -> dict:
        """The figures of ``dynaslice measure --json``, as a dict: per class and time the
        volume (mL for a model of millimetres), centroid and box in the input's patient frame;
        per class the smallest and largest volume, the volume change and the centroid's
        motion. ``times``: a list of times or the command's text (``"0,0.5,1"`` or ``"A:B:N"``,
        N times from A to B inclusive); None: 21 times over the model's range (its one time
        for a static model). ``resolution``: meshing cells along the domain's longest axis."""
        return json.loads(_dynaslice.measure_json(self._m, _time_text(times), resolution))

    def report(self, output: PathLike, inputs: Sequence[PathLike] = (), *,
               times: Union[None, str, float, Sequence[float]] = None, resolution: int = _dynaslice.DEFAULT_RESOLUTION,
               force: bool = False) -> None:
        """Writes the page ``dynaslice report`` writes (one self-contained HTML file): the
        input, the training (with the loss curve logged beside the model file), the classes,
        the measured figures (:meth:`measure` at ``times`` and ``resolution``) and the
        interactive 3D view; with the training ``inputs`` (read as the model was trained on
        them) its plane view. An existing page is replaced only with ``force=True``."""
        _dynaslice.report(self._m, os.fspath(output), [os.fspath(p) for p in inputs],
                          _time_text(times), resolution, force)


def _time_text(times: Union[None, str, float, Sequence[float]]) -> Optional[str]:
    """Times as the command line's ``--times`` text: a list ``t1,t2,…`` or ``A:B:N`` as given."""
    if times is None or isinstance(times, str):
        return times
    return ",".join(repr(float(t)) for t in np.atleast_1d(times))


def random_model(
    widths: Sequence[int],
    num_classes: int,
    seed: int = 0,
    motion_widths: Optional[Sequence[int]] = None,
) -> Model:
    """A model with random (untrained) weights, for tests and benchmarks; with
    ``motion_widths``, a motion model whose motion network has those sine layer widths."""
    motion = None if motion_widths is None else list(motion_widths)
    return Model(_dynaslice.random_model(list(widths), num_classes, seed, motion))


def _progress_lines() -> Callable[[dict], None]:
    """Without tqdm: a plain line on stderr naming the ``[progress]`` extra, then one line at
    every tenth of the run and at its end."""
    shown = {"tenth": -1}

    def update(p: dict) -> None:
        if shown["tenth"] < 0:
            print("dynaslice train: %d steps (pip install 'dynaslice[progress]' for a progress "
                  "bar)" % p["steps"], file=sys.stderr, flush=True)
        tenth = 10 * p["step"] // max(1, p["steps"])
        if tenth > shown["tenth"]:
            shown["tenth"] = tenth
            print("dynaslice train: step %d/%d loss %.3e" % (p["step"], p["steps"], p["loss"]),
                  file=sys.stderr, flush=True)

    return update


def _progress_bar() -> Callable[[dict], None]:
    """A tqdm bar fed by the training callback, when tqdm is installed (else plain lines); its
    length follows the run's schedule (a timed run's plan moves as the machine's speed
    changes)."""
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _progress_lines()
    bar = tqdm(total=None, unit="step", desc="dynaslice train")

    def update(p: dict) -> None:
        if bar.total != p["steps"]:
            bar.total = p["steps"]
            bar.refresh()
        bar.update(p["step"] - bar.n)
        bar.set_postfix(loss="%.3e" % p["loss"], refresh=False)
        if p["step"] >= p["steps"]:
            bar.close()

    return update


def train(
    inputs: Union[PathLike, Sequence[PathLike]],
    output: PathLike,
    *,
    steps: Optional[int] = None,
    minutes: Optional[float] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    progress: Union[bool, Callable[[dict], Any]] = True,
    **options: Any,
) -> Model:
    """Trains a model on cross-sections and writes it to ``output``, as ``dynaslice train``.

    ``inputs``: one path or several (views of one subject): native JSON, ``.csl``, ``.seq`` /
    ``.cslseq`` manifests, NIfTI, NRRD and ``.seg.nrrd`` label maps, DICOM RT Structure Sets.
    ``steps`` (default 3000) and ``minutes`` bound the run; ``seed`` (default 0) and
    ``threads`` (default: all cores) make it reproducible. Every keyword and default is the
    command line's (``dynaslice train --help``): both map onto one training specification, and
    the same model file comes out of both. ``progress``:
    True shows a tqdm bar when tqdm is installed (else a line on stderr at every tenth of the
    run), False nothing, a callable gets a dict
    (step, steps, loss, lr, elapsed and the loss terms) at most every 50 ms.

    ``options`` are the command's other options with underscores (``frames="0:37:4"``,
    ``widths=[128, 128]``, ``omega0``, ``lr``, ``class_weights``, ``resume=True``, …; see
    docs/python.md); an unknown one raises TypeError, a value out of range ValueError (with the
    command line's words) before any file is read. The loss log and curve are written beside
    the model (``output + ".loss.csv"``, ``".loss.png"``). While training, the checkpoint is
    kept at ``output + ".ckpt"`` (removed when the run finishes): Ctrl-C stops training, saves
    it and raises KeyboardInterrupt; SIGTERM and SIGHUP do the same and raise SystemExit
    (status 128 + the signal), unless the program set its own handler; ``resume=True``
    continues from it, ``force=True`` starts
    afresh over it. An existing model, loss log or curve is replaced only with ``force=True``.
    """
    if isinstance(inputs, (str, os.PathLike)):
        paths = [os.fspath(inputs)]
    else:
        paths = [os.fspath(p) for p in inputs]
    callback: Optional[Callable[[dict], Any]]
    if progress is True:
        callback = _progress_bar()
    elif progress is False or progress is None:
        callback = None
    else:
        callback = progress
    with _stop_on_termination():
        native = _dynaslice.train(
            paths,
            os.fspath(output),
            steps=steps,
            minutes=minutes,
            seed=seed,
            threads=threads,
            progress=callback,
            **options,
        )
    return Model(native)


@contextlib.contextmanager
def _stop_on_termination() -> Iterator[None]:
    """SIGTERM and SIGHUP (what ``timeout``, Slurm and ``docker stop`` send) stop training as
    Ctrl-C does, as ``dynaslice train`` handles them: the checkpoint is saved, then
    SystemExit(128 + signal) ends the program with the status the signal's default action
    gives, and ``resume=True`` continues the run. Only where Python's default action is in
    place (a handler the program set is left alone) and in the main thread (the only one
    Python runs signal handlers in)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, frame: Any) -> None:
        sys.stderr.write(
            "dynaslice: %s: stopping training and saving the checkpoint\n"
            % signal.Signals(signum).name
        )
        raise SystemExit(128 + signum)

    previous = {}
    for name in ("SIGTERM", "SIGHUP"):
        number = getattr(signal, name, None)
        if number is not None and signal.getsignal(number) == signal.SIG_DFL:
            previous[number] = signal.signal(number, stop)
    try:
        yield
    except SystemExit as e:
        # Python 3.11+ carries where the run stands as a note; print it before exiting.
        for note in getattr(e, "__notes__", []):
            sys.stderr.write("dynaslice: %s\n" % note)
        raise
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
