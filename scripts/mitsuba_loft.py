#!/usr/bin/env python3
"""Renders rooms made by an independent renderer (Mitsuba 3, `principled` BSDF) in the FIPT
synthetic layout, to check the presets on data our tracer did not make and that they were not
tuned on (`docs/loft-mitsuba.md`).

    pip install mitsuba==3.9.1 numpy
    python3 scripts/mitsuba_loft.py --out loft --spp 512
    python3 scripts/mitsuba_loft.py --layout gallery --out gallery --spp 512
    python3 scripts/mitsuba_loft.py --layout bedroom --out bedroom --spp 512
    python3 scripts/mitsuba_loft.py --layout atelier --out atelier --spp 256
    python3 scripts/mitsuba_loft.py --layout kitchen --out kitchen --spp 256
    python3 scripts/mitsuba_loft.py --layout kitchen --out kitchen-direct --spp 64 --max-depth 2
    python3 scripts/mitsuba_loft.py --layout office --out office --spp 256

`loft`: a glossy textured floor, one one-sided ceiling panel, a copper cylinder (metal,
σ 0.25), a rough aluminium box (metal, σ 0.45), a glossy red sphere (dielectric, σ 0.15), a
cabinet and a low table. `gallery` (held out for its first run only; settings were chosen with
it since: `docs/gallery-mitsuba.md`): see `gallery_objects`. `bedroom` (held out for its first
run only: `docs/bedroom-mitsuba.md`): see `bedroom_objects`, at 256×192. 40 train and 8 val views
(240×160 unless the layout says otherwise), a relighting set (a sphere light, the
scene's lights off). Ground-truth maps are the values at each pixel-centre ray. Deterministic
with --seed.
"""
import argparse
import json
import math
import os
import time

import numpy as np
import mitsuba as mi
import drjit as dr

mi.set_variant("llvm_ad_rgb")

W, H, FOV = 240, 160, 65.0
# A layout's objects list the floor, the ceiling and four walls first, then the rest.
ROOM_SURFACES = 6


def quad(p0, p1, p2, p3):
    """Two triangles p0 p1 p2, p0 p2 p3 (counter-clockwise seen from the normal side)."""
    return [(p0, p1, p2), (p0, p2, p3)]


def box(lo, hi):
    """Closed box, outward normals."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    c = lambda x, y, z: np.array([x, y, z], float)
    t = []
    t += quad(c(x0, y1, z0), c(x0, y1, z1), c(x1, y1, z1), c(x1, y1, z0))  # +y
    t += quad(c(x0, y0, z0), c(x1, y0, z0), c(x1, y0, z1), c(x0, y0, z1))  # -y
    t += quad(c(x1, y0, z0), c(x1, y1, z0), c(x1, y1, z1), c(x1, y0, z1))  # +x
    t += quad(c(x0, y0, z0), c(x0, y0, z1), c(x0, y1, z1), c(x0, y1, z0))  # -x
    t += quad(c(x0, y0, z1), c(x1, y0, z1), c(x1, y1, z1), c(x0, y1, z1))  # +z
    t += quad(c(x0, y0, z0), c(x0, y1, z0), c(x1, y1, z0), c(x1, y0, z0))  # -z
    return t


def cylinder(cx, cz, r, h, n=64):
    """Capped cylinder standing on y = 0, outward normals."""
    t = []
    ang = [2 * math.pi * i / n for i in range(n + 1)]
    for a0, a1 in zip(ang[:-1], ang[1:]):
        p0 = np.array([cx + r * math.cos(a0), 0, cz + r * math.sin(a0)])
        p1 = np.array([cx + r * math.cos(a1), 0, cz + r * math.sin(a1)])
        q0, q1 = p0 + [0, h, 0], p1 + [0, h, 0]
        t += quad(p0, q0, q1, p1)
        top, bot = np.array([cx, h, cz]), np.array([cx, 0, cz])
        t.append((top, q1, q0))
        t.append((bot, p0, p1))
    return t


def sphere(c, r, nu=48, nv=24):
    """UV sphere, outward normals."""
    t = []
    c = np.asarray(c, float)

    def pt(i, j):
        th, ph = math.pi * j / nv, 2 * math.pi * i / nu
        return c + r * np.array([math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)])

    for j in range(nv):
        for i in range(nu):
            a, b, cc, d = pt(i, j), pt(i + 1, j), pt(i + 1, j + 1), pt(i, j + 1)
            if j > 0:
                t.append((a, b, cc))
            if j < nv - 1:
                t.append((a, cc, d))
    return t


def outward(tris, centre):
    """Flips triangles whose geometric normal points towards `centre` (for closed meshes)."""
    out = []
    for a, b, c in tris:
        n = np.cross(b - a, c - a)
        m = (a + b + c) / 3
        out.append((a, b, c) if np.dot(n, m - centre) > 0 else (a, c, b))
    return out


def shell(lo, hi):
    """The room's floor, ceiling and walls x-, x+, z-, z+ (normals inward)."""
    c = lambda x, y, z: np.array([x, y, z], float)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    floor = quad(c(x0, y0, z1), c(x1, y0, z1), c(x1, y0, z0), c(x0, y0, z0))
    ceiling = quad(c(x0, y1, z0), c(x1, y1, z0), c(x1, y1, z1), c(x0, y1, z1))
    wall_xm = quad(c(x0, y0, z0), c(x0, y1, z0), c(x0, y1, z1), c(x0, y0, z1))
    wall_xp = quad(c(x1, y0, z0), c(x1, y0, z1), c(x1, y1, z1), c(x1, y1, z0))
    wall_zm = quad(c(x0, y0, z0), c(x1, y0, z0), c(x1, y1, z0), c(x0, y1, z0))
    wall_zp = quad(c(x0, y0, z1), c(x0, y1, z1), c(x1, y1, z1), c(x1, y0, z1))
    return floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp


