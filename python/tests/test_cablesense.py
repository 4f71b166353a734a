"""pytest suite of the Python bindings (run by .ci/run after `maturin develop`)."""

import math
import pathlib

import numpy as np
import pytest

import cablesense

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
TRACK = DATA / "scenes" / "track_demo.toml"
DEMO = DATA / "scenes" / "demo_two_section.toml"


def first_rows(n):
    rows = []
    for line in (DATA / "measurements" / "track_demo.csv").read_text().splitlines()[2:]:
        cells = line.split(",")
        try:
            rows.append([float(c) for c in cells[1:]])
        except ValueError:
            continue
        if len(rows) == n:
            break
    return rows


def test_solve_returns_arrays():
    sol = cablesense.solve(cablesense.Scene.from_file(DEMO))
    assert sol["report"]["converged"] and sol["report"]["status"] == "converged"
    n = sol["s"].shape[0]
    assert sol["r"].shape == (n, 3) and sol["R"].shape == (n, 3, 3)
    # rotations are orthonormal along the rod
    for R in sol["R"][:: max(1, n // 10)]:
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-9)
    assert np.allclose(sol["tip"], sol["r"][-1], atol=1e-12)
    assert np.allclose(sol["section_tips"][-1], sol["tip"], atol=1e-12)
    assert sol["cable_lengths"].shape == (6,) and np.all(sol["cable_lengths"] > 0.1)


def test_warm_solver_matches_cold_solve():
    scene = cablesense.Scene.from_file(TRACK)
    cold = cablesense.solve(scene)
    solver = cablesense.Solver(scene)
    a = solver.solve()
    b = solver.solve()  # warm: already at the solution
    assert b["report"]["iterations"] <= a["report"]["iterations"]
    assert np.allclose(a["tip"], cold["tip"], atol=1e-9)
    assert np.allclose(b["tip"], cold["tip"], atol=1e-9)


def test_scene_from_dict_equals_file():
    d = {
        "robot": {
            "sections": [
                {
                    "length_m": 0.3,
                    "shape": {"solid": {"diameter_m": 1.56e-3}},
                    "youngs_modulus_pa": 62.7e9,
                    "poisson_ratio": 0.3,
                    "density_kg_m3": 6800.0,
                }
            ]
        },
        "loads": {"gravity_m_s2": [0.0, 0.0, 0.0]},
    }
    sol = cablesense.solve(cablesense.Scene.from_dict(d))
    # no load, no gravity: straight along z
    assert np.allclose(sol["tip"], [0.0, 0.0, 0.3], atol=1e-12)


def test_estimator_recovers_the_demo_force():
    est = cablesense.Estimator(cablesense.Scene.from_file(TRACK))
    assert est.names == ["force_y@s0", "force_z@s0"]
    out = est.tick(first_rows(1)[0])
    assert out["status"] == "converged" and out["fit"] == "good"
    # truth at t = 0: F_y = -0.05 N, F_z = 0.04 N; noise ~2e-4 N
    assert abs(out["values"][0] + 0.05) < 1e-3 and abs(out["values"][1] - 0.04) < 1e-3
    assert out["covariance"].shape == (2, 2)
    assert np.allclose(np.sqrt(np.diag(out["covariance"])), out["std_dev"])
    # a missing cable and explicit noise
    out = est.tick([math.nan, -2.5e-3, 2.2e-4], sigma=[1e-5, 1e-5, 1e-5])
    assert out["redundancy"] == 0 and out["fit"] == "untestable"


def test_errors_carry_the_field_path():
    text = TRACK.read_text().replace("length_m = 0.39", "length_m = -0.39", 1)
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.Scene.from_toml(text)
    assert e.value.field == "robot.sections[0].length_m"
    assert str(e.value).count("must be > 0, got -0.39") == 1
    with pytest.raises(ValueError):
        cablesense.Scene.from_file(DATA / "nope.toml")
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.Estimator(cablesense.Scene.from_file(DEMO))
    assert e.value.field == "estimate"
    est = cablesense.Estimator(cablesense.Scene.from_file(TRACK))
    with pytest.raises(ValueError, match="2 changes for 3 cables"):
        est.tick([1e-3, 1e-3])
