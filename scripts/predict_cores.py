#!/usr/bin/env python3
"""A run's time on 16 and 64 cores, predicted per stage from its report.json.

Each stage's serial share s comes from Amdahl's law relative to 2 threads,
t(T) = t2 * (s + (1 - s) * 2 / T), with the speed-ups from 2 to 16 threads measured on a
16-core Xeon (issue 42, `studio-mitsuba` `fast`). Stages not measured there (load, emitters,
maps, eval) are taken as serial. Prints a Markdown table.

    python3 scripts/predict_cores.py OUT/report.json
"""
import json
import sys

SPEEDUP_2_TO_16 = {
    "bake": 5.3,
    "refine": 6.6,
    "train": 2.1,
    "re-render": 6.2,
    # the first (14.9 s at 2 threads, 4.6x) and the second search (33.8 s, 7.2x), time-weighted
    "search": (14.9 + 33.8) / (14.9 / 4.6 + 33.8 / 7.2),
}


def serial_share(speedup):
    return (1 / speedup - 2 / 16) / (1 - 2 / 16)


report = json.load(open(sys.argv[1]))
total = {2: 0.0, 16: 0.0, 64: 0.0}
print("| stage | 2 cores, s | peak MiB | serial share | 16 cores, s | 64 cores, s |")
print("|---|---|---|---|---|---|")
for st in report["stages"]:
    name, t = st["stage"], st["seconds"]
    s = serial_share(SPEEDUP_2_TO_16[name]) if name in SPEEDUP_2_TO_16 else 1.0
    t16, t64 = t * (s + (1 - s) * 2 / 16), t * (s + (1 - s) * 2 / 64)
    total[2] += t
    total[16] += t16
    total[64] += t64
    print(f"| {name} | {t:.1f} | {st.get('peak_rss_mib', 0):.0f} | {s:.3f} | {t16:.1f} | {t64:.1f} |")
print(f"| total | {total[2]:.1f} | | | {total[16]:.1f} | {total[64]:.1f} |")
