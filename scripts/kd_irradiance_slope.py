"""Does a run's kd error follow the light? Per part, the slope of log(kd_pred / kd_true) against
log E, E = the val image's radiance / kd_true (the irradiance the truth implies), over the
dielectric, non-emitting pixels of the source's val views.

A camera response decoded with the wrong contrast (a power of the true one) makes kd follow
E to that power: a slope near 0 means the decoding's contrast is right.

usage: python3 scripts/kd_irradiance_slope.py SOURCE RUN_MAPS
  SOURCE    a scene with ground truth (val/Image, DiffCol, IndexMA, Emit, Metallic)
  RUN_MAPS  a folder with views/val/NNN_kd.exr at the source's val cameras: a run of the
            scene itself, or RUN/eval/cameras-from of a copy's run (fipt eval --cameras-from)
needs: pip install OpenEXR numpy
"""
import glob
import os
import sys

import numpy as np
import OpenEXR


def read(path):
    ch = OpenEXR.File(path).channels()
    if "RGB" in ch:
        a = ch["RGB"].pixels
    elif "R" in ch:
        a = np.stack([ch[c].pixels for c in "RGB"], -1)
    else:
        a = list(ch.values())[0].pixels
    a = np.asarray(a, dtype=np.float64)
    return a.mean(-1) if a.ndim == 3 else a


def main(src, run):
    xs, ys, ids = [], [], []
    for p in sorted(glob.glob(f"{src}/val/Image/*.exr")):
        b = os.path.basename(p)
        k = int(b[:3])
        img, kt = read(p), read(f"{src}/val/DiffCol/{b}")
        idx, em = read(f"{src}/val/IndexMA/{b}"), read(f"{src}/val/Emit/{b}")
        met = read(f"{src}/val/Metallic/{b}")
        kp = read(f"{run}/views/val/{k:03d}_kd.exr")
        ok = (kt > 0.05) & (kp > 0.01) & (em <= 0) & (met < 0.5) & (img > 0)
        xs.append(np.log(img[ok] / kt[ok]))
        ys.append(np.log(kp[ok] / kt[ok]))
        ids.append(idx[ok])
    x, y, ids = np.concatenate(xs), np.concatenate(ys), np.concatenate(ids)
    rows = []
    for i in np.unique(ids):
        s = ids == i
        if s.sum() < 2000 or x[s].std() < 0.1:
            continue  # too few pixels, or too little spread of light to fit a slope
        slope = np.polyfit(x[s], y[s], 1)[0]
        rows.append((int(s.sum()), slope))
        print(f"part {int(i):3d}  pixels {int(s.sum()):7d}  log E spread {x[s].std():.2f}  slope {slope:+.3f}")
    if not rows:
        sys.exit(f"{run}: no part of 2,000 pixels or more with light varying across it")
    w = np.array([r[0] for r in rows], dtype=float)
    sl = np.array([r[1] for r in rows])
    order = np.argsort(sl)
    cum = np.cumsum(w[order]) / w.sum()
    print(f"{run}: pixel-weighted median slope {sl[order][np.searchsorted(cum, 0.5)]:+.3f} over {len(rows)} parts")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
