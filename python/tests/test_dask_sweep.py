"""The scale-out example (python/examples/dask_sweep.py) on a local Dask cluster of
two worker processes: the design sweep's results equal the serial run's, bit for
bit. Skipped when `distributed` is not installed (.ci/run installs it)."""

import os
import pathlib
import sys

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def test_dask_sweep_equals_the_serial_sweep(monkeypatch):
    # the workers import the task function from the example module by name
    monkeypatch.syspath_prepend(str(EXAMPLES))
    path = os.pathsep.join([str(EXAMPLES)] + [p for p in [os.environ.get("PYTHONPATH")] if p])
    monkeypatch.setenv("PYTHONPATH", path)
    import dask_sweep

    import cablesense

    base = cablesense.demo.scene("scenes/ftdcr_v4.toml")
    rows = dask_sweep.recording_rows(base, "hardware/ftdcr_v4/val.csv", 20)
    assert rows.shape == (20, 9)
    points = dask_sweep.designs([0.0, 0.003], [0.9, 1.1])
    ref = dask_sweep.serial(base, rows, points)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        out = dask_sweep.on_dask(client, base, rows, points)
        pids = set(client.run(os.getpid).values())
    assert len(pids) == 2 and os.getpid() not in pids  # separate processes
    assert [(r.payload_kg, r.modulus_scale) for r in out] == points
    assert all(r.converged.all() for r in out)
    assert dask_sweep.same(ref, out)
    # the designs differ (the comparison is not of four copies of one result)
    assert np.abs(out[0].tips - out[3].tips).max() > 1e-3
