#!/usr/bin/env python3
"""Write the committed seeds of the `estimator_tick` target into fuzz/seeds/estimator_tick/.

The byte layout mirrors `EstimatorInput::from_bytes` in fuzz_targets/shared_estimate.rs:
bytes 0..104 a `ForwardInput` (built with make_forward_seeds.py's helpers), 32
little-endian u16 spec fractions (bytes 104..168), 40 u8 spec choices (168..208), then
ticks of 109 bytes (a flags byte, 6 x (kind, 8 value bytes) changes, 6 x the same noise).
Keep the ranges below in sync with that function.
Run from the repository root: `python3 fuzz/make_estimator_seeds.py`.
"""
import math
import random
import struct
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
import make_forward_seeds as fw  # noqa: E402

OUT = Path(__file__).parent / "seeds" / "estimator_tick"
lin, log = fw.lin, fw.log
CABLES = 6

# kinds of a tick value (byte % 16): 0-9 plausible, then these
NAN, INF, NEG_INF, RAW, HUGE, TINY = 10, 11, 12, 13, 14, 15
FORCE, TORQUE, MASS, TENSION = 0, 1, 2, 3
LM, GN, CONSTRAINED, ARGMIN = 0, 1, 2, 3
NO_POISON = 0
POISON_NOISE_NAN = 17  # 17 + index into POISONS of shared_estimate.rs


def unknown(kind, section=0, axis=0, cable=7, bounds=None, prior=None, reference=0.0,
            initial=0.0):
    """(fractions, choices) of one unknown. section: 0 = last, 4 = first, 6 = past the
    end, 7 = none; axis 0 x, 2 y, 4 z, 6 none; cable 0..5, 7 none; bounds (min, max)
    with None = absent; prior (mean, sigma) or None."""
    lo, hi = bounds or (None, None)
    mean, sigma = prior or (0.0, 1.0)
    fr = [lin(lo if lo is not None else 0.0, -1.0, 0.5), lin(hi if hi is not None else 0.0, -0.5, 1.0),
          lin(mean, -0.5, 0.5), log(sigma, 1e-3, 10.0), lin(reference, -0.05, 0.05),
          lin(initial, -0.5, 0.5)]
    flags = (1 if lo is not None else 0) | (2 if hi is not None else 0)
    ch = [kind, section, axis, cable, flags, 1 if prior else 0]
    return fr, ch


def spec(unknowns, method=LM, iterations=4, budget=None, reuse=True, reference=None,
         poison=NO_POISON, noise=1e-5, tol=1e-10, rank_tol=1e-8):
    fr, ch = [], [len(unknowns) - 1]
    for u in (unknowns + [unknown(FORCE)] * 3)[:3]:
        fr += u[0]
        ch += u[1]
    fr += [log(noise, 1e-7, 1e-3), log(tol, 1e-12, 1e-4), log(rank_tol, 1e-12, 1e-4),
           log(budget or 1e-3, 1e-4, 2e-2)]
    fr += [lin(r, 0.05, 1.0) for r in (reference or [])]
    ch += [method, iterations - 1, 1 if budget else 0, 1 if reuse else 0,
           0 if reference else 1, poison]
    b = b"".join(fw.frac(x) for x in fr)
    assert len(b) <= 64 and len(ch) <= 40
    return b.ljust(64, b"\0") + bytes(ch).ljust(40, b"\1")


def val(x=None, kind=0, raw=None):
    """(kind, 8 bytes): a plausible change x (m, |x| <= 5 mm), or a special kind."""
    if raw is not None:
        return bytes([RAW]) + struct.pack("<d", raw)
    if kind == HUGE:
        return bytes([HUGE, 255] + [0] * 6 + [0x80 if x and x < 0 else 0])
    if x is None:
        return bytes([kind]) + bytes(8)
    return bytes([kind]) + struct.pack("<h", round(x / 5e-3 * 32767)) + bytes(6)


def sig(s):
    """A plausible noise s in [1e-7, 1e-3) m."""
    u = (math.log10(s) + 5.0) / 2.0
    return bytes([0]) + struct.pack("<h", round(u * 32768)) + bytes(6)


