"""Inverse kinematics (`IkSolver`) and the reachable workspace (`workspace`) from
Python: round trips through the model's own tips, honest outcomes for targets it
cannot reach, errors that name the bad argument, and the sampled workspace."""

import math
import pathlib

import numpy as np
import pytest

import cablesense

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"
FTDCR = DATA / "calibration" / "ftdcr_v4_calibrated.toml"
DARU = DATA / "calibration" / "daru_calibrated.toml"
VAL = DATA / "hardware" / "ftdcr_v4" / "val.csv"


def model_rows(scene, n):
    """The model's tips (n, 3), tip axes (n, 3) and the readings (n, p) of the
    first n val rows of the FTDCR v4 recording (solved through the scene's
    [readings] table, as `cablesense reach` takes its default targets)."""
    ts = cablesense.TendonSolver(scene)
    tips, axes, readings = [], [], []
    for i, line in enumerate(VAL.read_text().splitlines(), 1):
        row = ts.solve_line(i, line)
        if row is None or not row["report"]["converged"]:
            continue
        tips.append(row["tip"])
        axes.append(ts.solution()["R"][-1][:, 2])
        readings.append(row["readings"])
        if len(tips) == n:
            break
    return np.array(tips), np.array(axes), np.array(readings)


@pytest.fixture(scope="module")
def ftdcr():
    return cablesense.Scene.from_file(FTDCR)


def test_ik_of_the_model_tip_reproduces_it(ftdcr):
    tips, _, _ = model_rows(ftdcr, 12)
    ik = cablesense.IkSolver(ftdcr)
    assert ik.columns[0] == "servo_4_mm" and ik.limits.shape == (9, 2)
    # the shipped limits: segment 0 [-10.5, 5.5] mm
    assert ik.limits[0] == pytest.approx([-10.5e-3, 5.5e-3])
    ts = cablesense.TendonSolver(ftdcr)
    for tip in tips:
        readings, res = ik.ik(tip)  # warm from the previous row
        assert res["status"] == "reached" and res["reached"], res
        assert res["distance_m"] <= 5e-5
        assert res["objective"] == "closest"
        assert np.all(readings >= ik.limits[:, 0]) and np.all(readings <= ik.limits[:, 1])
        assert np.array_equal(readings, ik.readings)
        # the readings, solved forward again, reproduce the target within 0.05 mm
        again = ts.solve(readings)["tip"]
        assert np.linalg.norm(again - tip) <= 5e-5, (again, tip)
        assert res["tensions"].shape == (9,) and res["taut"].dtype == np.bool_
    # the batch: from zero readings, chained through the same rows
    ik.set_readings(np.zeros(9))
    assert np.allclose(ik.readings, 0.0)
    batch = ik.ik_many(tips)
    assert batch["readings"].shape == (12, 9) and batch["tip"].shape == (12, 3)
    assert batch["status"] == ["reached"] * 12, batch["status"]
    assert np.all(batch["status_code"] == 0) and batch["status_code"].dtype == np.int8
    assert np.all(batch["distance_m"] <= 5e-5)
    assert np.all(np.linalg.norm(batch["tip"] - tips, axis=1) <= 5e-5)
    assert batch["errors"] == [None] * 12


def test_the_batch_is_the_calls_one_by_one(ftdcr):
    tips, _, _ = model_rows(ftdcr, 8)
    a, b = cablesense.IkSolver(ftdcr), cablesense.IkSolver(ftdcr)
    batch = a.ik_many(tips)
    for i, tip in enumerate(tips):
        readings, res = b.ik(tip)
        assert np.array_equal(batch["readings"][i], readings), i
        assert batch["distance_m"][i] == res["distance_m"]
        assert batch["status"][i] == res["status"]
        assert batch["iterations"][i] == res["iterations"]
    assert np.array_equal(a.readings, b.readings)


def test_a_target_outside_the_workspace_is_unreachable_not_an_exception(ftdcr):
    ik = cablesense.IkSolver(ftdcr)
    start = ik.tip.copy()
    # 10 cm beyond the straight tip: longer than the robot can stretch
    readings, res = ik.ik(start + [0.0, 0.0, 0.1])
    assert res["status"] == "unreachable" and not res["reached"], res
    assert res["distance_m"] > 0.09
    assert res["first_order"] <= 1e-2
    assert np.linalg.norm(res["tip"] - (start + [0.0, 0.0, 0.1])) == pytest.approx(
        res["distance_m"], abs=1e-15
    )
    assert np.all(readings >= ik.limits[:, 0] - 1e-15)
    assert np.all(readings <= ik.limits[:, 1] + 1e-15)
    # in a batch too, between reachable rows
    tips, _, _ = model_rows(ftdcr, 2)
    ik.set_readings(np.zeros(9))
    batch = ik.ik_many([tips[0], start + [0.0, 0.0, 0.1], tips[1]])
    assert batch["status"][1] == "unreachable", batch
    assert batch["status_code"][1] == 1
    assert batch["reached"][0], batch


