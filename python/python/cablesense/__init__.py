"""cablesense: Cosserat-rod statics and load/shape estimation for cable-driven
continuum robots (Python bindings of the Rust crate; see the repository README).

    scene = cablesense.Scene.from_file("track_demo.toml")   # or from_toml / from_dict
    sol = cablesense.solve(scene)          # dict of numpy arrays + report
    solver = cablesense.Solver(scene)      # warm-started repeated solves
    est = cablesense.Estimator(scene)      # the scene's [estimate] problem
    out = est.tick([1.7e-3, -2.4e-3, 2.5e-4])

Invalid scenes raise SceneError (a ValueError) whose `field` names the offending
field path, e.g. "robot.sections[0].length_m".
"""

from ._cablesense import Estimator, Scene, SceneError, Solver, solve

__all__ = ["Estimator", "Scene", "SceneError", "Solver", "solve"]
