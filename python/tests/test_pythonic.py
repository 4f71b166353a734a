"""The API a Python user expects (issue 43): scenes as values (TOML, dict, pickle,
deepcopy), new loads and readings on live solvers without a cold start, batch
shapes, the embedded demo data, the row's report in `solution()`, and type errors
that say what was expected."""

import copy
import pathlib
import pickle

import numpy as np
import pytest

import cablesense
import cablesense.demo

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
DEMO = DATA / "scenes" / "demo_two_section.toml"
FTDCR = DATA / "scenes" / "ftdcr_v4.toml"


def test_scene_round_trips_through_toml_dict_pickle_and_deepcopy():
    for name in cablesense.demo.names():
        if not name.endswith(".toml") or name == "thesis/fitted.toml":
            continue
        scene = cablesense.demo.scene(name)
        text = scene.to_toml()
        assert cablesense.Scene.from_toml(text) == scene, name
        assert cablesense.Scene.from_dict(scene.to_dict()) == scene, name
        assert cablesense.Scene.from_json(scene.to_json()) == scene, name
        assert pickle.loads(pickle.dumps(scene)) == scene, name
        assert copy.deepcopy(scene) == scene and copy.copy(scene) == scene, name
    # the same solve, bit for bit, from the scene written out and read back
    scene = cablesense.Scene.from_file(DEMO)
    again = cablesense.Scene.from_toml(scene.to_toml())
    a, b = cablesense.solve(scene), cablesense.solve(again)
    assert np.array_equal(a["r"], b["r"]) and a["report"] == b["report"]
    # a changed scene (as a calibration makes) keeps its change through the trip
    heavier = scene.with_loads({"point": [{"section": 1, "mass_kg": 0.03}]})
    assert heavier != scene
    back = pickle.loads(pickle.dumps(cablesense.Scene.from_toml(heavier.to_toml())))
    assert back == heavier and back.to_dict()["loads"]["point"][0]["mass_kg"] == 0.03
    assert scene.to_dict()["loads"]["point"][0]["mass_kg"] == 0.02  # unchanged


def test_solver_takes_new_loads_warm():
    scene = cablesense.Scene.from_file(DEMO)
    tensions = list(scene.to_dict()["loads"]["tensions_n"])
    tensions[0] *= 1.02
    solver = cablesense.Solver(scene)
    solver.solve()
    solver.set_loads({"tensions_n": tensions})
    assert solver.loads["tensions_n"] == tensions
    assert solver.loads["point"][0]["mass_kg"] == 0.02  # keys not given are kept
    warm = solver.solve()
    cold = cablesense.solve(scene.with_loads({"tensions_n": tensions}))
    assert warm["report"]["converged"] and cold["report"]["converged"]
    # the same equilibrium to the shooting tolerance (seen: 3.5e-12 m) ...
    assert np.abs(warm["r"] - cold["r"]).max() < 1e-9
    # ... reached warm: fewer rod evaluations than the cold solve (seen 4332 vs 7952)
    assert warm["report"]["rhs_evals"] < 0.8 * cold["report"]["rhs_evals"]
    # a bad key or value changes nothing
    with pytest.raises(cablesense.SceneError) as e:
        solver.set_loads({"gravity": [0.0, 0.0, 0.0]})
    assert "gravity" in str(e.value) and e.value.field == "loads"
    with pytest.raises(cablesense.SceneError):
        solver.set_loads({"gravity_m_s2": [float("inf"), 0.0, 0.0]})
    with pytest.raises(cablesense.SceneError) as e:
        solver.set_loads({"tensions_n": [-1.0]})
    assert e.value.field == "loads.tensions_n[0]"
    assert solver.loads["tensions_n"] == tensions


