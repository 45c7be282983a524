"""kd PSNR against the truth, as run and at the ends of each unpinned light's range.

usage: python3 scripts/kd_at_light_ends.py RUN SCENE [--split val]

RUN is a `fipt run` folder of an LDR copy (its views/<split>/NNN_kd_light<e>_<end>.exr),
SCENE a folder with <split>/DiffCol/NNN_*.exr ground truth (the source or a `--layout same`
copy). Per map: PSNR of linear kd clamped to [0, 1] on pixels where both are non-zero, raw and
after one least-squares scale (LDR copies fix kd only up to a scale). Reads EXR through
Mitsuba 3 (`pip install mitsuba numpy`; DRJIT_LIBLLVM_PATH as for scripts/mitsuba_loft.py).
"""
import argparse, glob, os, re
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")


def read(p):
    return np.array(mi.Bitmap(p)).astype(np.float64)[..., :3]


def psnr(a, b, fit):
    s = (a * b).sum() / max((a * a).sum(), 1e-30) if fit else 1.0
    return 10 * np.log10(1.0 / max(((np.clip(s * a, 0, 1) - b) ** 2).mean(), 1e-30))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run")
    ap.add_argument("scene")
    ap.add_argument("--split", default="val")
    a = ap.parse_args()
    d = os.path.join(a.run, "views", a.split)
    ends = sorted(glob.glob(os.path.join(d, "*_kd_light*_*.exr")))
    views = sorted({int(os.path.basename(p)[:3]) for p in ends})
    names = sorted({re.sub(r"^\d{3}_", "", os.path.basename(p))[:-4] for p in ends})
    rows = {}
    for k in views:
        gt = glob.glob(os.path.join(a.scene, a.split, "DiffCol", f"{k:03}_*.exr"))
        if not gt:
            continue
        gt = read(gt[0])
        kd = read(os.path.join(d, f"{k:03}_kd.exr"))
        m = (gt.sum(-1) > 0) & (kd.sum(-1) > 0)
        for n in ["kd"] + names:
            x = read(os.path.join(d, f"{k:03}_{n}.exr"))
            for fit in (False, True):
                rows.setdefault((n, fit), []).append(psnr(x[m], gt[m], fit))
    print(f"views {views}")
    for (n, fit), v in rows.items():
        per = " ".join(f"{x:.1f}" for x in v)
        print(f"{n:22s} {'scaled' if fit else 'raw':6s} mean {np.mean(v):5.2f}  ({per})")


if __name__ == "__main__":
    main()