def loft_objects(lo, hi):
    c = lambda x, y, z: np.array([x, y, z], float)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp = shell(lo, hi)
    py = y1 - 0.01
    panel = quad(c(-0.2, py, -0.6), c(1.4, py, -0.6), c(1.4, py, 0.0), c(-0.2, py, 0.0))
    cyl = cylinder(-1.3, -0.8, 0.28, 0.9)
    cab_lo, cab_hi = c(1.2, 0.0, -1.78), c(2.38, 0.75, -1.2)
    table_lo, table_hi = c(-0.6, 0.0, 0.5), c(0.5, 0.42, 1.2)
    alu_lo, alu_hi = c(-0.35, 0.42, 0.65), c(0.0, 0.72, 0.95)
    red = sphere([0.9, 0.25, 0.3], 0.25)
    checker = {"type": "checker", "color0": [0.62, 0.44, 0.28], "color1": [0.30, 0.20, 0.12],
               "uv_scale": [6.0, 4.5]}
    return [
        ("floor", floor, dict(base_color=checker, roughness=0.35, metallic=0.0)),
        ("ceiling", ceiling, dict(base_color=[0.85, 0.85, 0.83], roughness=1.0, metallic=0.0)),
        ("wall_left_x-", wall_xm, dict(base_color=[0.35, 0.45, 0.60], roughness=0.9, metallic=0.0)),
        ("wall_right_x+", wall_xp, dict(base_color=[0.75, 0.70, 0.55], roughness=0.85, metallic=0.0)),
        ("wall_back_z-", wall_zm, dict(base_color=[0.55, 0.60, 0.45], roughness=0.95, metallic=0.0)),
        ("wall_front_z+", wall_zp, dict(base_color=[0.70, 0.50, 0.45], roughness=0.9, metallic=0.0)),
        ("ceiling_panel", panel, dict(radiance=[14.0, 13.0, 11.5])),
        ("copper_cylinder", outward(cyl, c(-1.3, 0.45, -0.8)),
         dict(base_color=[0.95, 0.64, 0.54], roughness=0.25, metallic=1.0)),
        ("cabinet", box(cab_lo, cab_hi), dict(base_color=[0.60, 0.50, 0.38], roughness=0.8, metallic=0.0)),
        ("low_table", box(table_lo, table_hi), dict(base_color=[0.12, 0.12, 0.14], roughness=0.5, metallic=0.0)),
        ("alu_box", box(alu_lo, alu_hi), dict(base_color=[0.91, 0.92, 0.92], roughness=0.45, metallic=1.0)),
        ("red_sphere", red, dict(base_color=[0.70, 0.12, 0.10], roughness=0.15, metallic=0.0)),
    ]


def gallery_objects(lo, hi):
    """A second layout, rendered for a held-out check: a dark glossy floor, two lights (a one-sided wall
    panel and a small bright ceiling square), a rough steel cylinder, a brass pole, a chrome
    sphere, a black glossy sphere on a painted pedestal, a white glossy box and a checkered rug."""
    c = lambda x, y, z: np.array([x, y, z], float)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp = shell(lo, hi)
    zp, py = z0 + 0.01, y1 - 0.01
    wall_panel = quad(c(-0.8, 1.6, zp), c(0.8, 1.6, zp), c(0.8, 2.4, zp), c(-0.8, 2.4, zp))
    spot = quad(c(1.65, py, 0.85), c(1.95, py, 0.85), c(1.95, py, 1.15), c(1.65, py, 1.15))
    ry = y0 + 0.005
    rug = quad(c(-1.6, ry, 1.4), c(0.4, ry, 1.4), c(0.4, ry, -0.2), c(-1.6, ry, -0.2))
    checker = {"type": "checker", "color0": [0.70, 0.62, 0.50], "color1": [0.25, 0.18, 0.15],
               "uv_scale": [5.0, 4.0]}
    return [
        ("floor", floor, dict(base_color=[0.22, 0.22, 0.24], roughness=0.2, metallic=0.0)),
        ("ceiling", ceiling, dict(base_color=[0.90, 0.90, 0.90], roughness=1.0, metallic=0.0)),
        ("wall_left_x-", wall_xm, dict(base_color=[0.80, 0.78, 0.72], roughness=0.9, metallic=0.0)),
        ("wall_right_x+", wall_xp, dict(base_color=[0.45, 0.30, 0.28], roughness=0.75, metallic=0.0)),
        ("wall_back_z-", wall_zm, dict(base_color=[0.30, 0.42, 0.38], roughness=0.95, metallic=0.0)),
        ("wall_front_z+", wall_zp, dict(base_color=[0.78, 0.76, 0.70], roughness=0.85, metallic=0.0)),
        ("wall_panel", wall_panel, dict(radiance=[9.0, 9.5, 10.5])),
        ("ceiling_spot", spot, dict(radiance=[60.0, 52.0, 40.0])),
        ("rug", rug, dict(base_color=checker, roughness=0.6, metallic=0.0)),
        ("steel_cylinder", outward(cylinder(-2.1, -1.2, 0.3, 1.1), c(-2.1, 0.55, -1.2)),
         dict(base_color=[0.56, 0.57, 0.58], roughness=0.5, metallic=1.0)),
        ("brass_pole", box(c(2.14, 0.0, -0.26), c(2.26, 1.6, -0.14)),
         dict(base_color=[0.90, 0.72, 0.40], roughness=0.3, metallic=1.0)),
        ("white_box", box(c(-0.85, 0.0, 0.35), c(-0.35, 0.5, 0.85)),
         dict(base_color=[0.82, 0.82, 0.80], roughness=0.25, metallic=0.0)),
        ("pedestal", box(c(1.2, 0.0, -1.6), c(1.6, 0.8, -1.2)),
         dict(base_color=[0.20, 0.30, 0.55], roughness=0.6, metallic=0.0)),
        ("black_sphere", sphere([1.4, 1.02, -1.4], 0.22),
         dict(base_color=[0.04, 0.04, 0.05], roughness=0.1, metallic=0.0)),
        ("chrome_sphere", sphere([0.9, 0.2, 1.3], 0.2),
         dict(base_color=[0.95, 0.95, 0.95], roughness=0.08, metallic=1.0)),
    ]


