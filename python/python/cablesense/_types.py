"""Typed layouts of the dicts the cablesense calls return (``TypedDict``s: at run
time they are plain dicts; a type checker knows every key and its type).

Arrays are float64 numpy arrays in SI units unless said otherwise; the shapes use
n rows, m samples along the rod, k sections, c cables and p displacement-driven
tendons.
"""

from typing import Any, Dict, List, Optional, TypedDict

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


class _SolveReportKeys(TypedDict):
    status: str
    converged: bool
    iterations: int
    residual: float
    rhs_evals: int
    jacobian_evals: int
    continuation_steps: int


class SolveReport(_SolveReportKeys, total=False):
    """Shooting report of a forward solve. ``status``: converged, max_iterations,
    stalled, singular_jacobian, non_finite, ...; ``diagnosis`` only when not
    converged: why, naming the loads that bend the rod most by their scene field."""

    diagnosis: str


class Solution(TypedDict):
    """A forward solution: ``s`` (m,) arc length; ``r`` (m, 3) backbone; ``R``
    (m, 3, 3) rotations; ``tip`` (3,); ``section_tips`` (k, 3); ``cable_lengths``
    (c,) from the base plate."""

    s: FloatArray
    r: FloatArray
    R: FloatArray
    tip: FloatArray
    section_tips: FloatArray
    cable_lengths: FloatArray
    report: SolveReport


class _TendonReportKeys(TypedDict):
    status: str
    converged: bool
    iterations: int
    residual_m: float
    forward_solves: int
    slack: int


class TendonReport(_TendonReportKeys, total=False):
    """Report of one row from readings. ``status``: converged, max_iterations,
    stalled, budget_exhausted, ...; ``slack`` the number of slack tendons;
    ``diagnosis`` only when not converged."""

    diagnosis: str


class TendonSolution(TypedDict):
    """``TendonSolver.solution()``: a forward solution whose report is the row's."""

    s: FloatArray
    r: FloatArray
    R: FloatArray
    tip: FloatArray
    section_tips: FloatArray
    cable_lengths: FloatArray
    report: TendonReport


class TendonRow(TypedDict):
    """One row from readings: ``tip`` (3,); ``section_tips`` (k, 3); ``tensions``
    (p,) N; ``taut`` (p,) bool; ``lengths`` (c,) of every cable."""

    tip: FloatArray
    section_tips: FloatArray
    tensions: FloatArray
    taut: BoolArray
    lengths: FloatArray
    report: TendonReport


class TendonLine(TendonRow):
    """``TendonSolver.solve_line``: the row plus its file line, time stamp (s or
    None), readings (p,) m and the recording's measured tip (3,) m or None."""

    line: int
    t_s: Optional[float]
    readings: FloatArray
    measured_tip: Optional[FloatArray]


class _TendonBatchKeys(TypedDict):
    tip: FloatArray
    section_tips: FloatArray
    tensions: FloatArray
    taut: BoolArray
    converged: BoolArray
    status: List[str]
    iterations: npt.NDArray[np.uint64]
    diagnosis: List[Optional[str]]


class TendonBatch(_TendonBatchKeys, total=False):
    """``TendonSolver.solve_many``: ``tip`` (n, 3); ``section_tips`` (n, k, 3);
    ``tensions`` (n, p); ``taut`` (n, p); ``converged`` (n,); ``status`` [n];
    ``iterations`` (n,); ``diagnosis`` [n]; with ``shapes=True`` also ``s`` (m,)
    and ``shapes`` (n, m, 3)."""

    s: FloatArray
    shapes: FloatArray


class Estimate(TypedDict):
    """``Estimator.tick`` (snapshot): ``values``, ``std_dev`` (q,); ``covariance``
    (q, q); ``status``: converged, unobservable, max_iterations, time_budget,
    stalled, forward_failed, no_data; ``fit``: good, poor, untestable; ``tip`` (3,);
    ``predicted`` (c,) cable length changes."""

    names: List[str]
    values: FloatArray
    std_dev: FloatArray
    covariance: FloatArray
    status: str
    fit: str
    rms_sigma: float
    redundancy: int
    rank: int
    tip: FloatArray
    predicted: FloatArray
    iterations: int
    elapsed_s: float


