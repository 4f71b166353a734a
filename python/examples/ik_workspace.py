"""Commanding the robot from Python: readings for a loop of tip targets (inverse
kinematics inside the scene's ``[robot.limits]``, warm from tick to tick; the
targets are the model's own tips along a loop of readings, so each is reachable),
a target it cannot reach, and the reachable workspace of the one-segment robot with its
convex hull.

    python python/examples/ik_workspace.py
"""

from __future__ import annotations

import sys

import numpy as np

import cablesense


def main() -> int:
    scene = cablesense.Scene.from_file("demo:scenes/ftdcr_v4.toml")
    ts = cablesense.TendonSolver(scene)
    p = len(ts.columns)
    # a loop of readings: the first three tendons pulled in turn by up to 1.5 mm
    angles = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    rows = np.zeros((len(angles), p))
    for j in range(3):
        rows[:, j] = 1.5e-3 * np.maximum(0.0, np.cos(angles - 2.0 * np.pi * j / 3.0))
    loop = ts.solve_many(rows)["tip"]
    centre = ts.solve(np.zeros(p))["tip"]

    ik = cablesense.IkSolver(scene, objective="closest")
    print(f"limits (mm): {np.round(ik.limits[:3] * 1e3, 1).tolist()} ... ({len(ik.columns)} tendons)")
    # the loop's tips as targets, one per control tick
    batch: cablesense.IkBatch = ik.ik_many(loop)
    reached = int(batch["reached"].sum())
    worst_um = float(np.nanmax(batch["distance_m"])) * 1e6
    print(f"loop: {reached}/{len(loop)} reached, farthest {worst_um:.2f} um")

    # one tick at a time, with the result dict
    readings, result = ik.ik(centre)
    res: cablesense.IkResult = result
    print(
        f"straight: {res['status']} ({res['objective']}), {res['iterations']} iterations,"
        f" readings (mm) {np.round(readings * 1e3, 3).tolist()}"
    )
    # a target beyond the robot's reach: a status and the closest tip, no exception
    _, far = ik.ik(centre + [0.0, 0.0, 0.1])
    print(f"10 cm above: {far['status']}, closest tip {far['distance_m'] * 1e3:.1f} mm away")

    # the reachable workspace of the one-segment robot (0..100 units per cable)
    daru = cablesense.Scene.from_file("demo:scenes/daru.toml")
    ws: cablesense.WorkspaceCloud = cablesense.workspace(daru, samples=300)
    vol = ws["hull_volume_m3"]
    print(
        f"workspace: {ws['solved_count']}/{len(ws['status'])} samples solved in"
        f" {ws['sampling_s']:.1f} s, hull {vol * 1e6 if vol is not None else float('nan'):.2f} cm^3"
    )
    return 0 if reached == len(loop) else 1


if __name__ == "__main__":
    sys.exit(main())