def bedroom_objects(lo, hi):
    """A fourth layout, rendered for a held-out check of materials that vary inside one object:
    a plank floor whose base colour and roughness alternate together (σ 0.25 / 0.6), a tray of
    alternating gold (metal) and black glossy (dielectric) tiles, a semi-gloss wall (σ 0.45), a
    lacquered nightstand (σ 0.12), a gold vase, a bed, and two lights: a ceiling square and a
    lamp shade that emits from all its faces (a closed box)."""
    c = lambda x, y, z: np.array([x, y, z], float)
    floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp = shell(lo, hi)
    py = hi[1] - 0.01
    panel = quad(c(-0.3, py, -0.3), c(0.3, py, -0.3), c(0.3, py, 0.3), c(-0.3, py, 0.3))
    planks = {"type": "checker", "color0": [0.46, 0.31, 0.19], "color1": [0.30, 0.19, 0.12],
              "uv_scale": [9.0, 3.0]}
    plank_sigma = {"type": "checker", "color0": 0.25, "color1": 0.6, "uv_scale": [9.0, 3.0]}
    tiles = {"type": "checker", "color0": [1.0, 0.78, 0.34], "color1": [0.05, 0.05, 0.05], "uv_scale": [4.0, 4.0]}
    tile_metal = {"type": "checker", "color0": 1.0, "color1": 0.0, "uv_scale": [4.0, 4.0]}
    return [
        ("floor", floor, dict(base_color=planks, roughness=plank_sigma, metallic=0.0)),
        ("ceiling", ceiling, dict(base_color=[0.88, 0.88, 0.86], roughness=1.0, metallic=0.0)),
        ("wall_left_x-", wall_xm, dict(base_color=[0.62, 0.66, 0.72], roughness=0.45, metallic=0.0)),
        ("wall_right_x+", wall_xp, dict(base_color=[0.80, 0.74, 0.62], roughness=0.9, metallic=0.0)),
        ("wall_back_z-", wall_zm, dict(base_color=[0.50, 0.36, 0.40], roughness=0.85, metallic=0.0)),
        ("wall_front_z+", wall_zp, dict(base_color=[0.74, 0.74, 0.70], roughness=0.95, metallic=0.0)),
        ("ceiling_square", panel, dict(radiance=[11.0, 11.0, 12.0])),
        ("lamp_shade", box(c(1.85, 1.05, 1.15), c(2.15, 1.35, 1.45)), dict(radiance=[7.0, 5.6, 3.6])),
        ("lamp_pole", box(c(1.98, 0.0, 1.28), c(2.02, 1.05, 1.32)),
         dict(base_color=[0.15, 0.15, 0.16], roughness=0.4, metallic=0.0)),
        ("bed", box(c(-2.2, 0.0, -1.9), c(-0.6, 0.5, 0.2)),
         dict(base_color=[0.25, 0.35, 0.55], roughness=1.0, metallic=0.0)),
        ("headboard", box(c(-2.2, 0.0, -2.0), c(-0.6, 1.1, -1.9)),
         dict(base_color=[0.35, 0.22, 0.14], roughness=0.35, metallic=0.0)),
        ("nightstand", box(c(-0.45, 0.0, -1.95), c(0.05, 0.55, -1.5)),
         dict(base_color=[0.85, 0.85, 0.84], roughness=0.12, metallic=0.0)),
        ("table", box(c(0.8, 0.0, -0.9), c(1.9, 0.7, -0.2)),
         dict(base_color=[0.55, 0.55, 0.52], roughness=0.7, metallic=0.0)),
        ("tray", box(c(1.05, 0.7, -0.75), c(1.55, 0.73, -0.35)),
         dict(base_color=tiles, roughness=0.25, metallic=tile_metal)),
        ("gold_vase", outward(cylinder(2.1, -1.6, 0.09, 0.4, n=48), c(2.1, 0.2, -1.6)),
         dict(base_color=[1.0, 0.78, 0.34], roughness=0.15, metallic=1.0)),
        ("grey_sphere", sphere([0.3, 0.3, 1.2], 0.3),
         dict(base_color=[0.45, 0.45, 0.45], roughness=0.7, metallic=0.0)),
    ]


