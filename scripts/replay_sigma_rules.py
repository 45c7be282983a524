#!/usr/bin/env python3
"""Replays the search's σ rule for dielectrics on stored cost curves and scores it against the
truth (docs/roughness-rooms.md): per room, the pixel-weighted σ PSNR over the dielectric parts
of one material (σ clamped to [0.2, 1]), for the rule as the run chose and for the interior cap
at several values.

    fipt profile SRC RUN --shadings refine1 --drop-edges --edge-contrast 4 --json P.json
    python3 scripts/replay_sigma_rules.py studio=SRC:P.json bedroom=SRC2:P2.json ...
"""
import json
import math
import sys


def load(name, src, prof):
    parts = json.load(open(f"{src}/scene_parts.json"))["objects"]
    out = []
    for r in json.load(open(prof)):
        o = parts[r["label"]]
        if o.get("type") == "emitter" or r["side"] is not None:
            continue
        if isinstance(o["roughness"], dict) or isinstance(o["metallic"], dict) or o["metallic"] > 0.5:
            continue
        if (r["choice"]["metallic"] or 0) > 0.5:
            continue
        out.append(dict(room=name, name=o["name"], truth=o["roughness"], row=r))
    return out


def argmin(c):
    f = [(x, i) for i, x in enumerate(c) if x == x]
    return min(f)[1] if f else None


def as_run(x):
    s = x["row"]["choice"]["roughness"]
    return 1.0 if s is None else s


def capped(cap, q=0.25):
    """The interior rule with `interior_cap` = cap (other cases as the run chose)."""
    def rule(x):
        f = x["row"]["fitted"]
        c, s = f["cost"][0], f["sigma"]
        b = argmin(c)
        gain = c[-1] / c[b] - 1
        if b in (0, len(c) - 1) or gain < 0.001:
            return as_run(x)
        limit = c[b] * (1 + min(gain * q, cap))
        return s[max(i for i in range(b, len(c)) if c[i] <= limit)]
    return rule


def score(parts, rule):
    per = {}
    for x in parts:
        p = x["row"]["fitted"]["pixels"]
        e = (min(max(rule(x), 0.2), 1) - min(max(x["truth"], 0.2), 1)) ** 2
        a = per.setdefault(x["room"], [0.0, 0])
        a[0] += p * e
        a[1] += p
    total = sum(a for a, _ in per.values()) / sum(n for _, n in per.values())
    db = lambda m: -10 * math.log10(max(m, 1e-12))
    return db(total), {k: round(db(a / n), 1) for k, (a, n) in per.items()}


def main():
    parts = []
    for arg in sys.argv[1:]:
        name, rest = arg.split("=", 1)
        src, prof = rest.split(":", 1)
        parts += load(name, src, prof)
    print("as the run chose:", score(parts, as_run))
    minimum = lambda x: x["row"]["fitted"]["sigma"][argmin(x["row"]["fitted"]["cost"][0])]
    print("the minimum alone:", score(parts, minimum))
    for cap in (0.02, 0.01, 0.005, 0.003):
        print(f"interior_cap {cap}:", score(parts, capped(cap)))


if __name__ == "__main__":
    main()
