"""Share of one part's val pixels whose recovered σ lies within 0.1 of the truth, per finish.

Usage: python3 scripts/sigma_finishes.py SRC RUN PART

SRC: a scene folder with val/Roughness and val/IndexMA (the Mitsuba rooms of
scripts/mitsuba_loft.py); RUN: a `fipt run` folder (its views/val/NNN_roughness.exr), or a
copy's `RUN/eval/cameras-from`; PART: the part index (0: the floor). Reads EXR through
mitsuba (pip install mitsuba numpy). Issue 55's two-finish target: 80 % of each finish.
"""
import sys, numpy as np, mitsuba as mi, glob, os
mi.set_variant('scalar_rgb')
if len(sys.argv) != 4:
    sys.exit(__doc__)
src, run, part = sys.argv[1], sys.argv[2], int(sys.argv[3])
def rd(p):
    return np.array(mi.Bitmap(p))
tot = ok = 0
per = {}
for f in sorted(glob.glob(f'{src}/val/Roughness/*.exr')):
    i = os.path.basename(f).split('_')[0]
    gt = rd(f); gt = gt[..., 0] if gt.ndim == 3 else gt
    idx = rd(f'{src}/val/IndexMA/{i}_0001.exr'); idx = idx[..., 0] if idx.ndim == 3 else idx
    pr = rd(f'{run}/views/val/{i}_roughness.exr'); pr = pr[..., 0] if pr.ndim == 3 else pr
    m = np.round(idx).astype(int) == part
    for fin in np.unique(np.round(gt[m], 2)):
        s = m & (np.abs(gt - fin) < 0.01)
        a = per.setdefault(fin, [0, 0]); a[0] += s.sum(); a[1] += (np.abs(pr[s] - gt[s]) <= 0.1).sum()
    tot += m.sum(); ok += (np.abs(pr[m] - gt[m]) <= 0.1).sum()
print(f'part {part}: {tot} px, within 0.1: {ok/max(tot,1):.3f}')
for k, (n, g) in sorted(per.items()):
    print(f'  finish {k}: {n} px, within 0.1: {g/max(n,1):.3f}')
