"""Type stubs of the cablesense extension (see __init__.py for the overview)."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

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

class CalibrationError(ValueError):
    """A calibration could not run (bad recording, parameter path, unsolvable model)."""

    file: Optional[str]
    line: Optional[int]
    column: Optional[str]
    field: Optional[str]
    """Scene field path when a parameter value makes the scene invalid."""

class Scene:
    """A validated scene: robot, loads, numerics and optional ``[estimate]``."""

    @staticmethod
    def from_file(path: Union[str, PathLike[str]]) -> Scene: ...
    @staticmethod
    def from_toml(text: str) -> Scene: ...
    @staticmethod
    def from_dict(d: Dict[str, Any]) -> Scene: ...
    @property
    def description(self) -> str: ...
    @property
    def cable_names(self) -> List[str]: ...

# Solution dict (SI units):
#   s (n,) m; r (n, 3) m; R (n, 3, 3) rotations; tip (3,) m; section_tips (k, 3) m;
#   cable_lengths (c,) m from the base plate;
#   report: {status, converged, iterations, residual, rhs_evals, jacobian_evals,
#            continuation_steps[, diagnosis]}; `diagnosis` (str) only when not
#            converged: why, with the loads that bend the rod most named by their
#            scene field (`Workspace::diagnose`)
Solution = Dict[str, Any]

def solve(scene: Scene) -> Solution:
    """Cold forward solve with the scene's loads (the GIL is released)."""

class Solver:
    """Keeps its workspace: solves after the first start warm."""

    def __init__(self, scene: Scene) -> None: ...
    def solve(self, warm: bool = True) -> Solution: ...

# Estimate dict: names [p]; values (p,); std_dev (p,); covariance (p, p);
#   status (converged | unobservable | max_iterations | time_budget | stalled |
#   forward_failed | no_data); fit (good | poor | untestable); rms_sigma; redundancy;
#   rank; tip (3,) m; predicted (c,) m; iterations; elapsed_s
Estimate = Dict[str, Any]

class Estimator:
    """The scene's ``[estimate]`` problem; ``tick`` releases the GIL."""

    def __init__(self, scene: Scene) -> None: ...
    @property
    def names(self) -> List[str]: ...
    def tick(
        self,
        changes: Union[Sequence[float], npt.NDArray[np.float64]],
        sigma: Optional[Union[Sequence[float], npt.NDArray[np.float64]]] = None,
        snapshot: bool = True,
    ) -> Estimate:
        """One sample: cable length changes (m; NaN = missing), optional noise (m).
        ``snapshot=False``: only {status, values, covariance (tick-end sensitivities),
        statistics_exact, tip}, without the ~16 us estimate snapshot (control loops)."""
    def time_ticks(
        self, samples: npt.NDArray[np.float64], count: int, snapshot: bool = False
    ) -> npt.NDArray[np.float64]:
        """Seconds per tick of ``count`` ticks run in Rust alone over the rows of
        ``samples`` (n, c) (with ``snapshot``: each plus the estimate snapshot that
        ``tick`` returns), for measuring the binding's overhead."""

# Tendon row dict (SI units): tip (3,) m; section_tips (k, 3) m; tensions (p,) N of
#   the displacement-driven tendons; taut (p,) bool; lengths (c,) m of every cable;
#   report: {status, converged, iterations, residual_m, forward_solves, slack
#            [, diagnosis]} (`diagnosis`, str, only when not converged).
#   solve_line adds line, t_s, readings (p,) m and measured_tip (3,) m or None.
TendonRow = Dict[str, Any]

class TendonSolver:
    """Servo readings of displacement-driven tendons in, shape and tensions out.

    Solves after the first start warm from the previous one (feed rows in time
    order); the GIL is released inside every solve.
    """

    def __init__(self, scene: Scene) -> None: ...
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
    def set_budget(
        self, max_passes: Optional[int] = None, time_budget_s: Optional[float] = None
    ) -> None:
        """Budget of every later solve: rod evaluations and wall time (s) per row
        (None: no limit). A row that runs out has report status
        ``"budget_exhausted"`` and is rolled back like any failed row."""
    def solve(
        self,
        readings: Union[Sequence[float], npt.NDArray[np.float64]],
        warm: bool = True,
    ) -> TendonRow:
        """One row of readings (m, in ``columns`` order)."""
    def solve_many(self, rows: npt.NDArray[np.float64]) -> Dict[str, Any]:
        """Rows (n, p) in order, warm-started: tip (n, 3), section_tips (n, k, 3),
        tensions (n, p), taut (n, p), converged (n,), status [n], iterations (n,),
        diagnosis [n] (str why a row did not converge, None when it did)."""
    def solve_line(self, line_no: int, text: str) -> Optional[TendonRow]:
        """One line of a readings file (CSV with header, or JSON lines); None for a
        header, comment or blank line."""
    def solution(self) -> Solution:
        """Full solution of the last solve (samples, tips, cable lengths)."""

# Calibration report (the layout of `cablesense calibrate`'s report.json) plus
#   scene: the calibrated Scene.
CalibrationReport = Dict[str, Any]

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

def validate_thesis(table: str, fitted: bool = True) -> Dict[str, Any]:
    """Compare the model with a thesis table (4.1, 4.2, 4.3, 4.3m, 4.4, 4.5, 4.5acc):
    {table, title, ref_length_m, all_converged, rows, points, lengths}."""

def predict_recording(scene: Scene, recording: Union[str, PathLike[str]]) -> Dict[str, Any]:
    """Predict every row of a recording with a (calibrated) scene, compared with its
    marker columns in the base frame: {lines, predicted_m (n, 3), measured_m (n, 3),
    errors {raw, mean_removed}}."""
