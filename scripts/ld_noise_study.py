#!/usr/bin/env python3
"""Where the per-cell base-colour fit puts σ's minimum on a dump of shadings made with the
ground truth's materials and lights (docs/roughness-rooms.md, *Where rough walls' glossy
minima come from*).

    cargo run --release -p fipt-method --example refine_gt -- SCENE RUN NAME fipt
    cargo run --release -p fipt-method --example refine_gt -- dump SCENE RUN NAME DUMP.bin
    python3 scripts/ld_noise_study.py DUMP.bin WIDTH HEIGHT [PART ...]

For each part (IndexMA), the σ minimising the search's cost (squared sRGB error, the base
colour fitted per 5 cm voxel in closed form, FIPT's model, m = 0) with
  raw:       the data and Ld as dumped;
  Ld 3x3:    Ld averaged over the 3 x 3 pixels of the same view and part;
  res/view:  the data replaced by the model at the true σ plus the true-σ residuals permuted
             within each view (same noise, no spatial structure);
  no flies:  raw, without the pixels brighter than 4x their voxel's median;
  linear:    raw, the squared error of linear values;
  Ld ±20 %:  Ld averaged over those of the 3 x 3 pixels whose Ld lies within 20 % of its own.
Needs numpy.
"""
import sys
import numpy as np

LEVELS = np.array([0.02, 0.216, 0.412, 0.608, 0.804, 1.0])
SIGMAS = np.arange(0.4, 1.001, 0.02)
COLS = 57


def lerp(v, s):
    k = int(np.clip(np.searchsorted(LEVELS, s) - 1, 0, len(LEVELS) - 2))
    t = (s - LEVELS[k]) / (LEVELS[k + 1] - LEVELS[k])
    return v[:, k] * (1 - t) + v[:, k + 1] * t


def srgb(x):
    x = np.maximum(x, 0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def cells(p, edge=0.05):
    _, cid = np.unique(np.floor(p / edge).astype(np.int64), axis=0, return_inverse=True)
    return cid.ravel()


def argmin(image, ld, ls0, ls1, cid, linear=False):
    nc = cid.max() + 1
    x = np.maximum(image, 1e-3)
    g = np.where(x <= 0.0031308, 12.92, 1.055 / 2.4 * np.power(x, 1 / 2.4 - 1))
    w = np.ones_like(image) if linear else g * g
    enc = (lambda x: x) if linear else srgb
    cost = []
    for s in SIGMAS:
        c = 0.04 * lerp(ls0, s) + lerp(ls1, s)
        sbb = np.zeros((nc, 3))
        sbr = np.zeros((nc, 3))
        np.add.at(sbb, cid, w * ld * ld)
        np.add.at(sbr, cid, w * ld * (image - c))
        a = sbr / np.maximum(sbb, 1e-30)
        cost.append(np.mean((enc(a[cid] * ld + c) - enc(image)) ** 2))
    cost = np.array(cost)
    i = cost.argmin()
    return f"{SIGMAS[i]:.2f} ({100 * (cost[-1] / cost[i] - 1):.2f} %)"


def smoothed_ld(d, part, width, height, tolerance=np.inf):
    v, px = d[:, 0].astype(int), d[:, 1].astype(int)
    nv = v.max() + 1
    ldm = np.zeros((nv, height, width, 3))
    pm = np.full((nv, height, width), -1)
    ldm[v, px // width, px % width] = d[:, 13:16]
    pm[v, px // width, px % width] = part
    acc, cnt = np.zeros((len(d), 3)), np.zeros(len(d))
    y, x = px // width, px % width
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            yy, xx = np.clip(y + dy, 0, height - 1), np.clip(x + dx, 0, width - 1)
            near = ldm[v, yy, xx].sum(1)
            own = d[:, 13:16].sum(1)
            ok = (pm[v, yy, xx] == part) & (np.abs(near - own) <= tolerance * own)
            acc += ok[:, None] * ldm[v, yy, xx]
            cnt += ok
    return acc / cnt[:, None]


def main():
    d = np.fromfile(sys.argv[1], dtype="<f4").reshape(-1, COLS)
    part = d[:, 2].astype(int)
    width, height = int(sys.argv[2]), int(sys.argv[3])
    parts = [int(a) for a in sys.argv[4:]] or sorted(set(part))
    lds = smoothed_ld(d, part, width, height)
    ldt = smoothed_ld(d, part, width, height, 0.2)
    print(f"{'part':>4} {'true σ':>6} | {'raw':>14} | {'Ld 3x3':>14} | {'res/view':>14} | {'no flies':>14} | {'linear':>14} | {'Ld ±20 %':>14}")
    for pid in parts:
        k = part == pid
        r = d[k]
        if len(r) < 200 or np.any(r[:, 52:55].sum(1) <= 0):
            continue
        image, ld = r[:, 10:13], r[:, 13:16]
        ls0, ls1 = r[:, 16:34].reshape(-1, 6, 3), r[:, 34:52].reshape(-1, 6, 3)
        kd, sigma = r[:, 52:55], float(np.median(r[:, 55]))
        cid = cells(r[:, 3:6])
        model = kd * ld + 0.04 * lerp(ls0, sigma) + lerp(ls1, sigma)
        res = image - model
        view = r[:, 0].astype(int)
        rng = np.random.default_rng(pid)
        permuted = res.copy()
        for vv in np.unique(view):
            at = np.where(view == vv)[0]
            permuted[at] = res[rng.permutation(at)]
        lum = image.sum(1)
        med = np.zeros(cid.max() + 1)
        for c in np.unique(cid):
            med[c] = np.median(lum[cid == c])
        keep = lum <= 4 * med[cid]
        _, ckeep = np.unique(cid[keep], return_inverse=True)
        print(
            f"{pid:>4} {sigma:>6.2f} | {argmin(image, ld, ls0, ls1, cid):>14} | "
            f"{argmin(image, lds[k], ls0, ls1, cid):>14} | "
            f"{argmin(model + permuted, ld, ls0, ls1, cid):>14} | "
            f"{argmin(image[keep], ld[keep], ls0[keep], ls1[keep], ckeep.ravel()):>14} | "
            f"{argmin(image, ld, ls0, ls1, cid, linear=True):>14} | "
            f"{argmin(image, ldt[k], ls0, ls1, cid):>14}"
        )


if __name__ == "__main__":
    main()
