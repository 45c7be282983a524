#!/usr/bin/env python3
"""How each stage of `fipt run` grows with the work: views, resolution and triangles at x1,
x2, x4 (triangles x1, x4, x16: `fipt synth --subdivide`), one axis at a time from a base
`room` scene. Writes DIR/scaling.csv (wall seconds and peak RSS per stage and run) and
DIR/scaling.md (the table and the fitted growth: the exponent b of seconds ~ work^b per stage
and axis, least squares on the logs). Python 3 standard library only.

usage: scripts/scaling.py DIR [--fipt target/release/fipt] [--preset fast] [--quick]
                          [--axes views,pixels,triangles]
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

BASE = {"views": 16, "width": 128, "height": 96, "subdivide": 0}
# axis -> [(factor of the work, overrides)]
AXES = {
    "views": [(1, {}), (2, {"views": 32}), (4, {"views": 64})],
    "pixels": [(1, {}), (2, {"width": 181, "height": 136}), (4, {"width": 256, "height": 192})],
    "triangles": [(1, {}), (4, {"subdivide": 1}), (16, {"subdivide": 2})],
}


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr[-3000:]}")
    return r


def point(args, name, s):
    scene = os.path.join(args.dir, "scenes", name)
    if not os.path.isfile(os.path.join(scene, "val", "transforms.json")):
        run([args.fipt, "synth", "room", "--out", scene, "--force",
             "--views", str(s["views"]), "--val-views", "2",
             "--width", str(s["width"]), "--height", str(s["height"]),
             "--spp", "16", "--subdivide", str(s["subdivide"])])
    out = os.path.join(args.dir, "runs", name)
    report = os.path.join(out, "report.json")
    done = os.path.isfile(report) and json.load(open(report)).get("status") == "complete"
    if not done:
        run([args.fipt, "run", scene, "--out", out, "--preset", args.preset, "--force"])
    r = json.load(open(report))
    stages = {}
    for st in r["stages"]:
        e = stages.setdefault(st["stage"], [0.0, 0.0])
        e[0] += st["seconds"]
        e[1] = max(e[1], st["peak_rss_mib"])
    tris = sum(1 for line in open(os.path.join(scene, "scene.obj")) if line.startswith("f "))
    return {"point": name, "views": s["views"], "pixels": s["width"] * s["height"],
            "triangles": tris, "total_s": r["seconds_total"], "stages": stages}


def slope(xs, ys):
    lx = [math.log(x) for x in xs]
    ly = [math.log(max(y, 1e-3)) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    den = sum((a - mx) ** 2 for a in lx)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / den if den else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--fipt", default="target/release/fipt")
    ap.add_argument("--preset", default="fast")
    ap.add_argument("--quick", action="store_true", help="x1 and x2 only")
    ap.add_argument("--axes", default=",".join(AXES), help="comma-separated: views,pixels,triangles")
    args = ap.parse_args()
    rows, fits, mem_fits = [], {}, {}
    for axis in args.axes.split(","):
        steps = AXES[axis]
        steps = steps[:2] if args.quick else steps
        pts = []
        for factor, over in steps:
            s = dict(BASE, **over)
            name = "base" if not over else f"{axis}-x{factor}"
            p = point(args, name, s)
            p["axis"], p["factor"] = axis, factor
            rows.append(p)
            pts.append(p)
            print(f"{name}: {p['total_s']:.1f} s", file=sys.stderr)
        names = []
        for p in pts:
            names += [k for k in p["stages"] if k not in names]
        xs = [p["factor"] for p in pts]
        fits[axis] = {k: slope(xs, [p["stages"].get(k, [0, 0])[0] for p in pts]) for k in names}
        fits[axis]["total"] = slope([p["factor"] for p in pts], [p["total_s"] for p in pts])
        mem_fits[axis] = {k: slope(xs, [p["stages"].get(k, [0, 0])[1] for p in pts]) for k in names}
    stages = []
    for p in rows:
        stages += [k for k in p["stages"] if k not in stages]
    with open(os.path.join(args.dir, "scaling.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["axis", "factor", "views", "pixels_per_view", "triangles", "total_s"]
                   + [f"{k}_s" for k in stages] + [f"{k}_peak_mib" for k in stages])
        for p in rows:
            w.writerow([p["axis"], p["factor"], p["views"], p["pixels"], p["triangles"],
                        f"{p['total_s']:.2f}"]
                       + [f"{p['stages'].get(k, [0, 0])[0]:.2f}" for k in stages]
                       + [f"{p['stages'].get(k, [0, 0])[1]:.0f}" for k in stages])
    with open(os.path.join(args.dir, "scaling.md"), "w") as f:
        f.write("| axis | ×work | views | pixels/view | triangles | total s | "
                + " | ".join(f"{k} s" for k in stages) + " | peak MiB |\n")
        f.write("|" + "---|" * (7 + len(stages)) + "\n")
        for p in rows:
            peak = max(v[1] for v in p["stages"].values())
            f.write(f"| {p['axis']} | {p['factor']} | {p['views']} | {p['pixels']} | {p['triangles']} | "
                    f"{p['total_s']:.1f} | "
                    + " | ".join(f"{p['stages'].get(k, [0, 0])[0]:.1f}" for k in stages)
                    + f" | {peak:.0f} |\n")
        f.write("\nFitted growth b (seconds ∝ work^b, least squares on the logs):\n\n")
        f.write("| axis | total | " + " | ".join(stages) + " |\n")
        f.write("|" + "---|" * (2 + len(stages)) + "\n")
        for axis, fit in fits.items():
            f.write(f"| {axis} | {fit['total']:.2f} | "
                    + " | ".join(f"{fit.get(k, float('nan')):.2f}" for k in stages) + " |\n")
        f.write("\nPeak RSS MiB while each stage ran (the largest over a stage's rounds):\n\n")
        f.write("| axis | ×work | " + " | ".join(stages) + " |\n")
        f.write("|" + "---|" * (2 + len(stages)) + "\n")
        for p in rows:
            f.write(f"| {p['axis']} | {p['factor']} | "
                    + " | ".join(f"{p['stages'].get(k, [0, 0])[1]:.0f}" for k in stages) + " |\n")
        f.write("\nFitted growth b of each stage's peak memory (MiB ∝ work^b):\n\n")
        f.write("| axis | " + " | ".join(stages) + " |\n")
        f.write("|" + "---|" * (1 + len(stages)) + "\n")
        for axis, fit in mem_fits.items():
            f.write(f"| {axis} | " + " | ".join(f"{fit.get(k, float('nan')):.2f}" for k in stages) + " |\n")
    print(open(os.path.join(args.dir, "scaling.md")).read())


if __name__ == "__main__":
    main()