def atelier_objects(lo, hi):
    """A fifth layout, for issue 55 (σ on rooms nobody tuned on): a plank floor whose roughness
    changes in 2 m tiles (σ 0.3 / 0.65) independently of its wood checker, a rough brick-red wall
    (σ 1), a glossy painted wall (σ 0.4), a bright plaster sphere (σ 1), a near-black glossy box
    (σ 0.1), two metals of different roughness (steel σ 0.2, copper σ 0.6), a shelf (σ 0.7), a
    checkered rug (σ 0.9), a window panel on the back wall and a ceiling square."""
    c = lambda x, y, z: np.array([x, y, z], float)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp = shell(lo, hi)
    zp, py, ry = z0 + 0.01, y1 - 0.01, y0 + 0.005
    window = quad(c(-1.2, 1.1, zp), c(0.2, 1.1, zp), c(0.2, 2.0, zp), c(-1.2, 2.0, zp))
    lamp = quad(c(0.8, py, 0.4), c(1.2, py, 0.4), c(1.2, py, 0.8), c(0.8, py, 0.8))
    rug = quad(c(-0.4, ry, 1.8), c(1.2, ry, 1.8), c(1.2, ry, 0.6), c(-0.4, ry, 0.6))
    planks = {"type": "checker", "color0": [0.55, 0.40, 0.26], "color1": [0.42, 0.29, 0.18],
              "uv_scale": [10.0, 4.0]}
    finish = {"type": "checker", "color0": 0.3, "color1": 0.65, "uv_scale": [1.35, 1.1]}
    rug_c = {"type": "checker", "color0": [0.75, 0.70, 0.62], "color1": [0.30, 0.35, 0.45],
             "uv_scale": [4.0, 3.0]}
    return [
        ("floor", floor, dict(base_color=planks, roughness=finish, metallic=0.0)),
        ("ceiling", ceiling, dict(base_color=[0.90, 0.90, 0.88], roughness=1.0, metallic=0.0)),
        ("wall_brick_x-", wall_xm, dict(base_color=[0.55, 0.28, 0.20], roughness=1.0, metallic=0.0)),
        ("wall_gloss_x+", wall_xp, dict(base_color=[0.45, 0.60, 0.52], roughness=0.4, metallic=0.0)),
        ("wall_back_z-", wall_zm, dict(base_color=[0.78, 0.76, 0.70], roughness=0.9, metallic=0.0)),
        ("wall_front_z+", wall_zp, dict(base_color=[0.60, 0.55, 0.62], roughness=0.8, metallic=0.0)),
        ("window", window, dict(radiance=[8.0, 8.5, 9.5])),
        ("ceiling_lamp", lamp, dict(radiance=[20.0, 18.0, 14.0])),
        ("rug", rug, dict(base_color=rug_c, roughness=0.9, metallic=0.0)),
        ("plaster_sphere", sphere([-1.2, 0.3, 1.0], 0.3),
         dict(base_color=[0.85, 0.84, 0.80], roughness=1.0, metallic=0.0)),
        ("black_box", box(c(0.6, 0.0, -1.0), c(1.1, 0.45, -0.5)),
         dict(base_color=[0.03, 0.03, 0.03], roughness=0.1, metallic=0.0)),
        ("steel_cylinder", outward(cylinder(-1.8, -1.4, 0.25, 0.9), c(-1.8, 0.45, -1.4)),
         dict(base_color=[0.60, 0.61, 0.62], roughness=0.2, metallic=1.0)),
        ("copper_box", box(c(1.6, 0.0, 0.9), c(2.1, 0.5, 1.4)),
         dict(base_color=[0.95, 0.64, 0.54], roughness=0.6, metallic=1.0)),
        ("shelf", box(c(-2.65, 0.0, -0.8), c(-2.25, 1.6, 0.6)),
         dict(base_color=[0.50, 0.38, 0.25], roughness=0.7, metallic=0.0)),
    ]


def lift(tris, dy):
    """The triangles moved up by `dy`."""
    return [tuple(np.asarray(p, float) + [0.0, dy, 0.0] for p in t) for t in tris]


def kitchen_objects(lo, hi):
    """A sixth layout, held out from every setting (rendered after the presets of 2026-12-06):
    a tiled floor whose roughness changes in its own tiles (σ 0.2 / 0.5) over a two-tone tile
    checker, a dark matte wall (σ 0.9), a glossy splashback wall (σ 0.3), a satin wall (σ 0.6),
    a glossy white counter (σ 0.15), a brushed-steel fridge (metal σ 0.35), a rough gold sphere
    (metal σ 0.5), a dark green glossy vase (σ 0.1), a rough terracotta pot (σ 1), a dark fabric
    ottoman (σ 0.9), a wooden table (σ 0.45), a window and a pendant that emits from all faces."""
    c = lambda x, y, z: np.array([x, y, z], float)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp = shell(lo, hi)
    zp = z0 + 0.01
    window = quad(c(-1.2, 1.0, zp), c(0.4, 1.0, zp), c(0.4, 2.0, zp), c(-1.2, 2.0, zp))
    tiles = {"type": "checker", "color0": [0.80, 0.78, 0.74], "color1": [0.60, 0.58, 0.56],
             "uv_scale": [6.0, 4.0]}
    finish = {"type": "checker", "color0": 0.2, "color1": 0.5, "uv_scale": [2.0, 1.5]}
    vase = outward(lift(cylinder(-2.25, -0.9, 0.08, 0.35, n=48), 0.9), c(-2.25, 1.07, -0.9))
    return [
        ("floor", floor, dict(base_color=tiles, roughness=finish, metallic=0.0)),
        ("ceiling", ceiling, dict(base_color=[0.92, 0.92, 0.90], roughness=0.95, metallic=0.0)),
        ("wall_dark_x-", wall_xm, dict(base_color=[0.18, 0.18, 0.20], roughness=0.9, metallic=0.0)),
        ("wall_splash_x+", wall_xp, dict(base_color=[0.70, 0.80, 0.85], roughness=0.3, metallic=0.0)),
        ("wall_back_z-", wall_zm, dict(base_color=[0.85, 0.70, 0.50], roughness=1.0, metallic=0.0)),
        ("wall_front_z+", wall_zp, dict(base_color=[0.55, 0.60, 0.70], roughness=0.6, metallic=0.0)),
        ("window", window, dict(radiance=[8.0, 8.5, 9.5])),
        ("pendant", box(c(0.0, 1.9, 0.45), c(0.3, 2.1, 0.75)), dict(radiance=[12.0, 10.0, 7.0])),
        ("counter", box(c(-2.55, 0.0, -1.5), c(-1.95, 0.9, 0.5)),
         dict(base_color=[0.85, 0.85, 0.83], roughness=0.15, metallic=0.0)),
        ("fridge", box(c(1.7, 0.0, -1.95), c(2.5, 1.9, -1.3)),
         dict(base_color=[0.62, 0.62, 0.63], roughness=0.35, metallic=1.0)),
        ("table", box(c(-0.5, 0.0, 0.2), c(0.7, 0.75, 1.0)),
         dict(base_color=[0.45, 0.30, 0.18], roughness=0.45, metallic=0.0)),
        ("gold_sphere", sphere([0.2, 0.93, 0.6], 0.18),
         dict(base_color=[1.0, 0.78, 0.34], roughness=0.5, metallic=1.0)),
        ("green_vase", vase, dict(base_color=[0.05, 0.15, 0.08], roughness=0.1, metallic=0.0)),
        ("terracotta_pot", outward(cylinder(1.8, 1.3, 0.25, 0.5), c(1.8, 0.25, 1.3)),
         dict(base_color=[0.65, 0.35, 0.22], roughness=1.0, metallic=0.0)),
        ("ottoman", box(c(-1.6, 0.0, 1.0), c(-1.0, 0.42, 1.6)),
         dict(base_color=[0.12, 0.10, 0.10], roughness=0.9, metallic=0.0)),
    ]


