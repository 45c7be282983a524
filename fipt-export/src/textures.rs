//! Material textures of an atlas: base colour, roughness and metallic at every texel centre
//! a chart's triangle covers, queried from a [`SurfaceModel`], then dilated into the gutters.
use crate::atlas::{Atlas, PAD};
use fipt_core::color::Rgb;
use fipt_core::reflectance::base_color;
use fipt_geom::Mesh;
use fipt_shading::scene::SurfaceModel;
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Linear-valued texture planes of one atlas (row-major, `width` × `height`).
#[derive(Clone, Debug)]
pub struct MaterialTextures {
    pub width: u32,
    pub height: u32,
    pub base_color: Vec<Rgb>,
    pub roughness: Vec<f32>,
    pub metallic: Vec<f32>,
    /// Texels whose centre lies on a triangle (the rest are dilated gutter or empty).
    pub covered: Vec<bool>,
}

fn inside(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> bool {
    let e = |o: Vec2, d: Vec2| (d - o).perp_dot(p - o);
    let (w0, w1, w2) = (e(b, c), e(c, a), e(a, b));
    let eps = -1e-4 * (b - a).perp_dot(c - a).abs();
    (w0 >= eps && w1 >= eps && w2 >= eps) || (w0 <= -eps && w1 <= -eps && w2 <= -eps)
}

/// The point of triangle (a, b, c) nearest `p` (2-D).
fn nearest_on_triangle(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> Vec2 {
    if inside(p, a, b, c) {
        return p;
    }
    let on_segment = |s: Vec2, e: Vec2| {
        let d = e - s;
        let t = if d.length_squared() > 0.0 {
            ((p - s).dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        s + d * t
    };
    [on_segment(a, b), on_segment(b, c), on_segment(c, a)]
        .into_iter()
        .min_by(|x, y| x.distance_squared(p).total_cmp(&y.distance_squared(p)))
        .unwrap_or(a)
}

/// Every texel of chart `c`'s rectangle: (texel index, triangle, world point). Texels whose
/// centre lies on a triangle take that point; the others (edges, gutter, triangles smaller
/// than a texel) the nearest point of the chart's surface, so no texel a lookup can reach is
/// left empty.
fn chart_texels(mesh: &Mesh, atlas: &Atlas, c: usize) -> Vec<(usize, u32, Vec3)> {
    let ch = &atlas.charts[c];
    let [x0, y0] = ch.texel;
    let [w, h] = ch.size;
    let mut slot: Vec<Option<(u32, Vec3)>> = vec![None; (w * h) as usize];
    let tris: Vec<(u32, [Vec2; 3])> = ch
        .triangles
        .iter()
        .map(|&t| {
            (
                t,
                mesh.vertices(t as usize).map(|p| atlas.texel_coords(c, p)),
            )
        })
        .collect();
    for &(t, [a, b, d]) in &tris {
        let lo = a.min(b).min(d).floor().max(Vec2::new(x0 as f32, y0 as f32));
        let hi = a.max(b).max(d).ceil();
        for y in lo.y as u32..(hi.y as u32).min(y0 + h) {
            for x in lo.x as u32..(hi.x as u32).min(x0 + w) {
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                if inside(q, a, b, d) {
                    slot[((y - y0) * w + x - x0) as usize] = Some((t, atlas.texel_point(c, x, y)));
                }
            }
        }
    }
    let mut out = Vec::with_capacity(slot.len());
    for (i, s) in slot.into_iter().enumerate() {
        let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
        let (t, p) = s.unwrap_or_else(|| {
            let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let (t, n) = tris
                .iter()
                .map(|&(t, [a, b, d])| (t, nearest_on_triangle(q, a, b, d)))
                .min_by(|u, v| u.1.distance_squared(q).total_cmp(&v.1.distance_squared(q)))
                .expect("a chart has triangles");
            (t, atlas.point_at(c, n))
        });
        if x < atlas.width && y < atlas.height {
            out.push(((y * atlas.width + x) as usize, t, p));
        }
    }
    out
}

impl MaterialTextures {
    /// Bakes the textures of `atlas` of `mesh` from `surfaces`.
    pub fn bake<S: SurfaceModel>(mesh: &Mesh, atlas: &Atlas, surfaces: &S) -> Self {
        let n = (atlas.width * atlas.height) as usize;
        let mut tex = MaterialTextures {
            width: atlas.width,
            height: atlas.height,
            base_color: vec![Vec3::ZERO; n],
            roughness: vec![0.0; n],
            metallic: vec![0.0; n],
            covered: vec![false; n],
        };
        let texels: Vec<Vec<(usize, Rgb, f32, f32)>> = (0..atlas.charts.len())
            .into_par_iter()
            .map(|c| {
                chart_texels(mesh, atlas, c)
                    .into_iter()
                    .map(|(i, t, p)| {
                        let sp = surfaces.surface(t, p);
                        let m = sp.metallic.clamp(0.0, 1.0);
                        let a = base_color(sp.kd, sp.ks, m).clamp(Vec3::ZERO, Vec3::ONE);
                        (i, a, sp.roughness, m)
                    })
                    .collect()
            })
            .collect();
        for (i, a, r, m) in texels.into_iter().flatten() {
            tex.base_color[i] = a;
            tex.roughness[i] = r;
            tex.metallic[i] = m;
            tex.covered[i] = true;
        }
        tex.dilate(PAD + 1);
        tex
    }

    /// Fills empty texels next to filled ones with their neighbours' mean, `passes` times.
    fn dilate(&mut self, passes: u32) {
        let (w, h) = (self.width as i64, self.height as i64);
        let mut filled = self.covered.clone();
        for _ in 0..passes {
            let mut next = Vec::new();
            for y in 0..h {
                for x in 0..w {
                    let i = (y * w + x) as usize;
                    if filled[i] {
                        continue;
                    }
                    let (mut a, mut r, mut m, mut k) = (Vec3::ZERO, 0.0, 0.0, 0.0f32);
                    for (dx, dy) in [
                        (-1, 0),
                        (1, 0),
                        (0, -1),
                        (0, 1),
                        (-1, -1),
                        (1, 1),
                        (-1, 1),
                        (1, -1),
                    ] {
                        let (nx, ny) = (x + dx, y + dy);
                        if nx < 0 || ny < 0 || nx >= w || ny >= h {
                            continue;
                        }
                        let j = (ny * w + nx) as usize;
                        if filled[j] {
                            a += self.base_color[j];
                            r += self.roughness[j];
                            m += self.metallic[j];
                            k += 1.0;
                        }
                    }
                    if k > 0.0 {
                        next.push((i, a / k, r / k, m / k));
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            for (i, a, r, m) in next {
                self.base_color[i] = a;
                self.roughness[i] = r;
                self.metallic[i] = m;
                filled[i] = true;
            }
        }
    }

    /// Base colour as 8-bit sRGB (glTF's `baseColorTexture` encoding).
    pub fn base_color_srgb8(&self) -> image::RgbImage {
        let px: Vec<u8> = self
            .base_color
            .iter()
            .flat_map(|c| {
                c.to_array()
                    .map(|v| to8(fipt_core::color::srgb_oetf(v.clamp(0.0, 1.0))))
            })
            .collect();
        image::RgbImage::from_raw(self.width, self.height, px).expect("sized")
    }

    /// glTF's `metallicRoughnessTexture`: roughness in G, metallic in B (linear 8-bit).
    pub fn metallic_roughness8(&self) -> image::RgbImage {
        let px: Vec<u8> = self
            .roughness
            .iter()
            .zip(&self.metallic)
            .flat_map(|(&r, &m)| [0, to8(r), to8(m)])
            .collect();
        image::RgbImage::from_raw(self.width, self.height, px).expect("sized")
    }

    /// One channel as an 8-bit grey image (linear).
    pub fn grey8(values: &[f32], width: u32, height: u32) -> image::GrayImage {
        image::GrayImage::from_raw(width, height, values.iter().map(|&v| to8(v)).collect())
            .expect("sized")
    }
}

fn to8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}
