"""What the Python binding adds to a warm inverse-kinematics call: the calibrated
FTDCR v4, targets = the model's tips at the val rows, twice through the rows, each
call warm from the previous one; `IkSolver.ik` called once per target from Python
against `IkSolver.ik_many` (the same calls in one Rust loop, the GIL released once)
from the same start, three times in turn (the smallest total of each is kept: the
machine this runs on is shared). The two give the same readings bit for bit
(`python/tests/test_command.py`), so the difference is the binding's per call.

    python python/bench/ik_overhead.py
"""

from __future__ import annotations

import os
import pathlib
import time

import numpy as np

import cablesense

DATA = pathlib.Path(__file__).resolve().parents[2] / "data"


def main() -> None:
    scene = cablesense.Scene.from_file(DATA / "calibration" / "ftdcr_v4_calibrated.toml")
    ts = cablesense.TendonSolver(scene)
    tips = []
    for i, line in enumerate((DATA / "hardware" / "ftdcr_v4" / "val.csv").read_text().splitlines(), 1):
        row = ts.solve_line(i, line)
        if row is not None and row["report"]["converged"]:
            tips.append(row["tip"])
    targets = np.array(tips + tips)
    t_calls, t_batch = np.inf, np.inf
    for _ in range(3):
        one = cablesense.IkSolver(scene)
        per_call = []
        t_all = time.perf_counter()
        for t in targets:
            t0 = time.perf_counter()
            one.ik(t)
            per_call.append(time.perf_counter() - t0)
        t_calls = min(t_calls, time.perf_counter() - t_all)
        batch = cablesense.IkSolver(scene)
        t0 = time.perf_counter()
        out = batch.ik_many(targets)
        t_batch = min(t_batch, time.perf_counter() - t0)
    ms = np.array(per_call) * 1e3
    n = len(targets)
    print(
        f"{n} warm calls: ik() per call median {np.median(ms):.3f} ms, p90 {np.percentile(ms, 90):.2f},"
        f" p99 {np.percentile(ms, 99):.2f}, max {ms.max():.1f}; {out['reached'].sum()} reached"
    )
    print(
        f"all calls {t_calls:.3f} s from Python, {t_batch:.3f} s in ik_many (best of 3):"
        f" {(t_calls - t_batch) / n * 1e6:.1f} us per call for the binding"
        f" (load average {os.getloadavg()[0]:.1f})"
    )


if __name__ == "__main__":
    main()
