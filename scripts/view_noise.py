"""The views' pixel noise, robustly: per view, the median over pixels of the squared difference
between a pixel's sRGB grey and the mean of its 8 neighbours, scaled to a variance (a Gaussian's
squared value has median 0.4549 of its variance; the difference's variance is 9/8 of the
pixel's). Texture and edges raise it a little; the median keeps them from deciding it.

Usage: python3 scripts/view_noise.py SCENE... (reads SCENE/train/Image/*.exr, every fifth of
the first 40 views; pip install numpy openexr)
"""
import sys, glob
import numpy as np
import OpenEXR, Imath

def read(path):
    f = OpenEXR.InputFile(path)
    dw = f.header()['dataWindow']
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    ch = [np.frombuffer(f.channel(c, Imath.PixelType(Imath.PixelType.FLOAT)), np.float32).reshape(h, w) for c in 'RGB']
    return np.stack(ch, -1)

def srgb(x):
    x = np.clip(x, 0, None)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)

if len(sys.argv) < 2:
    sys.exit(__doc__)
for scene in sys.argv[1:]:
    ests = []
    for p in sorted(glob.glob(f"{scene}/train/Image/*.exr"))[:40:5]:
        g = srgb(read(p)).mean(-1)
        ring = sum(np.roll(np.roll(g, dy, 0), dx, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dx or dy)
        r = (g - ring / 8)[2:-2, 2:-2]
        ests.append(np.median(r ** 2) / 0.4549 * 8 / 9)
    print(f"{scene}: noise variance (sRGB grey), median over views {np.median(ests):.3g}")
