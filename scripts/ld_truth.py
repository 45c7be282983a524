"""The diffuse shading Ld of a run's stored shadings against Mitsuba's own, at one view's pixels.

Usage: python3 scripts/ld_truth.py SRC VIEW SHADINGS [SHADINGS ...] [--step 4] [--dirs 512]
                                    [--depth 7] [--scale S]

SRC: a room made by scripts/mitsuba_loft.py (its scene_parts.json names the layout);
SHADINGS: a folder of a run's `.fsh` files (RUN/bake/train, RUN/refine1/train); VIEW: a
training view. At every --step-th pixel the true Ld0 (the `principled` diffuse's σ-free term
(1 − F_o/2)·(1/π)∫ L (1 − F_i/2) cos θi dω, the quantity the .fsh files store as Ld) is
integrated by Mitsuba's `path` integrator over --dirs cosine directions, with paths of at most
--depth segments from the surface point. The views of a room rendered with `max_depth` D hold,
at a pixel's surface point, incident light of at most D − 1 segments: `--depth 7` for the rooms
of mitsuba_loft.py's default (max_depth 8). --scale: the run's working scale S (the views are
divided by S; default: the `@exposure:S` tag of the shadings' manifest). Pixels whose stored Ld
is 0 (the emitters') are left out. Prints each folder's Σ Ld / Σ truth.
Needs `pip install mitsuba numpy`.
"""
import argparse, json, math, os, re, struct, sys
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_loft as ml  # noqa: E402  (sets the Mitsuba variant)
import mitsuba as mi  # noqa: E402


def read_fsh(path):
    """One view's shadings: (valid mask, Ld0) as H×W and H×W×3 arrays."""
    b = open(path, "rb").read()
    if b[:8] != b"FIPTSHD\0":
        sys.exit(f"{path}: not a .fsh file")
    ver, w, h, nl = struct.unpack("<4I", b[8:24])
    off, sparse = 24, ver >= 3
    stored = struct.unpack("<I", b[24:28])[0] if sparse else w * h
    off += 4 if sparse else 0
    off += 4 * nl
    valid = np.frombuffer(b, np.uint8, w * h, off).astype(bool)
    off += w * h
    ld = np.frombuffer(b, np.float32, stored * 3, off).reshape(stored, 3)
    dense = np.zeros((w * h, 3), np.float32)
    if sparse:
        dense[valid] = ld
    else:
        dense[:] = ld
    return valid.reshape(h, w), dense.reshape(h, w, 3)


def v3(x):
    return np.array([np.array(x.x), np.array(x.y), np.array(x.z)]).T


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("src")
    ap.add_argument("view", type=int)
    ap.add_argument("shadings", nargs="+")
    ap.add_argument("--step", type=int, default=4)
    ap.add_argument("--dirs", type=int, default=512)
    ap.add_argument("--depth", type=int, default=7)
    ap.add_argument("--scale", type=float)
    a = ap.parse_args()
    layout = json.load(open(os.path.join(a.src, "scene_parts.json")))["scene"]
    lay = ml.LAYOUTS[layout]
    objs = lay["objects"](np.array(lay["lo"]), np.array(lay["hi"]))
    tmp = os.path.join("/tmp", f"ld_truth_{layout}")
    os.makedirs(tmp, exist_ok=True)
    scene = mi.load_dict(ml.scene_dict(objs, ml.write_meshes(objs, tmp)))
    t = json.load(open(os.path.join(a.src, "train", "transforms.json")))
    w, h = t["width"], t["height"]
    f = 0.5 * w / math.tan(t["camera_angle_x"] / 2)
    m = np.array(t["frames"][a.view]["transform_matrix"])
    ys, xs = np.meshgrid(np.arange(h)[:: a.step], np.arange(w)[:: a.step], indexing="ij")
    ys, xs = ys.ravel(), xs.ravel()
    d = np.stack([-(xs + 0.5 - w / 2) / f, -(ys + 0.5 - h / 2) / f, np.ones(len(xs))], -1) @ m[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.repeat(m[None, :3, 3], len(d), 0)
    si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*o.T.astype(np.float32)), mi.Vector3f(*d.T.astype(np.float32))))
    p, nrm, hit = v3(si.p), v3(si.n), np.array(si.is_valid())
    nrm[(nrm * d).sum(1) > 0] *= -1
    n, k = len(p), a.dirs
    rng = np.random.default_rng(1)
    r1, r2 = rng.random((n, k)), rng.random((n, k))
    lz = np.sqrt(np.maximum(0.0, 1 - r1))
    lx, ly = np.sqrt(r1) * np.cos(2 * np.pi * r2), np.sqrt(r1) * np.sin(2 * np.pi * r2)
    helper = np.where(np.abs(nrm[:, :1]) > 0.9, np.array([[0, 1, 0]]), np.array([[1, 0, 0]]))
    t1 = np.cross(nrm, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(nrm, t1)
    wi = lx[..., None] * t1[:, None] + ly[..., None] * t2[:, None] + lz[..., None] * nrm[:, None]
    org = np.broadcast_to((p + nrm * 1e-4)[:, None, :], wi.shape).reshape(-1, 3)
    integ = mi.load_dict({"type": "path", "max_depth": a.depth})
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(3, n * k)
    ray = mi.Ray3f(mi.Point3f(*org.T.astype(np.float32)), mi.Vector3f(*wi.reshape(-1, 3).T.astype(np.float32)))
    radiance = v3(integ.sample(scene, sampler, ray)[0]).reshape(n, k, 3)
    fi = (1 - lz) ** 5
    fo = (1 - np.clip((-d * nrm).sum(1), 0, 1)) ** 5
    truth = (radiance * (1 - 0.5 * fi)[..., None]).mean(1) * (1 - 0.5 * fo)[:, None]
    for folder in a.shadings:
        scale = a.scale
        if scale is None:
            key = json.load(open(os.path.join(os.path.dirname(folder.rstrip("/")), "manifest.json")))["inputs_hash"]
            tag = re.search(r"@exposure:([^@]+)", key)
            scale = float(tag.group(1)) if tag else 1.0
        valid, ld = read_fsh(os.path.join(folder, f"{a.view:03d}.fsh"))
        if valid.shape != (h, w):
            sys.exit(f"{folder}: shadings of {valid.shape[1]}x{valid.shape[0]} for views of {w}x{h} (a downscaled run?)")
        ld = ld[ys, xs]
        ok = hit & valid[ys, xs] & (ld.mean(1) > 0)
        print(f"{folder}: {ok.sum()} pixels, Σ Ld / Σ Mitsuba's (paths ≤ {a.depth} segments) = "
              f"{ld[ok].sum() / (truth[ok].sum() / scale):.4f}")


if __name__ == "__main__":
    main()
