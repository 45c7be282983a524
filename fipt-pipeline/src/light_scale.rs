//! The radiance of lights that LDR views show only clipped.
//!
//! Off the lights, a rough surface's radiance is I(x) = kd(x) · (A(x) + Σ_e L_e · D_e(x)):
//! A is the light the surface receives from the rest of the scene (read from the views
//! themselves through a surface light field, the lights left out), D_e what light e would
//! give it at unit radiance (sampled on its triangles, with shadow rays). For one guess of the
//! radiances, kd(x) = I / (A + Σ L_e D_e) follows at every pixel; on a surface of one colour
//! it is flat only for the right guess, because D_e / A changes along it (nearer the light,
//! facing it, shadowed). The estimate is the guess that makes log kd flattest inside the
//! mesh's smooth patches, searched one light at a time over a log grid. Its curve says how
//! well the views pin it: a flat one leaves the convention in place, and the report says so.
use fipt_bake::slf::SlfBuilder;
use fipt_core::color::luminance;
use fipt_core::cube::Cube;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::rng::Pcg32;
use fipt_geom::{offset_ray_origin, Geometry, TriangleSampler};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

/// Every STRIDE-th pixel in each direction is a sample.
const STRIDE: usize = 4;
/// Cosine directions per sample for A, points per light for D.
const GATHER: usize = 64;
const LIGHT_POINTS: usize = 64;
/// Guesses per light: a log grid from 1 to 10^DECADES clip levels.
const STEPS: usize = 61;
const DECADES: f32 = 3.0;
/// A curve whose cost at a tenth and at ten times the minimum rises by less than this share
/// does not pin the radiance.
const MIN_CONTRAST: f64 = 0.02;

/// What the estimate found for one light.
#[derive(Clone, Debug, Serialize)]
pub struct LightEstimate {
    pub triangles: usize,
    /// Radiance per channel (at the views' scale after their gains), and its luminance in
    /// clip levels.
    pub radiance: [f32; 3],
    pub levels: f32,
    /// The least rise of the channels' costs at a tenth and at ten times the radiance.
    pub contrast: f64,
    /// Whether the curve pins it (else the convention stays).
    pub pinned: bool,
}

/// One sample: its pixel, patch, observed radiance, A and each light's D.
struct Sample {
    at: (usize, usize, usize),
    patch: u32,
    i: Vec3,
    a: Vec3,
    d: Vec<f32>,
}

/// Estimates each light's radiance; `lights` are groups of triangle ids, `skip[v][i]` the
/// pixels not to use (clipped, or on a light), `level` the clip level.
pub fn estimate(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    lights: &[Vec<u32>],
    skip: &[Vec<bool>],
    level: f32,
) -> Option<Vec<LightEstimate>> {
    let mesh = &geometry.mesh;
    let is_light: std::collections::HashSet<u32> = lights.iter().flatten().copied().collect();
    let hits: Vec<Vec<Option<fipt_shading::records::HitPoint>>> = views
        .par_iter()
        .map(|v| fipt_shading::records::hit_points(geometry, v))
        .collect();
    // The surface light field of everything but the lights.
    let cube = Cube::around(hits.iter().flatten().flatten().map(|h| h.p), 1.1)?;
    let mut slf = SlfBuilder::with_fallback(cube, 128, 3);
    for (v, hv) in hits.iter().enumerate() {
        for (i, h) in hv.iter().enumerate() {
            if let Some(h) = h.filter(|h| !is_light.contains(&h.tri) && !skip[v][i]) {
                slf.add(h.p, images[v].data[i]);
            }
        }
    }
    let slf = slf.finish();
    let side = light_sides(geometry, views, &hits, &is_light);
    let samplers: Vec<TriangleSampler> = lights
        .iter()
        .map(|t| TriangleSampler::uniform_area(mesh, t))
        .collect::<Option<_>>()?;
    let (patch, _) = fipt_geom::patches::smooth_patches(mesh, 30.0);
    let at = Surfaces {
        geometry,
        slf: &slf,
        is_light: &is_light,
        side: &side,
        samplers: &samplers,
        patch: &patch,
    };
    let samples = at.samples(views, images, &hits, skip);
    if samples.is_empty() {
        return None;
    }
    Some(search(&samples, lights, level))
}

/// What a sample is measured against: the scene, its lights and its patches.
struct Surfaces<'a> {
    geometry: &'a Geometry,
    slf: &'a fipt_bake::slf::SurfaceLightField,
    is_light: &'a std::collections::HashSet<u32>,
    side: &'a HashMap<u32, f32>,
    samplers: &'a [TriangleSampler],
    patch: &'a [u32],
}