def office_objects(lo, hi):
    """A seventh layout, held out from every setting (rendered 2026-12-07, after the rules of
    that day): a rough concrete floor (σ 0.75), a lacquered glossy wall (σ 0.25), a dark matte
    wall (σ 0.95), a satin wall (σ 0.7), a desk whose top has two finishes that follow its two
    colours (σ 0.25 / 0.7), a near-mirror chrome sphere (metal σ 0.08), a brushed aluminium
    cylinder (metal σ 0.45), a leather chair (σ 0.55), a rough plaster column (σ 1), a piano-black
    box (σ 0.05), a ceiling strip light and a floor lamp's shade."""
    c = lambda x, y, z: np.array([x, y, z], float)
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    floor, ceiling, wall_xm, wall_xp, wall_zm, wall_zp = shell(lo, hi)
    py = y1 - 0.01
    strip = quad(c(-1.5, py, -0.3), c(0.5, py, -0.3), c(0.5, py, 0.0), c(-1.5, py, 0.0))
    inlay = {"type": "checker", "color0": [0.62, 0.52, 0.40], "color1": [0.22, 0.30, 0.26],
             "uv_scale": [2.0, 2.0]}
    inlay_finish = {"type": "checker", "color0": 0.25, "color1": 0.7, "uv_scale": [2.0, 2.0]}
    return [
        ("floor", floor, dict(base_color=[0.48, 0.47, 0.45], roughness=0.75, metallic=0.0)),
        ("ceiling", ceiling, dict(base_color=[0.90, 0.90, 0.90], roughness=1.0, metallic=0.0)),
        ("wall_navy_x-", wall_xm, dict(base_color=[0.10, 0.13, 0.22], roughness=0.95, metallic=0.0)),
        ("wall_lacquer_x+", wall_xp, dict(base_color=[0.80, 0.55, 0.35], roughness=0.25, metallic=0.0)),
        ("wall_back_z-", wall_zm, dict(base_color=[0.82, 0.82, 0.78], roughness=0.85, metallic=0.0)),
        ("wall_front_z+", wall_zp, dict(base_color=[0.50, 0.62, 0.55], roughness=0.7, metallic=0.0)),
        ("strip_light", strip, dict(radiance=[13.0, 13.0, 12.0])),
        ("lamp_shade", box(c(1.9, 1.35, 1.2), c(2.25, 1.6, 1.55)), dict(radiance=[14.0, 11.0, 7.0])),
        ("desk", box(c(-0.9, 0.0, -1.6), c(0.7, 0.74, -0.8)),
         dict(base_color=inlay, roughness=inlay_finish, metallic=0.0)),
        ("chrome_sphere", sphere([0.3, 0.94, -1.2], 0.2),
         dict(base_color=[0.95, 0.95, 0.96], roughness=0.08, metallic=1.0)),
        ("alu_cylinder", outward(cylinder(2.0, -1.4, 0.22, 1.0), c(2.0, 0.5, -1.4)),
         dict(base_color=[0.91, 0.92, 0.92], roughness=0.45, metallic=1.0)),
        ("chair", box(c(-0.4, 0.0, 0.4), c(0.3, 0.5, 1.1)),
         dict(base_color=[0.35, 0.20, 0.12], roughness=0.55, metallic=0.0)),
        ("plaster_column", outward(cylinder(-1.9, 1.2, 0.3, 2.0), c(-1.9, 1.0, 1.2)),
         dict(base_color=[0.86, 0.85, 0.82], roughness=1.0, metallic=0.0)),
        ("piano_box", box(c(1.0, 0.0, 0.2), c(1.6, 0.6, 0.8)),
         dict(base_color=[0.02, 0.02, 0.02], roughness=0.05, metallic=0.0)),
    ]


