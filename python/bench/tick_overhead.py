"""What an estimator tick costs from Python over the same tick in Rust.

Issue 12: "a tick from Python costs at most 20 us more than from Rust (measure it)".
The tick of benches/estimate.rs (`estimate_tick_warm/lm`): the shipped track demo
(data/scenes/track_demo.toml, LM, unknown lateral tip force), 64 samples of cable
length changes along a tip force circling (-0.05 - 0.01 sin t, 0.01 cos t) N, cycled.
Both sides run in this process on the same estimator, in alternating blocks so that
they share the machine's load:

  rust   : Estimator.time_ticks(samples, n): n ticks timed one by one in Rust
           (`Instant` around `Estimator::tick`, no Python in the loop);
  rust+snapshot : the same, each tick followed by `Estimator::estimate()` (exact
           statistics, the shape recomputed for the tip: the work behind the dict);
  python : est.tick(row) timed one by one with time.perf_counter_ns(): argument
           conversion, the tick, the estimate snapshot and the result dict;
  python snapshot=False : est.tick(row, snapshot=False), the control-loop path
           (status, values, covariance, tip; no snapshot).

Prints medians and p90 of both and the difference of the medians; the log is in
benches/README.md. Run after `maturin develop --release` (see .ci/run):

  python python/bench/tick_overhead.py [--blocks 20] [--block 200]
"""

import argparse
import os
import pathlib
import platform
import statistics
import subprocess
import sys
import time

import numpy as np

import cablesense

ROOT = pathlib.Path(__file__).resolve().parents[2]
TRACK = ROOT / "data" / "scenes" / "track_demo.toml"


def samples(n):
    """The cable changes of benches/estimate.rs's `samples(&scene, n)`: the forward
    model under a point load at the tip of section 0, minus the unloaded lengths."""
    text = TRACK.read_text()
    ref = cablesense.solve(cablesense.Scene.from_toml(text))["cable_lengths"]
    out = []
    for i in range(n):
        t = i / n * 2.0 * np.pi
        fy, fz = float(-0.05 - 0.01 * np.sin(t)), float(0.01 * np.cos(t))
        loaded = text + (
            f"\n[[loads.point]]\nsection = 0\nforce_n = [0.0, {fy!r}, {fz!r}]\n"
        )
        sol = cablesense.solve(cablesense.Scene.from_toml(loaded))
        assert sol["report"]["converged"], sol["report"]
        out.append(sol["cable_lengths"] - ref)
    return np.array(out)


def machine():
    cpu = "?"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        commit = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True, text=True, check=True,
        ).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "diff", "--quiet", "HEAD"]).returncode
        commit += " (dirty tree)" if dirty else ""
    except (OSError, subprocess.CalledProcessError):
        commit = "?"
    load = " ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    return (
        f"{time.strftime('%Y-%m-%d %H:%M', time.gmtime())} UTC, {os.cpu_count()} cores, {cpu}, "
        f"Python {platform.python_version()}, numpy {np.__version__}, commit {commit}, load {load}"
    )


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=20, help="alternating block pairs")
    ap.add_argument("--block", type=int, default=200, help="ticks per block")
    a = ap.parse_args()
    print(machine())
    rows = samples(64)
    est = cablesense.Estimator(cablesense.Scene.from_file(TRACK))
    # warm-up as the criterion bench: one pass over the samples
    for r in rows:
        est.tick(r)
    py_us, rs_us, snap_us = [], [], []
    k = 0
    converged = 0
    for _ in range(a.blocks):
        rs_us.extend(1e6 * est.time_ticks(np.roll(rows, -k, axis=0), a.block))
        k = (k + a.block) % len(rows)
        snap_us.extend(1e6 * est.time_ticks(np.roll(rows, -k, axis=0), a.block, snapshot=True))
        k = (k + a.block) % len(rows)
        for _ in range(a.block):
            r = rows[k]
            t0 = time.perf_counter_ns()
            out = est.tick(r)
            py_us.append((time.perf_counter_ns() - t0) * 1e-3)
            converged += out["status"] == "converged"
            k = (k + 1) % len(rows)
    n = a.blocks * a.block
    print(f"{n} ticks per series ({len(rs_us)} rust), {converged} of the Python ticks converged")
    # the control-loop path: tick(row, snapshot=False), same blocks
    lean_us = []
    for _ in range(a.blocks):
        for _ in range(a.block):
            r = rows[k]
            t0 = time.perf_counter_ns()
            est.tick(r, snapshot=False)
            lean_us.append((time.perf_counter_ns() - t0) * 1e-3)
            k = (k + 1) % len(rows)
        rs_us.extend(1e6 * est.time_ticks(np.roll(rows, -k, axis=0), a.block))
        k = (k + a.block) % len(rows)
    for name, xs in [
        ("rust                   ", rs_us),
        ("rust+snapshot          ", snap_us),
        ("python tick            ", py_us),
        ("python snapshot=False  ", lean_us),
    ]:
        print(f"{name}: median {statistics.median(xs):7.1f} us  p90 {pct(xs, 0.9):7.1f} us")
    m = {k: statistics.median(v) for k, v in [("r", rs_us), ("s", snap_us), ("p", py_us)]}
    print(f"python - rust, medians: {m['p'] - m['r']:+.1f} us (target <= 20 us), of which "
          f"the snapshot {m['s'] - m['r']:+.1f} us and the binding {m['p'] - m['s']:+.1f} us")
    lean = statistics.median(lean_us) - m["r"]
    print(f"python tick(snapshot=False) - rust, medians: {lean:+.1f} us")
    return 0 if converged == n else 1


if __name__ == "__main__":
    sys.exit(main())