type Hits = [Vec<Option<fipt_shading::records::HitPoint>>];

impl Surfaces<'_> {
    /// Every STRIDE-th pixel of every view that sees a lit, unclipped surface off the lights.
    fn samples(
        &self,
        views: &[View],
        images: &[Image],
        hits: &Hits,
        skip: &[Vec<bool>],
    ) -> Vec<Sample> {
        views
            .par_iter()
            .enumerate()
            .flat_map_iter(|(v, view)| {
                let (w, h) = (view.camera.width, view.camera.height);
                let mut out = vec![];
                for y in (STRIDE / 2..h).step_by(STRIDE) {
                    for x in (STRIDE / 2..w).step_by(STRIDE) {
                        let i = y * w + x;
                        let Some(hit) =
                            hits[v][i].filter(|h| !skip[v][i] && !self.is_light.contains(&h.tri))
                        else {
                            continue;
                        };
                        let seen = images[v].data[i];
                        if seen.min_element() > 0.0 {
                            out.push(self.sample((v, x, y), view.camera.origin, hit, seen));
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// The sample of pixel `at` that sees `hit` from `eye` with radiance `seen`.
    fn sample(
        &self,
        at: (usize, usize, usize),
        eye: Vec3,
        hit: fipt_shading::records::HitPoint,
        seen: Vec3,
    ) -> Sample {
        let mut n = self.geometry.mesh.face_normal(hit.tri as usize);
        if n.dot(eye - hit.p) < 0.0 {
            n = -n;
        }
        // The same random numbers at every pixel: A and D vary smoothly along a surface (their
        // noise does not pass for texture), but for shadows.
        let mut rng = Pcg32::from_keys(&[0x11a7]);
        let o = offset_ray_origin(hit.p, n);
        let a = gather(self.geometry, self.slf, self.is_light, o, n, &mut rng);
        let d = self
            .samplers
            .iter()
            .map(|s| direct(self.geometry, s, self.side, o, n, &mut rng))
            .collect();
        Sample {
            at,
            patch: self.patch[hit.tri as usize],
            i: seen,
            a,
            d,
        }
    }
}

/// The side each light triangle was seen from (+1 its winding's, −1 the other, 0 both).
fn light_sides(
    geometry: &Geometry,
    views: &[View],
    hits: &Hits,
    is_light: &std::collections::HashSet<u32>,
) -> HashMap<u32, f32> {
    let mesh = &geometry.mesh;
    let mut votes: HashMap<u32, (u32, u32)> = HashMap::new();
    for (v, hv) in hits.iter().enumerate() {
        let eye = views[v].camera.origin;
        for h in hv.iter().flatten().filter(|h| is_light.contains(&h.tri)) {
            let front = mesh.face_normal(h.tri as usize).dot(eye - h.p) > 0.0;
            let e = votes.entry(h.tri).or_default();
            if front {
                e.0 += 1
            } else {
                e.1 += 1
            }
        }
    }
    votes
        .into_iter()
        .map(|(t, (f, b))| {
            (
                t,
                if b * 10 < f {
                    1.0
                } else if f * 10 < b {
                    -1.0
                } else {
                    0.0
                },
            )
        })
        .collect()
}

/// A(x): the mean radiance the SLF gives over cosine-distributed directions (lights count 0).
fn gather(
    geometry: &Geometry,
    slf: &fipt_bake::slf::SurfaceLightField,
    is_light: &std::collections::HashSet<u32>,
    o: Vec3,
    n: Vec3,
    rng: &mut Pcg32,
) -> Vec3 {
    let (t, b) = n.any_orthonormal_pair();
    let mut sum = Vec3::ZERO;
    for _ in 0..GATHER {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        let r = u1.sqrt();
        let phi = std::f32::consts::TAU * u2;
        let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
        if let Some(h) = geometry.bvh.closest_hit(o, d, 0.0, f32::INFINITY) {
            if !is_light.contains(&h.tri) {
                let p = fipt_geom::hit_point(&geometry.mesh, &h);
                sum += slf.lookup(p);
            }
        }
    }
    sum / GATHER as f32
}

/// D(x): the Lambertian shading (irradiance / π) a light of unit radiance gives at `o`, each
/// triangle emitting on the side(s) `side` says it was seen from.
fn direct(
    geometry: &Geometry,
    s: &TriangleSampler,
    side: &HashMap<u32, f32>,
    o: Vec3,
    n: Vec3,
    rng: &mut Pcg32,
) -> f32 {
    let mut sum = 0.0;
    for _ in 0..LIGHT_POINTS {
        let q = s.sample(&geometry.mesh, rng.next_f32(), rng.next_2d());
        let to = q.p - o;
        let d2 = to.length_squared();
        if d2 <= 1e-10 {
            continue;
        }
        let dir = to / d2.sqrt();
        let facing = -q.n.dot(dir) * side.get(&q.tri).copied().unwrap_or(0.0);
        let cos_l = if facing == 0.0 {
            q.n.dot(dir).abs()
        } else {
            facing
        };
        let cos_x = n.dot(dir);
        if cos_x <= 0.0 || cos_l <= 0.0 || geometry.bvh.occluded(o, dir, d2.sqrt() * (1.0 - 1e-3)) {
            continue;
        }
        sum += cos_x * cos_l / (d2 * q.pdf_area);
    }
    sum / (LIGHT_POINTS as f32 * std::f32::consts::PI)
}

/// Pairs of samples one stride apart in a view (right and down) on the same patch.
fn neighbours(samples: &[Sample]) -> Vec<(usize, usize)> {
    let index: HashMap<(usize, usize, usize), usize> =
        samples.iter().enumerate().map(|(k, s)| (s.at, k)).collect();
    let mut pairs = vec![];
    for (k, s) in samples.iter().enumerate() {
        let (v, x, y) = s.at;
        for next in [(v, x + STRIDE, y), (v, x, y + STRIDE)] {
            if let Some(&j) = index.get(&next) {
                if samples[j].patch == s.patch {
                    pairs.push((k, j));
                }
            }
        }
    }
    pairs
}

/// Each channel on its own: coordinate descent over the lights, each light's radiance on a
/// log grid, three rounds.
fn search(samples: &[Sample], lights: &[Vec<u32>], level: f32) -> Vec<LightEstimate> {
    let pairs = neighbours(samples);
    let grid: Vec<f32> = (0..STEPS)
        .map(|k| level * 10f32.powf(DECADES * k as f32 / (STEPS - 1) as f32))
        .collect();
    let tenth = ((STEPS - 1) as f32 / DECADES) as usize;
    let mut out: Vec<LightEstimate> = lights
        .iter()
        .map(|t| LightEstimate {
            triangles: t.len(),
            radiance: [0.0; 3],
            levels: 0.0,
            contrast: f64::INFINITY,
            pinned: true,
        })
        .collect();
    for c in 0..3 {
        let mut l = vec![grid[STEPS / 2]; lights.len()];
        let mut curves = vec![vec![]; lights.len()];
        for _ in 0..3 {
            for e in 0..lights.len() {
                let curve: Vec<f64> = grid
                    .par_iter()
                    .map(|&g| {
                        let mut t = l.clone();
                        t[e] = g;
                        cost(samples, &pairs, c, &t)
                    })
                    .collect();
                let best = (0..STEPS)
                    .min_by(|&a, &b| curve[a].total_cmp(&curve[b]))
                    .unwrap_or(0);
                l[e] = grid[best];
                curves[e] = curve;
            }
        }
        for (e, est) in out.iter_mut().enumerate() {
            let cv = &curves[e];
            let best = (0..STEPS)
                .min_by(|&a, &b| cv[a].total_cmp(&cv[b]))
                .unwrap_or(0);
            let at = |k: isize| cv[k.clamp(0, STEPS as isize - 1) as usize];
            let rise = (at(best as isize - tenth as isize).min(at((best + tenth) as isize))
                / cv[best].max(1e-12))
                - 1.0;
            est.radiance[c] = l[e];
            est.contrast = est.contrast.min(rise);
            est.pinned &= rise >= MIN_CONTRAST && best > 0 && best + 1 < STEPS;
        }
    }
    for est in &mut out {
        est.levels = luminance(Vec3::from_array(est.radiance)) / level;
    }
    out
}

/// The total variation of log kd in `channel` for radiances `l`: the mean |Δ log kd| between neighbouring
/// samples on one patch. Reflectance is piecewise constant (a texture's edges cost the same
/// at every guess); a wrong guess leaves the shading's gradients and shadow edges in kd.
fn cost(samples: &[Sample], pairs: &[(usize, usize)], channel: usize, l: &[f32]) -> f64 {
    let kd: Vec<f64> = samples
        .iter()
        .map(|s| {
            let shade = s.a[channel] + s.d.iter().zip(l).map(|(d, l)| d * l).sum::<f32>();
            (s.i[channel] as f64 / shade.max(1e-12) as f64).ln()
        })
        .collect();
    pairs
        .iter()
        .map(|&(a, b)| (kd[a] - kd[b]).abs())
        .sum::<f64>()
        / pairs.len().max(1) as f64
}