class Tick(TypedDict):
    """``Estimator.tick(snapshot=False)``: the control-loop path."""

    status: str
    values: FloatArray
    covariance: FloatArray
    statistics_exact: bool
    tip: FloatArray


class IkResult(TypedDict):
    """``IkSolver.ik``'s result (the readings come beside it): ``status``:
    ``reached``, ``unreachable`` (the closest tip found, at a constrained stationary
    point), ``budget_exhausted``; ``distance_m`` from ``tip`` (3,) to the target;
    ``angle_rad`` to the target direction (0 without one); ``objective`` the
    secondary objective that chose the solution (``closest``, ``least_pull``,
    ``least_tension``); the work: ``iterations``, ``jacobians`` (evaluated),
    ``forward_solves``, ``qp_solves``; ``slack`` tendons; ``first_order`` (0 at a
    constrained stationary point, NaN when none was built); ``tensions`` (p,) N and
    ``taut`` (p,) at the readings."""

    status: str
    reached: bool
    distance_m: float
    tip: FloatArray
    angle_rad: float
    objective: str
    iterations: int
    jacobians: int
    forward_solves: int
    qp_solves: int
    slack: int
    first_order: float
    tensions: FloatArray
    taut: BoolArray


class IkBatch(TypedDict):
    """``IkSolver.ik_many``: ``readings`` (n, p) m; ``tip`` (n, 3); ``distance_m``,
    ``angle_rad`` (n,); ``status`` [n] (as ``IkResult``, or ``invalid`` for a bad
    row, whose numbers are NaN); ``status_code`` (n,) int8 (0 reached, 1
    unreachable, 2 budget_exhausted, -1 invalid); ``reached`` (n,); ``iterations``,
    ``forward_solves`` (n,); ``objective``; ``errors`` [n] (why a row was invalid,
    None for a good one)."""

    readings: FloatArray
    tip: FloatArray
    distance_m: FloatArray
    angle_rad: FloatArray
    status: List[str]
    status_code: npt.NDArray[np.int8]
    reached: BoolArray
    iterations: npt.NDArray[np.uint64]
    forward_solves: npt.NDArray[np.uint64]
    objective: str
    errors: List[Optional[str]]


class WorkspaceCloud(TypedDict):
    """``workspace``: the sampled actuator box and its tips. ``columns`` [p];
    ``limits`` (p, 2) m; ``readings`` (n, p) m; ``tips`` (n, 3) m (NaN for a sample
    that did not solve); ``markers`` (n, 3) m, the ``marker_offset`` point of each
    sample (None without one); ``status`` (n,) uint8, an index into ``status_names``
    (converged, converged_stepped, converged_cold, failed,
    converged_neighbour); ``solved`` (n,);
    ``solved_count``, ``failed_count``; ``sampling_s``; ``hull_volume_m3`` of the
    convex hull of the solved tips (None when it has no volume: ``hull_error``
    says why); ``hull_vertices`` (v, 3) m; ``hull_triangles`` (t, 3) indices into
    them, counter-clockwise seen from outside."""

    columns: List[str]
    limits: FloatArray
    readings: FloatArray
    tips: FloatArray
    markers: Optional[FloatArray]
    status: npt.NDArray[np.uint8]
    status_names: List[str]
    solved: BoolArray
    solved_count: int
    failed_count: int
    sampling_s: float
    hull_volume_m3: Optional[float]
    hull_vertices: FloatArray
    hull_triangles: npt.NDArray[np.uint64]
    hull_error: Optional[str]


#: Calibration report (the layout of ``cablesense calibrate``'s report.json) plus
#: ``scene``, the calibrated Scene.
CalibrationReport = Dict[str, Any]
#: ``validate_thesis``: {table, title, ref_length_m, all_converged, rows, points, lengths}.
ThesisComparison = Dict[str, Any]
#: ``predict_recording``: {lines, predicted_m (n, 3), measured_m (n, 3), errors}.
RecordingPrediction = Dict[str, Any]

__all__ = [
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
]