def test_tendon_solver_takes_new_loads_warm():
    # a payload at the tip of the FTDCR v4 (the scene with a 0 kg payload site, so
    # that a new mass changes values, not the structure)
    scene = cablesense.Scene.from_file(FTDCR).with_loads(
        {"point": [{"section": 2, "mass_kg": 0.0}]}
    )
    q = np.zeros(9)
    q[0], q[4] = 2e-3, 1e-3
    live = cablesense.TendonSolver(scene)
    before = live.solve(q)
    live.set_loads({"point": [{"section": 2, "mass_kg": 0.002}]})
    assert live.loads["point"][0]["mass_kg"] == 0.002
    warm = live.solve()  # the same readings, now with 2 g at the tip
    fresh = cablesense.TendonSolver(scene)
    fresh.set_loads({"point": [{"section": 2, "mass_kg": 0.002}]})
    cold = fresh.solve(q, warm=False)
    assert warm["report"]["converged"] and cold["report"]["converged"]
    moved = np.abs(warm["tip"] - before["tip"]).max()
    assert moved > 5e-5  # the payload moves the tip (seen 0.11 mm) ...
    # ... and the warm row is the cold one to the tendon tolerance (seen 0.27 um)
    assert np.abs(warm["tip"] - cold["tip"]).max() < 1e-5
    # fewer rod evaluations than the cold row (seen 6 vs 10)
    assert warm["report"]["forward_solves"] < cold["report"]["forward_solves"]
    # a payload where the scene had none changes the load structure (the shooting
    # workspace is rebuilt): still warm from the last shape, the same row as cold
    # (it stalled from the rebuilt straight rod: 21 mm off)
    plain = cablesense.TendonSolver(cablesense.Scene.from_file(FTDCR))
    plain.solve(q)
    plain.set_loads({"point": [{"section": 2, "mass_kg": 0.002}]})
    rebuilt = plain.solve()
    assert rebuilt["report"]["converged"], rebuilt["report"]
    assert np.abs(rebuilt["tip"] - cold["tip"]).max() < 1e-5
    # a driven tendon's tension comes from its reading, not from the loads
    with pytest.raises(cablesense.SceneError) as e:
        live.set_loads({"tensions_n": [1.0]})
    assert e.value.field == "loads.tensions_n[0]"
    assert live.loads["point"][0]["mass_kg"] == 0.002


def test_set_readings_then_solve():
    scene = cablesense.Scene.from_file(FTDCR)
    a, b = cablesense.TendonSolver(scene), cablesense.TendonSolver(scene)
    q = np.zeros(9)
    q[1] = 1.5e-3
    assert np.array_equal(a.readings, np.zeros(9))
    a.set_readings(q)
    assert np.array_equal(a.readings, q)
    ra, rb = a.solve(), b.solve(q)
    assert np.array_equal(ra["tip"], rb["tip"]) and ra["report"] == rb["report"]
    with pytest.raises(cablesense.ReadingsError) as e:
        a.set_readings([0.0] * 8)
    assert e.value.field == "readings"
    with pytest.raises(cablesense.ReadingsError):
        a.set_readings([float("nan")] + [0.0] * 8)
    assert np.array_equal(a.readings, q)  # unchanged by the bad ones


def test_solve_many_returns_the_shapes():
    scene = cablesense.Scene.from_file(FTDCR)
    Q = np.zeros((5, 9))
    Q[:, 0] = np.linspace(0.0, 2e-3, 5)
    batch = cablesense.TendonSolver(scene).solve_many(Q, shapes=True)
    n, m = 5, batch["s"].shape[0]
    assert m > 10 and batch["shapes"].shape == (n, m, 3)
    assert np.allclose(batch["shapes"][:, -1], batch["tip"], atol=1e-12)
    assert "shapes" not in cablesense.TendonSolver(scene).solve_many(Q)
    # the same rows one at a time: the same backbones, bit for bit
    one = cablesense.TendonSolver(scene)
    for i in range(n):
        one.solve(Q[i])
        sol = one.solution()
        assert np.array_equal(sol["r"], batch["shapes"][i]), i
        assert np.array_equal(sol["s"], batch["s"])
    # an integer array or nested lists are converted like numpy converts them
    ints = cablesense.TendonSolver(scene).solve_many(np.zeros((2, 9), dtype=np.int64))
    lists = cablesense.TendonSolver(scene).solve_many([[0.0] * 9, [0.0] * 9])
    assert np.array_equal(ints["tip"], lists["tip"])


