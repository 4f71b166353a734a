"""Type stubs of the cablesense extension (see __init__.py for the overview)."""

from os import PathLike
from typing import (
    Any,
    Callable,
    Dict,
    List,
    Literal,
    Optional,
    Sequence,
    Tuple,
    Union,
    final,
    overload,
)

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

from . import demo as demo
from ._types import CalibrationReport as CalibrationReport
from ._types import Estimate as Estimate
from ._types import IkBatch as IkBatch
from ._types import IkResult as IkResult
from ._types import RecordingPrediction as RecordingPrediction
from ._types import Solution as Solution
from ._types import SolveReport as SolveReport
from ._types import TendonBatch as TendonBatch
from ._types import TendonLine as TendonLine
from ._types import TendonReport as TendonReport
from ._types import TendonRow as TendonRow
from ._types import TendonSolution as TendonSolution
from ._types import ThesisComparison as ThesisComparison
from ._types import Tick as Tick
from ._types import WorkspaceCloud as WorkspaceCloud

__version__: str

__all__ = [
    "CalibrationError",
    "CalibrationReport",
    "Estimate",
    "IkBatch",
    "IkResult",
    "RecordingPrediction",
    "Solution",
    "SolveReport",
    "TendonBatch",
    "TendonLine",
    "TendonReport",
    "TendonRow",
    "TendonSolution",
    "ThesisComparison",
    "Tick",
    "WorkspaceCloud",
    "demo",
    "Estimator",
    "IkSolver",
    "ReadingsError",
    "Scene",
    "SceneError",
    "Solver",
    "TargetError",
    "TendonSolver",
    "calibrate",
    "predict_recording",
    "solve",
    "validate_thesis",
    "workspace",
    "__version__",
]

#: A row of floats: a sequence or a 1-D array of a real dtype.
_Floats = Union[Sequence[float], npt.NDArray[np.floating[Any]], npt.NDArray[np.integer[Any]]]
#: Rows of floats: anything ``numpy.asarray(x, float64)`` makes a 2-D array of.
_Rows = Union[Sequence[Sequence[float]], npt.NDArray[np.floating[Any]], npt.NDArray[np.integer[Any]]]
#: A dict with the layout of the scene's ``[loads]`` table.
_Loads = Dict[str, Any]

class SceneError(ValueError):
    """A scene could not be read or is invalid."""

    field: Optional[str]
    """Offending field path, e.g. ``robot.sections[0].length_m`` (None for syntax errors)."""

class ReadingsError(ValueError):
    """Bad tendon readings: wrong count, not finite, or pulling in more than the tendon."""

    field: Optional[str]
    """The reading, e.g. ``readings[1] (s1b)`` or ``rows[4].readings[0] (s1a)``."""
    line: Optional[int]
    """Line of a readings file (``TendonSolver.solve_line``), else None."""

class TargetError(ValueError):
    """A bad inverse-kinematics target: a NaN or infinite coordinate, a direction of
    zero length, a wrong shape."""

    field: Optional[str]
    """The argument, e.g. ``target[2]``, ``direction``, ``targets``."""

class CalibrationError(ValueError):
    """A calibration could not run (bad recording, parameter path, unsolvable model)."""

    file: Optional[str]
    line: Optional[int]
    column: Optional[str]
    field: Optional[str]
    """Scene field path when a parameter value makes the scene invalid."""