# Each layout: room bounds, its objects (floor, ceiling and four walls first), the relighting
# sphere light (centre, radius, radiance; at least 1.3 m from every val camera).
LAYOUTS = {
    "loft": dict(lo=[-2.4, 0.0, -1.8], hi=[2.4, 2.7, 1.8], objects=loft_objects,
                 relight=([-0.8, 2.2, 1.3], 0.15, [70.0, 66.0, 58.0])),
    "gallery": dict(lo=[-3.0, 0.0, -2.0], hi=[3.0, 3.0, 2.0], objects=gallery_objects,
                    relight=([-1.5, 2.5, 1.2], 0.15, [70.0, 66.0, 58.0])),
    "bedroom": dict(lo=[-2.5, 0.0, -2.1], hi=[2.5, 2.6, 2.1], objects=bedroom_objects,
                    relight=([1.0, 2.1, 0.9], 0.15, [70.0, 66.0, 58.0]), camera=(256, 192, 60.0)),
    "atelier": dict(lo=[-2.7, 0.0, -2.2], hi=[2.7, 2.8, 2.2], objects=atelier_objects,
                    relight=([-0.5, 2.2, 0.2], 0.15, [70.0, 66.0, 58.0])),
    "kitchen": dict(lo=[-2.6, 0.0, -2.0], hi=[2.6, 2.7, 2.0], objects=kitchen_objects,
                    relight=([-0.8, 2.2, -0.5], 0.15, [70.0, 66.0, 58.0])),
    "office": dict(lo=[-2.5, 0.0, -2.0], hi=[2.5, 2.7, 2.0], objects=office_objects,
                   relight=([0.8, 2.2, 0.6], 0.15, [70.0, 66.0, 58.0])),
}