def tick(changes, sigma=None, n_changes=0, n_sigma=0):
    """n_changes / n_sigma: 0 all cables, 1 one fewer, 2 two more, 3 none."""
    flags = n_changes | (4 if sigma is not None else 0) | (n_sigma << 3)
    ch = (changes + [val(0.0)] * CABLES)[:CABLES]
    sg = ((sigma or []) + [sig(1e-5)] * CABLES)[:CABLES]
    b = bytes([flags]) + b"".join(ch) + b"".join(sg)
    assert len(b) == 109
    return b


def seed(forward, spec_bytes, ticks):
    assert len(forward) == 104
    return forward + spec_bytes + b"".join(ticks)


FW = fw.SEEDS
SMOOTH = [tick([val(1e-4), val(-6e-5), val(-4e-5)]),
          tick([val(1.2e-4), val(-7e-5), val(-5e-5)]),
          tick([val(1.3e-4), val(-7e-5), val(-6e-5)])]

SEEDS = {
    # one section, passive cables; lateral tip force x, y; LM
    "single_lm_force_xy": seed(FW["single_section_passive"],
                               spec([unknown(FORCE, axis=0), unknown(FORCE, axis=2)]), SMOOTH),
    # same, Gauss-Newton without Jacobian reuse, bounds and a prior
    "single_gn_bounds_prior": seed(
        FW["single_section_passive"],
        spec([unknown(FORCE, axis=0, bounds=(-0.2, 0.2)),
              unknown(FORCE, axis=2, prior=(0.0, 0.05))], method=GN, reuse=False), SMOOTH),
    # two sections, tensions of cables 0 and 4 (bounded below by 0) and a tip force
    "two_constrained_tensions": seed(
        FW["two_section_tensioned"],
        spec([unknown(TENSION, cable=0), unknown(TENSION, cable=4),
              unknown(FORCE, axis=2, section=0)], method=CONSTRAINED),
        [tick([val(1e-4), val(-5e-5), val(-5e-5), val(2e-4), val(-1e-4), val(-1e-4)])] * 2),
    # argmin's Gauss-Newton, torque and mass unknowns, measured reference lengths
    "two_argmin_torque_mass": seed(
        FW["two_section_adaptive_body"],
        spec([unknown(TORQUE, axis=4), unknown(MASS, bounds=(0.0, 0.5))], method=ARGMIN,
             iterations=3, reference=[0.3, 0.31, 0.32, 0.6, 0.61, 0.62]),
        [tick([val(1e-4)] * 6)]),
    # NaN, infinities, huge and raw values, missing cables, bad noise, time budget
    "single_lm_pathological_ticks": seed(
        FW["single_section_passive"],
        spec([unknown(FORCE, axis=0), unknown(FORCE, axis=2)], budget=2e-3),
        [tick([val(kind=NAN), val(kind=INF), val(kind=NEG_INF)]),
         tick([val(1e-4, kind=HUGE), val(-1e-4), val(raw=-1e300)]),
         tick([val(1e-4), val(-6e-5)], sigma=[val(kind=NAN), val(raw=0.0), val(raw=-1.0)], n_changes=1),
         tick([val(1e-4, kind=TINY), val(raw=5e-324), val(raw=-0.0)], n_changes=2, n_sigma=3)]),
    # an unknown past the last section: construction must be Err
    "single_bad_section": seed(FW["single_section_passive"],
                               spec([unknown(FORCE, axis=0, section=6)]), SMOOTH[:1]),
    # a poisoned spec (noise NaN): construction must be Err
    "single_poison_noise_nan": seed(FW["single_section_passive"],
                                    spec([unknown(FORCE, axis=0)], poison=POISON_NOISE_NAN), SMOOTH[:1]),
    "zeros": bytes(208 + 109),
    "ones": bytes([255] * (208 + 4 * 109)),
}

if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    rng = random.Random(20261122)
    for i in range(3):
        SEEDS[f"random_{i}"] = bytes(rng.randrange(256) for _ in range(208 + 2 * 109))
    for name, data in SEEDS.items():
        (OUT / f"{name}.bin").write_bytes(data)
        print(OUT / f"{name}.bin", len(data))
