"""A design sweep of the FTDCR v4 mapped over a Dask cluster with the ordinary API.

Every design point is a scene (a payload at the tip and a scale on the backbone's
Young's modulus) built from the embedded FTDCR v4 scene with ``Scene.to_dict`` /
``Scene.from_dict``; each task solves the held-out recording's servo readings with
its own warm-started ``TendonSolver`` and returns the tips. Scenes pickle, so they
travel to the worker processes as they are; Dask schedules (no scheduler of our
own). The serial run is the same function in a loop, and gives the same numbers
bit for bit (each task is deterministic and independent of the others).

    python python/examples/dask_sweep.py --workers 2 --rows 100

On a cluster, pass its scheduler address instead (``--scheduler tcp://host:8786``);
the workers need ``cablesense`` installed.
"""

from __future__ import annotations

import argparse
import time
from typing import List, NamedTuple, Optional, Sequence, Tuple

import distributed
import numpy as np
import numpy.typing as npt

import cablesense

Floats = npt.NDArray[np.float64]


class Result(NamedTuple):
    """The outcome of one design point over the rows."""

    payload_kg: float
    modulus_scale: float
    tips: Floats
    """(n, 3) m, one tip per row."""
    converged: npt.NDArray[np.bool_]
    """(n,) whether each row converged."""


def design_scene(
    base: cablesense.Scene, payload_kg: float, modulus_scale: float
) -> cablesense.Scene:
    """``base`` with a payload at the tip and every section's modulus scaled."""
    d = base.to_dict()
    for section in d["robot"]["sections"]:
        section["youngs_modulus_pa"] *= modulus_scale
    tip_section = len(d["robot"]["sections"]) - 1
    d["loads"]["point"] = [{"section": tip_section, "mass_kg": payload_kg}]
    return cablesense.Scene.from_dict(d)


def recording_rows(scene: cablesense.Scene, name: str, count: int) -> Floats:
    """The first ``count`` rows of an embedded recording as readings (m), in the
    solver's column order (the scene's ``[readings]`` table maps and scales them)."""
    reader = cablesense.TendonSolver(scene)
    rows: List[Floats] = []
    for i, line in enumerate(cablesense.demo.text(name).splitlines(), start=1):
        row = reader.solve_line(i, line)
        if row is not None:
            rows.append(row["readings"])
        if len(rows) == count:
            break
    return np.array(rows)


def solve_design(
    scene: cablesense.Scene, rows: Floats, payload_kg: float, modulus_scale: float
) -> Result:
    """One task: the rows in order on a fresh solver of ``scene``."""
    batch = cablesense.TendonSolver(scene).solve_many(rows)
    return Result(payload_kg, modulus_scale, batch["tip"], batch["converged"])


def designs(payloads: Sequence[float], scales: Sequence[float]) -> List[Tuple[float, float]]:
    """Every (payload, modulus scale) pair."""
    return [(m, e) for m in payloads for e in scales]


def serial(base: cablesense.Scene, rows: Floats, points: Sequence[Tuple[float, float]]) -> List[Result]:
    """The sweep in this process, one design after the other."""
    return [solve_design(design_scene(base, m, e), rows, m, e) for m, e in points]


def on_dask(
    client: distributed.Client,
    base: cablesense.Scene,
    rows: Floats,
    points: Sequence[Tuple[float, float]],
) -> List[Result]:
    """The sweep as one Dask task per design (results in the order of ``points``)."""
    scenes = [design_scene(base, m, e) for m, e in points]
    shared = client.scatter(rows, broadcast=True)
    futures = client.map(
        solve_design,
        scenes,
        [shared] * len(points),
        [m for m, _ in points],
        [e for _, e in points],
        pure=False,
    )
    results: List[Result] = client.gather(futures)
    return results


def same(a: Sequence[Result], b: Sequence[Result]) -> bool:
    """Bit-identical tips and flags, design by design."""
    return len(a) == len(b) and all(
        x.payload_kg == y.payload_kg
        and x.modulus_scale == y.modulus_scale
        and np.array_equal(x.tips, y.tips)
        and np.array_equal(x.converged, y.converged)
        for x, y in zip(a, b)
    )


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--workers", type=int, default=2, help="local worker processes")
    ap.add_argument("--scheduler", help="address of an existing Dask scheduler")
    ap.add_argument("--rows", type=int, default=100, help="recording rows per design")
    args = ap.parse_args(argv)
    base = cablesense.demo.scene("scenes/ftdcr_v4.toml")
    rows = recording_rows(base, "hardware/ftdcr_v4/val.csv", args.rows)
    points = designs([0.0, 0.002, 0.005], [0.9, 1.0, 1.1])
    t0 = time.perf_counter()
    ref = serial(base, rows, points)
    t_serial = time.perf_counter() - t0
    if args.scheduler:
        client = distributed.Client(args.scheduler)
        cluster = None
    else:
        cluster = distributed.LocalCluster(
            n_workers=args.workers, threads_per_worker=1, processes=True
        )
        client = distributed.Client(cluster)
    try:
        t0 = time.perf_counter()
        out = on_dask(client, base, rows, points)
        t_dask = time.perf_counter() - t0
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    nominal = next(r for r in out if r.payload_kg == 0.0 and r.modulus_scale == 1.0)
    for r in out:
        off = np.linalg.norm(r.tips - nominal.tips, axis=1).max() * 1e3
        print(
            f"payload {r.payload_kg * 1e3:4.1f} g  E x{r.modulus_scale:.1f}: "
            f"{int(r.converged.sum())}/{len(r.converged)} rows converged, "
            f"tip up to {off:.2f} mm from the nominal design (no payload, E x1.0)"
        )
    ok = same(ref, out)
    print(
        f"{len(points)} designs x {len(rows)} rows: serial {t_serial:.2f} s, "
        f"dask {t_dask:.2f} s; equal to the serial run: {ok}"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