def test_bad_targets_name_the_argument(ftdcr):
    tips, _, _ = model_rows(ftdcr, 3)
    ik = cablesense.IkSolver(ftdcr)
    ik.ik(tips[0])
    before = ik.readings.copy()
    with pytest.raises(cablesense.TargetError) as e:
        ik.ik([0.0, math.nan, 0.18])
    assert e.value.field == "target[1]" and "finite" in str(e.value)
    assert isinstance(e.value, ValueError)
    with pytest.raises(cablesense.TargetError) as e:
        ik.ik(tips[1], direction=[0.0, 0.0, 0.0])
    assert e.value.field == "direction" and "zero length" in str(e.value)
    with pytest.raises(cablesense.TargetError) as e:
        ik.ik(tips[1], direction=[0.0, math.inf, 1.0])
    assert e.value.field == "direction[1]"
    with pytest.raises(cablesense.TargetError) as e:
        ik.ik([0.0, 0.18])
    assert e.value.field == "target" and "got 2 values" in str(e.value)
    with pytest.raises(TypeError, match="target: expected 3 coordinates"):
        ik.ik("abc")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="1-D float array"):
        ik.ik(np.zeros((3, 1)))
    # nothing moved
    assert np.array_equal(ik.readings, before)
    # a bad row in a batch does not stop it: status "invalid", the next row goes on
    bad = np.array([tips[1], [0.0, 0.0, math.nan], tips[2]])
    batch = ik.ik_many(bad)
    assert batch["status"] == ["reached", "invalid", "reached"], batch
    assert batch["status_code"].tolist() == [0, -1, 0]
    assert np.all(np.isnan(batch["readings"][1])) and np.all(np.isnan(batch["tip"][1]))
    assert batch["errors"][0] is None and batch["errors"][2] is None
    assert "targets[1][2]" in batch["errors"][1]
    dirs = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    batch = ik.ik_many(tips, directions=dirs)
    assert batch["status"][1] == "invalid" and "directions[1]" in batch["errors"][1]
    with pytest.raises(cablesense.TargetError) as e:
        ik.ik_many(np.zeros((4, 2)))
    assert e.value.field == "targets"
    with pytest.raises(cablesense.TargetError) as e:
        ik.ik_many(tips, directions=np.ones((2, 3)))
    assert e.value.field == "directions"
    with pytest.raises(TypeError, match=r"shape \(n, 3\)"):
        ik.ik_many(np.zeros(3))
    # a dtype numpy cannot make floats of
    with pytest.raises(TypeError, match="targets: .*numpy cannot convert"):
        ik.ik_many(np.array([["a", "b", "c"]]))
    with pytest.raises(TypeError, match="target: expected 3 coordinates"):
        ik.ik(np.array(["a", "b", "c"]))
    # integers are numbers: an int array is a target like any other
    _, res = ik.ik(np.array([0, 0, 1]))
    assert res["status"] == "unreachable", res
    # start readings outside the limits: ReadingsError naming the reading
    with pytest.raises(cablesense.ReadingsError) as e:
        ik.set_readings([0.02] + [0.0] * 8)
    assert e.value.field == "readings[0] (servo_4_mm)" and "actuator limits" in str(e.value)


def test_bad_settings_name_the_field(ftdcr):
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.IkSolver(ftdcr, tolerance_m=0.0)
    assert e.value.field == "ik.tolerance_m"
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.IkSolver(ftdcr, objective="fastest")  # type: ignore[arg-type]
    assert e.value.field == "ik.objective"
    ik = cablesense.IkSolver(ftdcr, max_iterations=50)
    assert ik.settings["max_iterations"] == 50
    assert ik.settings["rest_weight"] == 1e-3
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.IkSolver(ftdcr, rest_weight=-1.0)
    assert e.value.field == "ik.rest_weight"
    assert cablesense.IkSolver(ftdcr, rest_weight=0.0).settings["rest_weight"] == 0.0
    with pytest.raises(cablesense.SceneError) as e:
        ik.ik([0.0, 0.0, 0.18], secondary_weight=-1.0)
    assert e.value.field == "ik.secondary_weight"
    # no displacement-driven tendon
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.IkSolver(cablesense.Scene.from_file(DATA / "scenes" / "track_demo.toml"))
    assert e.value.field == "robot.cables"
    # limits that exclude reading 0 are a scene error naming the field
    text = DARU.read_text()
    assert "[robot.limits]" in text
    bad = text.replace("sections = [[0.0, 100.0]]", "sections = [[10.0, 100.0]]")
    assert bad != text
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.IkSolver(cablesense.Scene.from_toml(bad))
    assert e.value.field is not None and "limits" in e.value.field


