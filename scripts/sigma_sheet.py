#!/usr/bin/env python3
"""σ maps of runs beside the truth, for comparing runs of one scene by eye
(docs/roughness-rooms.md).

    pip install OpenEXR pillow numpy
    python3 scripts/sigma_sheet.py SRC OUT.png RUN1 [RUN2 ...] [--views 0,3,6]

One row per val view of SRC (a scene with val/Roughness/): the true σ, each run's
views/val/NNN_roughness.exr, then each run's |error| × 5; σ clamped to [0.2, 1] as the
evaluation does, white = 1.
"""
import sys, OpenEXR, numpy as np
from PIL import Image
def read(p):
    with OpenEXR.File(p) as f:
        ch = f.channels()
        k = list(ch.keys())
        a = ch[k[0]].pixels if len(k) == 1 else ch[k[0]].pixels
        a = np.asarray(a, np.float32)
        return a if a.ndim == 2 else a[..., 0]
args = sys.argv[1:]
views = [0, 3, 6]
if '--views' in args:
    i = args.index('--views'); views = [int(v) for v in args[i+1].split(',')]; del args[i:i+2]
src, out, runs = args[0], args[1], args[2:]
rows = []
for v in views:
    t = np.clip(read(f"{src}/val/Roughness/{v:03d}_0001.exr"), 0.2, 1)
    row = [t]
    preds = [np.clip(read(f"{r}/views/val/{v:03d}_roughness.exr"), 0.2, 1) for r in runs]
    row += preds + [np.clip(np.abs(p - t) * 5, 0, 1) for p in preds]
    rows.append(np.concatenate([np.pad(x, 2, constant_values=1) for x in row], 1))
img = np.concatenate(rows, 0)
Image.fromarray((img * 255).astype(np.uint8)).resize((img.shape[1]*2, img.shape[0]*2), Image.NEAREST).save(out)
print(out, img.shape)
