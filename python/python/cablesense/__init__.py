"""cablesense: Cosserat-rod statics and load/shape estimation for cable-driven
continuum robots (Python bindings of the Rust crate; see the repository README).

    scene = cablesense.Scene.from_file("track_demo.toml")   # or from_toml / from_dict
    sol = cablesense.solve(scene)          # dict of numpy arrays + report
    solver = cablesense.Solver(scene)      # warm-started repeated solves
    est = cablesense.Estimator(scene)      # the scene's [estimate] problem
    out = est.tick([1.7e-3, -2.4e-3, 2.5e-4])

Tendon-driven robots (displacement-driven tendons, servo readings in metres):

    ts = cablesense.TendonSolver(cablesense.Scene.from_file("tdcr_two_segment.toml"))
    row = ts.solve([1e-3, 0, 0, 0, 0, 0])  # tip, section_tips, tensions, taut, report
    for i, line in enumerate(open("readings.csv"), 1):   # a recording, row by row
        out = ts.solve_line(i, line)       # None for the header

Commanding the robot: which readings put the tip at a target (inverse kinematics
within the scene's [robot.limits]), and the reachable workspace:

    ik = cablesense.IkSolver(scene, objective="closest")
    readings, result = ik.ik([0.01, 0.0, 0.09])   # warm from the previous call
    result["status"], result["distance_m"]        # reached / unreachable / budget_exhausted
    batch = ik.ik_many(targets)                   # (n, 3) in, (n, p) readings out
    ws = cablesense.workspace(scene, samples=2000)
    ws["tips"], ws["hull_volume_m3"]

Calibration from a recording (the scene's [calibration] table maps the columns):

    fit = cablesense.calibrate(scene, "train.csv", val="val.csv")
    fit["params"], fit["val"]["mean_removed"]["rmse_m"], fit["scene"]
    # the hardware validation: a calibrated scene predicting a held-out recording
    cablesense.predict_recording(fit["scene"], "val.csv")["errors"]["mean_removed"]

Scenes are values: `scene.to_toml()` / `to_dict()` / `to_json()` and back, pickling
and `copy.deepcopy` (so they travel to worker processes, e.g. a Dask cluster);
`scene.with_loads({...})` is a copy with other loads. Live solvers take new loads
and readings without a cold start: `Solver.set_loads`, `TendonSolver.set_loads`,
`TendonSolver.set_readings`. The embedded demo data: `Scene.from_file("demo:NAME")`
or `cablesense.demo` (names, text, scene).

The dicts the calls return are typed for checkers (`cablesense.Solution`,
`TendonRow`, `TendonBatch`, `Estimate`, ...: TypedDicts, plain dicts at run time).

The thesis validation (data embedded in the library):

    v = cablesense.validate_thesis("4.3")  # rows, per-point and per-cable summaries

Invalid scenes raise SceneError (a ValueError) whose `field` names the offending
field path, e.g. "robot.sections[0].length_m"; bad readings raise ReadingsError
(`field` e.g. "readings[1] (s1b)", `line`); bad IK targets raise TargetError
(`field` e.g. "target[2]", "direction"); a calibration that cannot run raises
CalibrationError (`file`, `line`, `column`, `field`).
"""

from ._cablesense import (
    CalibrationError,
    Estimator,
    IkSolver,
    ReadingsError,
    Scene,
    SceneError,
    Solver,
    TargetError,
    TendonSolver,
    calibrate,
    predict_recording,
    solve,
    validate_thesis,
    workspace,
    __version__,
)
from ._types import (
    CalibrationReport,
    Estimate,
    IkBatch,
    IkResult,
    RecordingPrediction,
    Solution,
    SolveReport,
    TendonBatch,
    TendonLine,
    TendonReport,
    TendonRow,
    TendonSolution,
    ThesisComparison,
    Tick,
    WorkspaceCloud,
)
from . import demo

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