def test_the_objective_chooses_and_says_so(ftdcr):
    tips, _, _ = model_rows(ftdcr, 30)
    target = tips[29]
    pulls = {}
    for objective in ("closest", "least_pull"):
        ik = cablesense.IkSolver(ftdcr, objective=objective)
        readings, res = ik.ik(target)
        assert res["status"] == "reached", (objective, res)
        assert res["objective"] == objective
        pulls[objective] = readings.sum()
    assert pulls["least_pull"] <= pulls["closest"] + 1e-9, pulls
    # a call's override applies to that call only
    ik = cablesense.IkSolver(ftdcr)
    readings, res = ik.ik(target, objective="least_pull")
    assert res["objective"] == "least_pull"
    assert readings.sum() == pytest.approx(pulls["least_pull"], abs=1e-9)
    _, res = ik.ik(target)
    assert res["objective"] == "closest"
    assert ik.settings["objective"] == "closest"


def test_a_direction_target_is_followed(ftdcr):
    tips, axes, readings = model_rows(ftdcr, 20)
    ik = cablesense.IkSolver(ftdcr, max_iterations=100, max_forward_solves=300)
    ik.set_readings(readings[18])
    q, res = ik.ik(tips[19], direction=3.0 * axes[19])
    assert res["status"] == "reached", res
    assert res["angle_rad"] <= 1e-3 and res["distance_m"] <= 1e-5


def test_workspace_returns_the_cloud_and_its_hull():
    scene = cablesense.Scene.from_file(DARU)
    seen = []
    ws = cablesense.workspace(scene, samples=120, threads=2, progress=seen.append)
    n = 120
    assert ws["columns"] == ["l1", "l2", "l3"]
    assert ws["readings"].shape == (n, 3) and ws["tips"].shape == (n, 3)
    assert ws["status"].shape == (n,) and ws["status"].dtype == np.uint8
    assert ws["status_names"] == [
        "converged",
        "converged_stepped",
        "converged_cold",
        "failed",
        "converged_neighbour",
    ]
    assert np.array_equal(ws["solved"], ws["status"] != 3)
    assert ws["solved_count"] + ws["failed_count"] == n and ws["solved_count"] > 100
    # unsolved samples have NaN tips, solved ones finite
    assert np.all(np.isfinite(ws["tips"][ws["solved"]]))
    assert np.all(np.isnan(ws["tips"][~ws["solved"]]))
    # the samples lie in the limits box (0..100 units of 1e-4 m)
    assert ws["limits"] == pytest.approx(np.array([[0.0, 0.01]] * 3))
    assert np.all(ws["readings"] >= 0.0) and np.all(ws["readings"] <= 0.01)
    vol = ws["hull_volume_m3"]
    assert vol is not None and vol > 0.0 and ws["hull_error"] is None
    v, t = ws["hull_vertices"], ws["hull_triangles"]
    assert v.shape[1] == 3 and t.shape[1] == 3 and t.max() < v.shape[0]
    # every solved tip within the hull's bounds
    tips = ws["tips"][ws["solved"]]
    assert np.all(tips >= v.min(axis=0) - 1e-12) and np.all(tips <= v.max(axis=0) + 1e-12)
    # the volume from the triangles (divergence theorem) equals the reported one
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0 == pytest.approx(vol, rel=1e-9)
    # progress: once per sample
    assert len(seen) == n and max(seen) == n
    assert ws["markers"] is None
    # the result does not depend on the threads; a marker 25 mm along the tip axis
    one = cablesense.workspace(scene, samples=120, threads=1, marker_offset=[0.0, 0.0, 0.025])
    assert np.array_equal(one["tips"], ws["tips"], equal_nan=True)
    markers = one["markers"]
    assert markers is not None and markers.shape == (n, 3)
    gap = np.linalg.norm(markers - one["tips"], axis=1)[one["solved"]]
    assert np.allclose(gap, 0.025, atol=1e-12), gap


def test_workspace_errors_name_the_field():
    scene = cablesense.Scene.from_file(DARU)
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.workspace(scene, samples=0)
    assert e.value.field == "workspace.samples"
    # a scene without [robot.limits]: no box to sample
    two = cablesense.Scene.from_file(DATA / "scenes" / "tdcr_two_segment.toml")
    with pytest.raises(cablesense.SceneError) as e:
        cablesense.workspace(two, samples=10)
    assert e.value.field is not None and e.value.field.startswith("robot.limits")

    def stop(done: int) -> None:
        raise RuntimeError(f"stop at {done}")

    with pytest.raises(cablesense.SceneError) as e:
        cablesense.workspace(scene, samples=5, marker_offset=[0.0, math.nan, 0.0])
    assert e.value.field is not None and "marker_offset" in e.value.field
    with pytest.raises(RuntimeError, match="stop at 1"):
        cablesense.workspace(scene, samples=5, threads=1, progress=stop)
