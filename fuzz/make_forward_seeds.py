#!/usr/bin/env python3
"""Write the committed seeds of the `forward_solve` target into fuzz/seeds/forward_solve/.

The byte layout mirrors `ForwardInput::from_bytes` in fuzz_targets/shared.rs: 48
little-endian u16 fractions (bytes 0..96) read in field order, then 8 u8 choices
(bytes 96..104). Keep the ranges below in sync with that function.
Run from the repository root: `python3 fuzz/make_forward_seeds.py`.
"""
import math
import random
import struct
from pathlib import Path

N = 104
OUT = Path(__file__).parent / "seeds" / "forward_solve"


def frac(x):
    assert 0.0 <= x <= 1.0, x
    return struct.pack("<H", round(x * 65535))


def build(fractions, choices):
    b = b"".join(frac(x) for x in fractions)
    assert len(b) <= 96 and len(choices) == 8
    return b.ljust(96, b"\0") + bytes(choices)


def lin(v, lo, hi):
    return (v - lo) / (hi - lo)


def log(v, lo, hi):
    return (math.log(v) - math.log(lo)) / (math.log(hi) - math.log(lo))


def sec(length, d, guides):
    return [lin(length, 0.05, 0.5), lin(d, 0.5e-3, 3e-3), (guides + 0.5) / 5.999]


MAT = [log(62.7e9, 20e9, 200e9), lin(0.3, 0, 0.49), lin(6800, 1000, 9000)]
GUIDE = [lin(2.2e-3, 0, 5e-3), lin(0.01, 0, 0.014)]
ZERO3 = [0.5] * 3  # the middle of a symmetric range is 0
BASE = [0.5, 0.5, 1.0, 0.5]  # axis +z, angle 0
GRAVITY_ACROSS = [0.5, lin(-9.81, -10, 10), 0.5]
TOL = [log(1e-10, 1e-12, 1e-6)]
RK4_24 = [lin(23, 0, 31)]
PERTURB = [lin(5e-4, -0.02, 0.02), lin(5e-4, -0.02, 0.02), 0.5]


def tensions(ts):
    return [lin(t, -2, 4) for t in ts]


# choices: two sections, frame (1 = body), integrator (0 = adaptive), rod (1 = kirchhoff),
# guide mass (0 none, 1 average, 2 accurate, 3 point), max_iterations - 1,
# continuation, max_continuation_steps
SEEDS = {
    # the benchmark's single section: five guides, passive cables, tip force
    "single_section_passive": build(
        sec(0.39, 1.56e-3, 5) * 2 + MAT + GUIDE + ZERO3 + BASE + GRAVITY_ACROSS
        + [lin(0.02, -0.3, 0.3), 0.5, 0.5] + ZERO3 + [0.0] + tensions([0] * 6)
        + RK4_24 + TOL + PERTURB,
        [0, 0, 1, 0, 1, 4, 1, 3],
    ),
    # the benchmark's two sections, one tensioned cable per section
    "two_section_tensioned": build(
        sec(0.195, 1.56e-3, 4) * 2 + MAT + GUIDE + ZERO3 + BASE + GRAVITY_ACROSS
        + ZERO3 + ZERO3 + [0.0] + tensions([1.5, 0, 0, 0, 0.8, 0])
        + RK4_24 + TOL + PERTURB,
        [1, 0, 1, 0, 2, 4, 1, 3],
    ),
    # adaptive integrator, Kirchhoff rod, body-frame tip torque, payload, point masses
    "two_section_adaptive_body": build(
        sec(0.3, 1.2e-3, 3) * 2 + MAT + GUIDE + [0.6, 0.5, 0.5] + BASE + GRAVITY_ACROSS
        + ZERO3 + [0.5, 0.5, lin(0.005, -0.03, 0.03)] + [lin(0.02, 0, 0.05)]
        + tensions([0.5] * 6) + [log(1e-7, 1e-8, 1e-4), 0.5] + TOL + PERTURB,
        [1, 1, 0, 1, 3, 4, 1, 3],
    ),
    "zeros": bytes(N),
    "ones": bytes([255] * N),
}

if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    rng = random.Random(20261122)
    for i in range(3):
        SEEDS[f"random_{i}"] = bytes(rng.randrange(256) for _ in range(N))
    for name, data in SEEDS.items():
        (OUT / f"{name}.bin").write_bytes(data)
        print(OUT / f"{name}.bin")
