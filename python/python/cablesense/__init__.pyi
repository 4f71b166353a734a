"""Type stubs of the cablesense extension (see __init__.py for the overview)."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

class SceneError(ValueError):
    """A scene could not be read or is invalid."""

    field: Optional[str]
    """Offending field path, e.g. ``robot.sections[0].length_m`` (None for syntax errors)."""

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
#            continuation_steps}
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
    ) -> Estimate: ...
