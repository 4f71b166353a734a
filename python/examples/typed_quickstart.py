"""The typed API in a few lines: a type checker (``mypy --strict``) knows every key
of the dicts the calls return (``cablesense.TendonRow``, ``TendonBatch``, ...).

    python python/examples/typed_quickstart.py
"""

from __future__ import annotations

import copy
import pickle

import numpy as np

import cablesense


def main() -> int:
    scene = cablesense.Scene.from_file("demo:scenes/ftdcr_v4.toml")
    ts = cablesense.TendonSolver(scene)
    q = np.zeros(len(ts.columns))
    q[0] = 1.5e-3  # m: pull the first tendon in by 1.5 mm
    row: cablesense.TendonRow = ts.solve(q)
    report: cablesense.TendonReport = row["report"]
    tip_mm = row["tip"] * 1e3
    print(f"tip {np.round(tip_mm, 2)} mm, {report['status']} in {report['iterations']} iterations")

    # the same readings with a 2 g payload at the tip, warm from the row above
    ts.set_loads({"point": [{"section": 2, "mass_kg": 0.002}]})
    loaded = ts.solve()
    sag_mm = float(np.linalg.norm(loaded["tip"] - row["tip"])) * 1e3
    print(f"a 2 g payload moves the tip {sag_mm:.3f} mm")

    # a ramp in one call, with the backbone of every row
    ramp = np.outer(np.linspace(0.0, 2e-3, 5), np.eye(len(ts.columns))[0])
    batch: cablesense.TendonBatch = ts.solve_many(ramp, shapes=True)
    shapes = batch.get("shapes")
    assert shapes is not None
    print(f"{int(batch['converged'].sum())}/{len(ramp)} rows, shapes {shapes.shape}")

    # the full solution of the last row carries that row's report
    sol: cablesense.TendonSolution = ts.solution()
    assert sol["report"]["converged"] == bool(batch["converged"][-1])

    # scenes are values: written out, pickled and copied without loss
    saved = scene.to_toml()
    assert cablesense.Scene.from_toml(saved) == scene
    assert pickle.loads(pickle.dumps(scene)) == copy.deepcopy(scene)

    # a forward solve with new loads on a live solver
    demo = cablesense.demo.scene("scenes/demo_two_section.toml")
    solver = cablesense.Solver(demo)
    first: cablesense.Solution = solver.solve()
    solver.set_loads({"gravity_m_s2": [0.0, 0.0, -9.81]})
    second = solver.solve()
    print(
        f"gravity turned: {first['report']['status']} -> {second['report']['status']}, "
        f"{second['report']['rhs_evals']} rod evaluations warm"
    )

    est = cablesense.Estimator(cablesense.demo.scene("scenes/track_demo.toml"))
    e: cablesense.Estimate = est.tick([1.7e-3, -2.4e-3, 2.5e-4])
    t: cablesense.Tick = est.tick([1.7e-3, -2.4e-3, 2.5e-4], snapshot=False)
    print(f"estimate {e['names']} = {np.round(e['values'], 4)} ({e['status']}, tick {t['status']})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
