"""Type stubs of the native module (dynaslice-python/src); use the wrappers in ``dynaslice``."""

from os import PathLike
from typing import Any, Callable, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
DEFAULT_RESOLUTION: int

class DynasliceError(Exception):
    """A DynaSlice operation failed; the message is the command line's."""

_Points = npt.NDArray[Union[np.float32, np.float64]]
_Times = Union[float, npt.NDArray[Union[np.float32, np.float64]]]
_Path = Union[str, "PathLike[str]"]

class Model:
    """A validated model file (see dynaslice.Model)."""

    @staticmethod
    def load(path: _Path) -> Model: ...
    @staticmethod
    def from_bytes(data: bytes) -> Model: ...
    def to_bytes(self) -> bytes: ...
    @property
    def num_classes(self) -> int: ...
    @property
    def class_records(self) -> List[Tuple[str, int, Optional[Tuple[int, int, int]]]]: ...
    @property
    def class_colors(self) -> List[Tuple[int, int, int]]: ...
    @property
    def bounds(self) -> Tuple[List[float], List[float]]: ...
    @property
    def time_range(self) -> Tuple[float, float]: ...
    @property
    def is_static(self) -> bool: ...
    @property
    def metadata(self) -> str: ...
    def sdf(self, points: _Points, t: _Times) -> npt.NDArray[np.float32]: ...
    def gradient(self, points: _Points, t: _Times) -> npt.NDArray[np.float32]: ...
    def dfdt(self, points: _Points, t: _Times) -> npt.NDArray[np.float32]: ...
    def jacobian(
        self, points: _Points, t: _Times
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    def labels(self, points: _Points, t: _Times, index: bool = False) -> npt.NDArray[np.int32]: ...
    def displacement(self, points: _Points, t: _Times) -> npt.NDArray[np.float32]: ...
    def mesh(
        self,
        t: float,
        classes: Sequence[str],
        resolution: int = ...,
        non_overlapping: bool = False,
        newton_steps: int = 1,
        safety: float = 1.5,
        dense: bool = False,
        threads: Optional[int] = None,
    ) -> List[
        Tuple[
            int,
            npt.NDArray[np.float32],
            npt.NDArray[np.int64],
            npt.NDArray[np.float32],
            npt.NDArray[np.float32],
        ]
    ]: ...
    def label_volume_like(
        self,
        like: _Path,
        times: Optional[Sequence[float]] = None,
        output: Optional[_Path] = None,
        threads: Optional[int] = None,
    ) -> Tuple[npt.NDArray[np.int32], Tuple[int, int, int], int]: ...
    def label_volume_grid(
        self,
        dims: Sequence[int],
        affine: Sequence[Sequence[float]],
        times: Sequence[float],
        output: Optional[_Path] = None,
        threads: Optional[int] = None,
    ) -> Tuple[npt.NDArray[np.int32], Tuple[int, int, int], int]: ...

def train(
    inputs: Sequence[_Path],
    output: _Path,
    *,
    steps: Optional[int] = None,
    minutes: Optional[float] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    progress: Optional[Callable[[dict], Any]] = None,
    **options: Any,
) -> Model: ...
def description(model: Model) -> List[str]: ...
def measure_json(model: Model, times: Optional[str] = None, resolution: int = ...) -> str: ...
def report(
    model: Model,
    output: _Path,
    inputs: Sequence[_Path] = ...,
    times: Optional[str] = None,
    resolution: int = ...,
    force: bool = False,
) -> None: ...
def kernel_name() -> str: ...
def random_model(
    widths: Sequence[int],
    num_classes: int,
    seed: int = 0,
    motion_widths: Optional[Sequence[int]] = None,
) -> Model: ...
def _bench_rust_batch(
    model: Model, n: int, t: float, repeats: int = 5
) -> Tuple[float, npt.NDArray[np.float32]]: ...