def test_demo_data_is_reachable_from_python():
    embedded = cablesense.Scene.from_file("demo:scenes/ftdcr_v4.toml")
    assert embedded == cablesense.Scene.from_file(FTDCR)
    assert cablesense.demo.scene("scenes/ftdcr_v4.toml") == embedded
    assert "hardware/ftdcr_v4/val.csv" in cablesense.demo.names()
    val = cablesense.demo.text("demo:hardware/ftdcr_v4/val.csv")
    assert val == (DATA / "hardware" / "ftdcr_v4" / "val.csv").read_text()
    about = dict(cablesense.demo.files())
    assert "FTDCR" in about["scenes/ftdcr_v4.toml"]
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.Scene.from_file("demo:scenes/nope.toml")
    assert "demo:scenes/nope.toml" in str(e.value)
    with pytest.raises(KeyError):
        cablesense.demo.text("scenes/nope.toml")


def test_solution_has_the_rows_report_after_warm_rows():
    scene = cablesense.Scene.from_file(FTDCR)
    ts = cablesense.TendonSolver(scene)
    lines = cablesense.demo.text("hardware/ftdcr_v4/val.csv").splitlines()
    rows = [ts.solve_line(i, line) for i, line in enumerate(lines[:30], start=1)]
    last = rows[-1]
    assert last is not None and last["report"]["converged"]
    sol = ts.solution()
    assert sol["report"] == last["report"]
    assert np.array_equal(sol["tip"], last["tip"])
    # after a row that does not converge: its report, with the diagnosis
    bad = ts.solve([0.05] + [0.0] * 8)
    assert not bad["report"]["converged"]
    assert ts.solution()["report"] == bad["report"] and "diagnosis" in bad["report"]


def test_type_errors_say_what_was_expected():
    ts = cablesense.TendonSolver(cablesense.Scene.from_file(FTDCR))
    with pytest.raises(TypeError) as e:
        ts.solve_many(np.zeros(9))
    assert str(e.value) == (
        "rows: expected a 2-D float array of shape (n, 9), one row of 9 readings (m)"
        " per solve; got ndarray of shape (9,) and dtype float64"
    )
    with pytest.raises(TypeError) as e:
        ts.solve_many([["a"] * 9])
    assert "shape (n, 9)" in str(e.value) and "cannot convert to float64" in str(e.value)
    with pytest.raises(cablesense.ReadingsError) as e:
        ts.solve_many(np.zeros((3, 4)))
    assert "4 columns for 9" in str(e.value) and "shape (3, 4)" in str(e.value)
    with pytest.raises(TypeError) as e:
        ts.solve(np.zeros((2, 9)))
    assert str(e.value) == (
        "readings: expected 9 readings (m) as a sequence of floats or a 1-D float"
        " array; got ndarray of shape (2, 9) and dtype float64"
    )
    with pytest.raises(TypeError) as e:
        ts.solve([0.0, "x"] + [0.0] * 7)
    assert "got list of 9 items, whose item 1 is str" in str(e.value)
    est = cablesense.Estimator(cablesense.Scene.from_file(DATA / "scenes" / "track_demo.toml"))
    with pytest.raises(TypeError) as e:
        est.tick("abc")
    assert "expected 3 cable length changes (m)" in str(e.value)
    # a float32 or int array is a 1-D float array like any other
    row = ts.solve(np.zeros(9, dtype=np.float32))
    assert row["report"]["converged"]
    assert "'ndarray' object cannot be cast" not in str(e.value)


def test_set_loads_after_a_failed_row_is_as_without_it():
    # a failed row leaves a rollback pending; set_loads applies it first, so the
    # rows under the new loads are bit-identical to those of a solver that never saw
    # the failed row (with and without a change of the load structure)
    for with_site in [True, False]:
        scene = cablesense.Scene.from_file(FTDCR)
        if with_site:
            scene = scene.with_loads({"point": [{"section": 2, "mass_kg": 0.0}]})
        Q = np.zeros((6, 9))
        Q[:, 2] = np.linspace(0.0, 1.5e-3, 6)
        clean, faulty = cablesense.TendonSolver(scene), cablesense.TendonSolver(scene)
        clean.solve_many(Q[:3])
        faulty.solve_many(Q[:3])
        assert not faulty.solve([0.05] + [0.0] * 8)["report"]["converged"]
        for ts in (clean, faulty):
            ts.set_loads({"point": [{"section": 2, "mass_kg": 0.003}]})
        a, b = clean.solve_many(Q[3:]), faulty.solve_many(Q[3:])
        assert a["converged"].all(), with_site
        for key in ["tip", "tensions", "iterations"]:
            assert np.array_equal(a[key], b[key]), (with_site, key)