def write_obj(path, tris, comment, uv=None):
    """Flat-shaded OBJ: each triangle its own three vertices and one normal."""
    with open(path, "w") as f:
        f.write(f"# {comment}\n")
        for a, b, c in tris:
            for p in (a, b, c):
                f.write(f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n")
        if uv is not None:
            for a, b, c in tris:
                for p in (a, b, c):
                    u, v = uv(p)
                    f.write(f"vt {u:.6f} {v:.6f}\n")
        for a, b, c in tris:
            n = np.cross(b - a, c - a)
            n /= np.linalg.norm(n)
            f.write(f"vn {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}\n")
        for i in range(len(tris)):
            v = [3 * i + 1, 3 * i + 2, 3 * i + 3]
            if uv is not None:
                f.write("f " + " ".join(f"{k}/{k}/{i + 1}" for k in v) + "\n")
            else:
                f.write("f " + " ".join(f"{k}//{i + 1}" for k in v) + "\n")


def rgb(v):
    return {"type": "rgb", "value": list(map(float, v))}


def bbox_uv(tris):
    """The uv of a checkered (horizontal) object: u along +x, v along -z over its bounding box,
    as `fipt` reads `scene_parts.json` checkers."""
    pts = np.array([p for t in tris for p in t])
    lo, hi = pts.min(0), pts.max(0)
    return lambda p: ((p[0] - lo[0]) / (hi[0] - lo[0]), (hi[2] - p[2]) / (hi[2] - lo[2]))


TEXTURED = ("base_color", "roughness", "metallic")


def textured(m):
    return any(isinstance(m.get(k), dict) for k in TEXTURED)


def mi_texture(v):
    """A material parameter for Mitsuba: a constant (RGB or float) or a checkerboard over the uv."""
    if not isinstance(v, dict):
        return rgb(v) if isinstance(v, (list, tuple)) else float(v)
    c0, c1 = v["color0"], v["color1"]
    if not isinstance(c0, (list, tuple)):
        # Mitsuba 3.9.1's checkerboard returns color1 from eval_1 (scalar parameters) where
        # eval (colours) returns color0: swapped here so both follow the colour rule.
        c0, c1 = float(c1), float(c0)
    else:
        c0, c1 = rgb(c0), rgb(c1)
    return {"type": "checkerboard", "color0": c0, "color1": c1,
            "to_uv": mi.ScalarTransform4f().scale([v["uv_scale"][0], v["uv_scale"][1], 1.0])}


def gt_texture(v, tris, p):
    """A material parameter's value at points `p` (n × 3) of an object: n × 3."""
    if not isinstance(v, dict):
        return np.broadcast_to(np.asarray(v, float), (len(p), 3)) if isinstance(v, (list, tuple)) \
            else np.full((len(p), 3), float(v))
    u, w = bbox_uv(tris)(p.T)
    su, sv = v["uv_scale"]
    first = ((u * su) % 1.0 > 0.5) == ((w * sv) % 1.0 > 0.5)
    c0, c1 = (np.broadcast_to(np.asarray(x, float), (3,)) for x in (v["color0"], v["color1"]))
    return np.where(first[:, None], c0, c1)


def write_meshes(objs, tmp):
    """One OBJ per object (the floor with its uv), for Mitsuba; returns their paths."""
    paths = []
    for i, (name, tris, m) in enumerate(objs):
        paths.append(os.path.join(tmp, f"{i:02d}.obj"))
        write_obj(paths[-1], tris, name, bbox_uv(tris) if textured(m) else None)
    return paths


MAX_DEPTH = 8


def scene_dict(objs, paths, lights_on=True, extra=None):
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": MAX_DEPTH}}
    for i, ((name, tris, m), path) in enumerate(zip(objs, paths)):
        shape = {"type": "obj", "filename": path, "face_normals": True, "flip_tex_coords": False}
        if "radiance" in m:
            shape["bsdf"] = {"type": "diffuse", "reflectance": rgb([0, 0, 0])}
            if lights_on:
                shape["emitter"] = {"type": "area", "radiance": rgb(m["radiance"])}
        else:
            shape["bsdf"] = {"type": "principled", "base_color": mi_texture(m["base_color"]),
                             "roughness": mi_texture(m["roughness"]), "metallic": mi_texture(m["metallic"]),
                             "specular": 0.5}
        d[f"shape_{i:02d}"] = shape
    if extra:
        d.update(extra)
    return d


def cameras(rng, n, objs, lo, hi, panel_every):
    """Poses inside the room, aimed at objects, walls or (every `panel_every`-th) a light."""
    targets = {name: np.mean([np.mean(t, axis=0) for t in tris], axis=0) for name, tris, _ in objs}
    room = objs[:ROOM_SURFACES]
    lights = [name for name, _, m in objs if "radiance" in m]
    furniture = [o for o in objs[ROOM_SURFACES:] if "radiance" not in o[2]]
    blockers = [(np.min([p for t in tris for p in t], 0) - 0.25, np.max([p for t in tris for p in t], 0) + 0.25)
                for name, tris, m in furniture]
    # Objects twice as often as the floor and walls.
    names = [n_ for n_, _, _ in room if n_ != "ceiling"] + 2 * [n_ for n_, _, _ in furniture]
    out = []
    while len(out) < n:
        o = rng.uniform(lo + [0.35, 0.7, 0.35], hi - [0.35, 0.5, 0.35])
        if any(np.all(o > b0) and np.all(o < b1) for b0, b1 in blockers):
            continue
        k = len(out) // panel_every
        aim = lights[k % len(lights)] if len(out) % panel_every == panel_every - 1 else names[rng.integers(len(names))]
        t = targets[aim] + rng.normal(0, 0.3, 3)
        t = np.clip(t, lo + 0.05, hi - 0.05)
        d = t - o
        if np.linalg.norm(d) < 1.6 or abs(d[1]) / np.linalg.norm(d) > 0.9:
            continue
        out.append((o, t, aim))
    return out


def to_world(o, t):
    return mi.ScalarTransform4f().look_at(origin=list(map(float, o)), target=list(map(float, t)), up=[0, 1, 0])


def sensor(o, t, spp, seed):
    return {"type": "perspective", "fov": FOV, "fov_axis": "x", "to_world": to_world(o, t),
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
            "film": {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"}}


def pixel_rays(o, t):
    m = np.array(to_world(o, t).matrix, dtype=np.float64)
    f = 0.5 * W / math.tan(math.radians(FOV) / 2)
    u, v = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    d = np.stack([-(u - W / 2) / f, -(v - H / 2) / f, np.ones_like(u)], -1).reshape(-1, 3)
    d = d @ m[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return m, d


def shape_index(scene):
    """Object index (the `shape_NN` key) of each of the scene's shape ids, -1 elsewhere."""
    shape_ids = np.array(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()))
    lut = np.full(int(shape_ids.max()) + 1, -1)
    for k, sid in enumerate(shape_ids):
        lut[sid] = int(scene.shapes()[k].id()[len("shape_"):])
    return lut


def gt_maps(scene, index, objs, o, t):
    """Per-pixel-centre maps: IndexMA, DiffCol, Specular, Roughness, Metallic, Emit, albedo."""
    m, d = pixel_rays(o, t)
    n = d.shape[0]
    ray = mi.Ray3f(mi.Point3f(*[np.full(n, m[i, 3], np.float32) for i in range(3)]),
                   mi.Vector3f(*[d[:, i].astype(np.float32) for i in range(3)]))
    si = scene.ray_intersect(ray)
    ids = np.array(dr.reinterpret_array(mi.UInt32, si.shape)).astype(np.int64)
    idx = np.where(ids < len(index), index[np.minimum(ids, len(index) - 1)], -1)
    p = np.stack([np.array(si.p.x), np.array(si.p.y), np.array(si.p.z)], -1)
    maps = {k: np.zeros((n, 3), np.float32) for k in ("DiffCol", "Specular", "Roughness", "Metallic", "Emit")}
    maps["Roughness"][:] = 1.0
    for i, (name, tris, mat) in enumerate(objs):
        sel = idx == i
        if not sel.any():
            continue
        if "radiance" in mat:
            maps["Emit"][sel] = mat["radiance"]
            continue
        col, sig, mm = (gt_texture(mat[k], tris, p[sel]) for k in TEXTURED)
        maps["DiffCol"][sel] = col * (1 - mm)
        maps["Specular"][sel] = 0.04 * (1 - mm) + col * mm
        maps["Roughness"][sel] = sig
        maps["Metallic"][sel] = mm
    maps["albedo"] = maps["DiffCol"] + maps["Specular"]
    maps["IndexMA"] = np.repeat(np.maximum(idx, 0)[:, None], 3, 1).astype(np.float32)
    return {k: v.reshape(H, W, 3) for k, v in maps.items()}, idx.reshape(H, W)


def write_exr(path, a):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = path + ".tmp.exr"
    mi.Bitmap(np.ascontiguousarray(a, dtype=np.float32)).write(tmp)
    os.replace(tmp, path)


def transforms(cams):
    frames = []
    for k, (o, t, _) in enumerate(cams):
        frames.append({"file_path": f"Image/{k:03d}_0001.exr",
                       "transform_matrix": np.array(to_world(o, t).matrix).tolist(),
                       "origin": [round(float(x), 4) for x in o], "look_at": [round(float(x), 4) for x in t]})
    return {"camera_angle_x": math.radians(FOV), "width": W, "height": H,
            "camera_convention": "Mitsuba camera-to-world: local +X = image left, +Y = up, +Z = forward; "
                                 "pixel-centre ray (-(u-W/2)/f, -(v-H/2)/f, 1), f = 0.5*W/tan(camera_angle_x/2)",
            "frames": frames}


def parts_json(objs, layout):
    out, start = [], 0
    for i, (name, tris, m) in enumerate(objs):
        pts = np.array([p for t in tris for p in t])
        o = {"index": i, "name": name, "face_start": start, "face_end": start + len(tris),
             "num_faces": len(tris), "bbox": [pts.min(0).round(6).tolist(), pts.max(0).round(6).tolist()]}
        start += len(tris)
        if "radiance" in m:
            o.update(type="emitter", radiance=m["radiance"],
                     emitter="Mitsuba area (one-sided, front = normal side), BSDF black")
        else:
            o.update(type="principled", roughness=m["roughness"], metallic=m["metallic"], specular=0.5,
                     base_color=m["base_color"])
        out.append(o)
    return {"scene": layout, "geometry": {"file": "scene.obj", "num_faces": start,
                                          "face_range": "[face_start, face_end) in scene.obj face order (0-based)"},
            "gt_conventions": {
                "bsdf": "Mitsuba 3.9.1 `principled` (specular 0.5 -> dielectric F0 0.04; one-sided)",
                "kd": "base_color * (1 - metallic)", "ks": "F0 = 0.04 * (1 - metallic) + base_color * metallic",
                "roughness": "principled roughness; GGX alpha = roughness^2",
                "emitters": "area emitters, constant radiance, one-sided (front = normal side); BSDF black. "
                            "Emitter pixels in GT maps: kd = ks = metallic = 0, roughness = 1, Emit = radiance"},
            "objects": out}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--layout", choices=sorted(LAYOUTS), default="loft")
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--train", type=int, default=40)
    ap.add_argument("--val", type=int, default=8)
    ap.add_argument("--relight-only", action="store_true", help="render only relight/ (same cameras)")
    ap.add_argument("--max-depth", type=int, default=8,
                    help="path length; 2 renders the lights' direct light alone (same cameras for the same --seed, --train, --val)")
    a = ap.parse_args()
    global MAX_DEPTH
    MAX_DEPTH = a.max_depth
    rng = np.random.default_rng(a.seed)
    lay = LAYOUTS[a.layout]
    global W, H, FOV
    W, H, FOV = lay.get("camera", (W, H, FOV))
    lo, hi = np.array(lay["lo"]), np.array(lay["hi"])
    objs = lay["objects"](lo, hi)
    os.makedirs(a.out, exist_ok=True)
    tmp = os.path.join(a.out, ".meshes")
    os.makedirs(tmp, exist_ok=True)
    all_tris = [t for _, tris, _ in objs for t in tris]
    write_obj(os.path.join(a.out, "scene.obj"), all_tris, f"{a.layout}-mitsuba: whole scene, world space, metres, y up")
    with open(os.path.join(a.out, "scene_parts.json"), "w") as f:
        json.dump(parts_json(objs, a.layout), f, indent=1)
    paths = write_meshes(objs, tmp)
    scene = mi.load_dict(scene_dict(objs, paths))
    index = shape_index(scene)
    centre, radius, power = lay["relight"]
    relight_scene = mi.load_dict(scene_dict(objs, paths, lights_on=False, extra={"relight": {
        "type": "sphere", "center": centre, "radius": radius,
        "bsdf": {"type": "diffuse", "reflectance": rgb([0, 0, 0])},
        "emitter": {"type": "area", "radiance": rgb(power)}}}))
    log = {"scene": a.layout, "mitsuba": mi.__version__, "variant": mi.variant(), "spp": a.spp, "seed": a.seed,
           "render": {}}
    splits = {"train": cameras(rng, a.train, objs, lo, hi, 5), "val": cameras(rng, a.val, objs, lo, hi, 6)}
    todo = [] if a.relight_only else list(splits.items())
    for split, cams in todo + [("relight", splits["val"])]:
        sdir = os.path.join(a.out, split)
        os.makedirs(sdir, exist_ok=True)
        with open(os.path.join(sdir, "transforms.json"), "w") as f:
            json.dump(transforms(cams), f, indent=1)
        seen = {}
        for k, (o, t, aim) in enumerate(cams):
            t0 = time.time()
            sc = relight_scene if split == "relight" else scene
            seed = 1000 * ["train", "val", "relight"].index(split) + k
            img = mi.render(sc, sensor=mi.load_dict(sensor(o, t, a.spp, seed)))
            write_exr(os.path.join(sdir, "Image", f"{k:03d}_0001.exr"), np.array(img))
            if split != "relight":
                maps, idx = gt_maps(scene, index, objs, o, t)
                for kind, arr in maps.items():
                    name = f"{k:03d}.exr" if kind == "albedo" else f"{k:03d}_0001.exr"
                    write_exr(os.path.join(sdir, kind, name), arr)
                for i in np.unique(idx[idx >= 0]):
                    seen.setdefault(objs[i][0], []).append([k, int((idx == i).sum())])
            log["render"].setdefault(split, []).append({"view": k, "aim": aim, "seconds": round(time.time() - t0, 2)})
            print(f"{split} {k:03d} {time.time() - t0:.1f}s aim {aim}", flush=True)
        log.setdefault("pixels_per_object", {})[split] = seen
    with open(os.path.join(a.out, "relight", "light.json"), "w") as f:
        json.dump({"type": "sphere", "center": centre, "radius": radius, "radiance": power,
                   "original_emitters": "OFF: the scene's lights emit nothing in relight/Image; its geometry stays, black",
                   "cameras": "relight/transforms.json (= val/transforms.json)"}, f, indent=1)
    if a.relight_only:
        return
    with open(os.path.join(a.out, "build_log.json"), "w") as f:
        json.dump(log, f, indent=1)


if __name__ == "__main__":
    main()
