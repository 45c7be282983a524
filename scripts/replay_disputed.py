#!/usr/bin/env python3
"""Replays the search's σ rule for dielectrics on stored cost curves, with and without
`[search] hedge_disputed` (docs/roughness-rooms.md, *Disputed minima*), and scores both
against the truth: per room, the pixel-weighted σ PSNR over the dielectric parts of one
material (σ clamped to [0.2, 1]); a region left without a target counts as the training's
drift, 0.99. Prints the regions where the replay differs from the run's choice (none when the
rule below is the search's) and those the hedge moves.

    fipt profile SRC RUN --shadings refine1 --drop-edges --edge-contrast 4 --json P.json
    python3 scripts/replay_disputed.py studio=SRC:P.json loft=SRC2:P2.json ...

The settings are the defaults of `SearchConfig` (dielectric_tolerance 0.25, interior_gain
0.001, interior_sigma 0.1, interior_tolerance 0.25, interior_cap 0.005, held_out_band 0.1,
rough_band 0.1).
"""
import math
import sys

from replay_sigma_rules import argmin, load

DRIFT = 0.99


def roughest_within(c, b, tol):
    limit = c[b] * (1 + tol)
    return max(i for i in range(b, len(c)) if c[i] <= limit)


def holds_out(halves, band=0.1, gain_min=0.001):
    def beats(fit, test):
        b, other = argmin(fit["cost"][0]), test["cost"][0]
        return b is not None and b > 0 and other[b] == other[b] and other[b] > 0 \
            and other[-1] / other[b] - 1 >= gain_min

    if beats(halves[0], halves[1]) and beats(halves[1], halves[0]):
        return True

    def interior(h):
        b, s = argmin(h["cost"][0]), h["sigma"]
        return s[b] if b is not None and b > 0 and s[b] < s[-1] - band else None

    a, b = interior(halves[0]), interior(halves[1])
    return a is not None and b is not None and abs(a - b) <= band + 1e-6


def choose(r, hedge):
    f = r["fitted"]
    c, s = f["cost"][0], f["sigma"]
    n, b = len(s), argmin(f["cost"][0])
    gain = c[-1] / c[b] - 1
    si = roughest_within(c, b, 0.25)
    interior = s[b] >= 0.1 and gain >= 0.001
    lifted = roughest_within(c, b, min(gain * 0.25, 0.005))
    if interior and holds_out(r["halves"]):
        si = lifted
    near_roughest = s[b] >= s[-1] - 0.1 - 1e-6
    if si + 1 < n or near_roughest:
        return s[si]
    if hedge and interior:
        return (s[lifted] + s[-1]) / 2
    return None


def score(items, rule):
    per = {}
    for x in items:
        p, v = x["row"]["fitted"]["pixels"], rule(x)
        e = (min(max(DRIFT if v is None else v, 0.2), 1) - min(max(x["truth"], 0.2), 1)) ** 2
        a = per.setdefault(x["room"], [0.0, 0])
        a[0] += p * e
        a[1] += p
    return {k: round(-10 * math.log10(max(v[0] / v[1], 1e-10)), 2) for k, v in per.items()}


if __name__ == "__main__":
    items = []
    for arg in sys.argv[1:]:
        name, _, rest = arg.partition("=")
        src, _, prof = rest.rpartition(":")
        items += load(name, src, prof)
    for x in items:
        run, plain, hedged = x["row"]["choice"]["roughness"], choose(x["row"], False), choose(x["row"], True)
        if (run is None) != (plain is None) or (run is not None and abs(run - plain) > 0.011):
            print(f"replay differs: {x['room']} {x['name']}: run {run}, replay {plain}")
        if hedged != plain:
            print(f"hedged: {x['room']} {x['name']} (true {x['truth']}): {plain} -> {hedged:.2f}")
    print("as run ", score(items, lambda x: x["row"]["choice"]["roughness"]))
    print("replay ", score(items, lambda x: choose(x["row"], False)))
    print("hedged ", score(items, lambda x: choose(x["row"], True)))
