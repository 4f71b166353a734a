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

Calibration from a recording (the scene's [calibration] table maps the columns):

    fit = cablesense.calibrate(scene, "train.csv", val="val.csv")
    fit["params"], fit["val"]["mean_removed"]["rmse_m"], fit["scene"]
    # the hardware validation: a calibrated scene predicting a held-out recording
    cablesense.predict_recording(fit["scene"], "val.csv")["errors"]["mean_removed"]

The thesis validation (data embedded in the library):

    v = cablesense.validate_thesis("4.3")  # rows, per-point and per-cable summaries

Invalid scenes raise SceneError (a ValueError) whose `field` names the offending
field path, e.g. "robot.sections[0].length_m"; bad readings raise ReadingsError
(`field` e.g. "readings[1] (s1b)", `line`); a calibration that cannot run raises
CalibrationError (`file`, `line`, `column`, `field`).
"""

from ._cablesense import (
    CalibrationError,
    Estimator,
    ReadingsError,
    Scene,
    SceneError,
    Solver,
    TendonSolver,
    calibrate,
    predict_recording,
    solve,
    validate_thesis,
    __version__,
)

__all__ = [
    "CalibrationError",
    "Estimator",
    "ReadingsError",
    "Scene",
    "SceneError",
    "Solver",
    "TendonSolver",
    "calibrate",
    "predict_recording",
    "solve",
    "validate_thesis",
    "__version__",
]