@final
class Scene:
    """A validated scene: robot, loads, numerics and optional ``[estimate]``.

    A value: equal scenes compare equal; it converts to TOML, JSON and a dict and
    back exactly, pickles and deep-copies."""

    @staticmethod
    def from_file(path: Union[str, PathLike[str]]) -> Scene:
        """A ``.toml`` or ``.json`` file, or an embedded ``demo:NAME``."""
    @staticmethod
    def from_toml(text: str) -> Scene: ...
    @staticmethod
    def from_json(text: str) -> Scene: ...
    @staticmethod
    def from_dict(d: Dict[str, Any]) -> Scene: ...
    def to_toml(self) -> str: ...
    def to_json(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def with_loads(self, loads: _Loads) -> Scene:
        """A copy with the given keys of the ``[loads]`` table replaced."""
    def __reduce__(self) -> Tuple[Any, Tuple[str]]: ...
    def __copy__(self) -> Scene: ...
    def __deepcopy__(self, memo: Any, /) -> Scene: ...
    def __eq__(self, other: object, /) -> bool: ...
    def __ne__(self, other: object, /) -> bool: ...
    @property
    def description(self) -> str: ...
    @property
    def cable_names(self) -> List[str]: ...

def solve(scene: Scene) -> Solution:
    """Cold forward solve with the scene's loads (the GIL is released)."""

@final
class Solver:
    """Keeps its workspace: solves after the first start warm."""

    def __new__(cls, scene: Scene) -> Self: ...
    def solve(self, warm: bool = True) -> Solution: ...
    def set_loads(self, loads: _Loads) -> None:
        """New loads for the next solves, keeping the warm start (keys not given
        keep their values)."""
    @property
    def loads(self) -> Dict[str, Any]: ...

@final
class Estimator:
    """The scene's ``[estimate]`` problem; ``tick`` releases the GIL."""

    def __new__(cls, scene: Scene) -> Self: ...
    @property
    def names(self) -> List[str]: ...
    @overload
    def tick(
        self,
        changes: _Floats,
        sigma: Optional[_Floats] = None,
        snapshot: Literal[True] = True,
    ) -> Estimate:
        """One sample: cable length changes (m; NaN = missing), optional noise (m)."""
    @overload
    def tick(self, changes: _Floats, sigma: Optional[_Floats], snapshot: Literal[False]) -> Tick: ...
    @overload
    def tick(self, changes: _Floats, *, snapshot: Literal[False]) -> Tick: ...
    def time_ticks(
        self, samples: npt.NDArray[np.float64], count: int, snapshot: bool = False
    ) -> npt.NDArray[np.float64]:
        """Seconds per tick of ``count`` ticks run in Rust alone over the rows of
        ``samples`` (n, c), for measuring the binding's overhead."""

@final
class TendonSolver:
    """Servo readings of displacement-driven tendons in, shape and tensions out.

    Solves after the first start warm from the previous one (feed rows in time
    order); the GIL is released inside every solve.
    """

    def __new__(cls, scene: Scene) -> Self: ...
    @property
    def columns(self) -> List[str]:
        """Readings column of each driven tendon (the order of ``solve``)."""
    @property
    def cable_names(self) -> List[str]: ...
    @property
    def scale_m(self) -> float:
        """Metres per unit of a readings file's tendon columns (``[readings] scale_m``)."""
    @property
    def rest_free_lengths(self) -> npt.NDArray[np.float64]:
        """Free length ``L0`` of each driven tendon at reading 0 (m)."""
    @property
    def readings(self) -> npt.NDArray[np.float64]:
        """The readings ``solve()`` without readings solves (m)."""
    @property
    def loads(self) -> Dict[str, Any]: ...
    def set_budget(
        self, max_passes: Optional[int] = None, time_budget_s: Optional[float] = None
    ) -> None:
        """Budget of every later solve: rod evaluations and wall time (s) per row
        (None: no limit). A row that runs out has report status
        ``"budget_exhausted"`` and is rolled back like any failed row."""
    def set_loads(self, loads: _Loads) -> None:
        """New external loads for the next solves, keeping the warm start."""
    def set_readings(self, readings: _Floats) -> None:
        """Readings (m) for the next ``solve()`` without readings; checked now."""
    def solve(self, readings: Optional[_Floats] = None, warm: bool = True) -> TendonRow:
        """One row of readings (m, in ``columns`` order)."""
    def solve_many(self, rows: _Rows, shapes: bool = False) -> TendonBatch:
        """Rows (n, p) in order, warm-started (``shapes=True``: also the backbone of
        every row, ``shapes`` (n, m, 3), and ``s`` (m,))."""
    def solve_line(self, line_no: int, text: str) -> Optional[TendonLine]:
        """One line of a readings file (CSV with header, or JSON lines); None for a
        header, comment or blank line."""
    def solution(self) -> TendonSolution:
        """Full solution of the last solve, with the row's report."""

#: The secondary objective that chooses among the solutions of an inverse solve.
_Objective = Literal["closest", "least_pull", "least_tension"]

@final
class IkSolver:
    """Inverse kinematics: which readings put the tip at a target, inside the
    scene's ``[robot.limits]``.

    Every call starts warm from the readings of the previous one (or of
    ``set_readings``); the first from zero readings. The GIL is released inside
    every solve. Bad settings raise ``SceneError`` naming the field
    (``ik.tolerance_m``).
    """

    def __new__(
        cls,
        scene: Scene,
        objective: _Objective = "closest",
        secondary_weight: Optional[float] = None,
        tolerance_m: Optional[float] = None,
        angle_tolerance_rad: Optional[float] = None,
        rest_weight: Optional[float] = None,
        direction_weight_m: Optional[float] = None,
        trust_radius_m: Optional[float] = None,
        max_iterations: Optional[int] = None,
        max_forward_solves: Optional[int] = None,
    ) -> Self: ...
    @property
    def columns(self) -> List[str]:
        """Readings column of each driven tendon (the order of the readings)."""
    @property
    def scale_m(self) -> float:
        """Metres per unit of a readings file's tendon columns (readings here are m)."""
    @property
    def limits(self) -> npt.NDArray[np.float64]:
        """Actuator limits (p, 2), ``[min, max]`` per reading (m; -inf/inf: none)."""
    @property
    def readings(self) -> npt.NDArray[np.float64]:
        """The readings the next ``ik`` starts from (m)."""
    @property
    def tip(self) -> npt.NDArray[np.float64]:
        """The tip at ``readings`` (m)."""
    @property
    def settings(self) -> Dict[str, Any]:
        """The constructor's settings."""
    def set_readings(self, readings: _Floats) -> None:
        """Start the next ``ik`` at these readings (m, inside the limits; one
        forward solve). Bad readings raise ``ReadingsError`` naming them."""
    def ik(
        self,
        target: _Floats,
        direction: Optional[_Floats] = None,
        *,
        objective: Optional[_Objective] = None,
        secondary_weight: Optional[float] = None,
        direction_weight_m: Optional[float] = None,
        tolerance_m: Optional[float] = None,
    ) -> Tuple[npt.NDArray[np.float64], IkResult]:
        """Readings (p,) m that put the tip at ``target`` (3,) m (and its axis along
        ``direction``), warm from the previous call, and the result. An unreachable
        target is ``status == "unreachable"`` with the closest tip, not an
        exception; a NaN target or a zero-length direction raises ``TargetError``."""
    def ik_many(self, targets: _Rows, directions: Optional[_Rows] = None) -> IkBatch:
        """``ik`` for every row of ``targets`` (n, 3) in order, chained warm; a bad
        row is status ``invalid`` and does not stop the batch."""

def workspace(
    scene: Scene,
    samples: int = 20000,
    threads: int = 0,
    progress: Optional[Callable[[int], object]] = None,
    marker_offset: Optional[_Floats] = None,
) -> WorkspaceCloud:
    """The reachable tips of the actuator box of ``[robot.limits]`` (``samples``
    Halton points, warm chains, ``threads`` threads, 0: every core) and their convex
    hull. ``progress(done)`` is called after each sample; with ``marker_offset`` (m,
    tip frame) also the ``markers`` of every sample."""

def calibrate(
    scene: Scene,
    train: Union[str, PathLike[str]],
    val: Optional[Union[str, PathLike[str]]] = None,
    params: Optional[List[str]] = None,
    threads: int = 2,
    max_iterations: Optional[int] = None,
) -> CalibrationReport:
    """Fit the scene's ``[calibration]`` parameters (plus ``params`` paths), capture
    frame and marker offset to the recording ``train``; predict ``val`` too."""

def validate_thesis(table: str, fitted: bool = True) -> ThesisComparison:
    """Compare the model with a thesis table (4.1, 4.2, 4.3, 4.3m, 4.4, 4.5, 4.5acc)."""

def predict_recording(scene: Scene, recording: Union[str, PathLike[str]]) -> RecordingPrediction:
    """Predict every row of a recording with a (calibrated) scene."""
