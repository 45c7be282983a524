//! The radiance of lights that LDR views show only clipped.
//!
//! Off the lights, a rough surface's radiance is I(x) = kd(x) · (A(x) + Σ_e L_e · D_e(x)):
//! A is the light the surface receives from the rest of the scene (read from the views
//! themselves through a surface light field, the lights left out), D_e what light e would
//! give it at unit radiance (sampled on its triangles, with shadow rays). For one guess of the
//! radiances, kd(x) = I / (A + Σ L_e D_e) follows at every pixel; on a surface of one colour
//! it is flat only for the right guess, because D_e / A changes along it (nearer the light,
//! facing it, shadowed). The estimate is the guess that makes log kd flattest inside the
//! mesh's smooth patches (the least variance of log kd about each patch's mean), searched one
//! light at a time over a log grid. Its curve says how well the views pin it: a flat one
//! leaves the albedo prior in place, and the report says so.
//!
//! The variance reads what a wrong guess leaves across a whole patch: a halo around the light,
//! a wall darker on its far side. Differences between neighbouring samples (4 pixels apart),
//! the measure before 2026-12-07, see only the step of that gradient between two samples,
//! which the pixels' noise and a JPEG's blocks swamp: a light 10× off raised that cost by
//! 0.05–1.1 % on the phone copies, and nearly every clipped light fell to the prior.
use crate::capture::flagged;
use fipt_bake::slf::SlfBuilder;
use fipt_core::color::luminance;
use fipt_core::cube::Cube;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::rng::Pcg32;
use fipt_geom::{Geometry, TriangleSampler};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

/// Every STRIDE-th pixel in each direction is a sample.
const STRIDE: usize = 4;
/// Cosine directions per sample for A, points per light for D.
pub(crate) const GATHER: usize = 64;
const LIGHT_POINTS: usize = 64;
/// Guesses per light: a log grid from 1 to 10^DECADES clip levels.
const STEPS: usize = 61;
const DECADES: f32 = 3.0;
/// A curve whose cost at a tenth and at ten times the minimum rises by less than this share
/// does not pin the radiance.
const MIN_CONTRAST: f64 = 0.02;
/// Rounds of the coordinate descent over the lights, at most.
const MAX_ROUNDS: usize = 16;

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
    /// Whether the flatness curve pins it.
    pub pinned: bool,
    /// The range the views allow, in clip levels (luminance): at least the highest clip level
    /// of the views that see it clipped and what the surfaces it lights need to reflect no
    /// more than they receive ([`KD_MAX`]); at most what keeps them above [`KD_MIN`].
    pub range: [f32; 2],
    /// How the radiance was chosen: "flatness" (the curve pins it inside the range),
    /// "flatness, clamped to the range", "albedo" (the prior of [`KD_BRIGHT`], inside the
    /// range) or "lower bound" (no surface it lights bounds it: the clip bound).
    pub chosen_by: String,
}

/// No surface reflects more than this share of the light it receives…
pub const KD_MAX: f32 = 0.95;
/// …or less than this (black paint, dark fabric).
pub const KD_MIN: f32 = 0.02;
/// A light the flatness does not pin is set to its albedo lower bound × KD_MAX / KD_BRIGHT:
/// the radiance at which the surface bounding it would read this albedo if the light were all
/// it received (a room's brightest lit surface, a wall, a ceiling, white furniture, lies
/// between 0.65 and 0.95, and 0.8 is within ×1.2 of either end). Solving that surface for this
/// albedo with the room's light included brought two unpinned lights on clean HDR rooms within
/// 10 % (the studio's bulb) and 26 % (the atelier's lamp, blue) of the truth, but put the
/// studio's bulb ×2.4–3.1 high on its six LDR copies and gave clipped highlights taken for
/// lights 2–294 clip levels (docs/clipped-lights.md).
pub const KD_BRIGHT: f32 = 0.8;
/// The most one channel of an unpinned light may exceed another.
const MAX_TINT: f32 = 4.0;
/// Samples a patch needs to bound a light.
const MIN_PATCH_SAMPLES: usize = 10;
/// A patch whose kd quartiles lie further apart than this at every radiance of the search's
/// grid is not one diffuse colour (a mirror, a metal, a highlight): it neither bounds a light
/// nor enters the flatness cost. At the true radiances, the diffuse patches that bound lights
/// on five Mitsuba rooms lie within ×1.3 (a checkered floor ×2.1); the gallery's chrome
/// patch, ×18, set its spot's lower bound at 8× the truth (docs/clipped-lights.md).
pub const MAX_QUARTILE_RATIO: f32 = 4.0;

/// One sample: its pixel, patch, observed radiance, A and each light's D.
pub(crate) struct Sample {
    pub(crate) at: (usize, usize, usize),
    pub(crate) patch: u32,
    pub(crate) i: Vec3,
    pub(crate) a: Vec3,
    pub(crate) d: Vec<f32>,
}

/// Estimates each light's radiance; `lights` are groups of triangle ids, `skip[v][i]` the
/// pixels not to use (clipped, or on a light), `level` the clip level. Also returns the model
/// of the room's light the estimate measured against (A and each light's D anywhere), which
/// draws the maps at the ends of a light's range ([`crate::light_ends`]), and the surface
/// patches (and their samples) left out as not one diffuse colour ([`MAX_QUARTILE_RATIO`]).
pub fn estimate(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    lights: &[Vec<u32>],
    skip: &[Vec<bool>],
    level: f32,
    seen_clipped: &[f32],
) -> Option<(
    Vec<LightEstimate>,
    crate::light_ends::LightModel,
    [usize; 2],
)> {
    let hits = view_hits(geometry, views);
    let (samples, model) = samples_and_model(geometry, views, images, &hits, lights, skip, STRIDE)?;
    let before = samples.len();
    let (samples, mixed) = one_colour(samples, level);
    let mut out = search(&samples, lights, level, seen_clipped);
    bound_and_choose(&samples, &mut out, seen_clipped, level);
    Some((out, model, [mixed, before - samples.len()]))
}

/// What each view's pixels see.
pub(crate) fn view_hits(
    geometry: &Geometry,
    views: &[View],
) -> Vec<Vec<Option<fipt_shading::records::HitPoint>>> {
    views
        .par_iter()
        .map(|v| fipt_shading::records::hit_points(geometry, v))
        .collect()
}

/// The model of the room's light (A from the views' surface light field, each light's D) and
/// the samples measured against it, every `stride`-th pixel each way (none: None); `hits`:
/// what each view's pixels see.
pub(crate) fn samples_and_model(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    hits: &Hits,
    lights: &[Vec<u32>],
    skip: &[Vec<bool>],
    stride: usize,
) -> Option<(Vec<Sample>, crate::light_ends::LightModel)> {
    let mesh = &geometry.mesh;
    let is_light: std::collections::HashSet<u32> = lights.iter().flatten().copied().collect();
    let slf = surface_light_field(hits, images, &is_light, skip, |x| x)?;
    let side = light_sides(geometry, views, hits, &is_light);
    let samplers: Vec<TriangleSampler> = lights
        .iter()
        .map(|t| TriangleSampler::uniform_area(mesh, t))
        .collect::<Option<_>>()?;
    let (patch, _) = fipt_geom::patches::smooth_patches(mesh, 30.0);
    let fill = patch_means(hits, images, &is_light, skip, &patch);
    let model = crate::light_ends::LightModel {
        slf,
        fill,
        is_light,
        side,
        samplers,
    };
    let near_light = touching(mesh, &model.is_light);
    let at = Surfaces {
        geometry,
        model: &model,
        near_light: &near_light,
        patch: &patch,
    };
    let samples = at.samples(views, images, hits, skip, stride);
    (!samples.is_empty()).then_some((samples, model))
}

/// Per triangle, the mean radiance the views see on its smooth patch (`patch`: each
/// triangle's), lights and the pixels `skip` left out; zero where no view sees the patch.
/// [`gather`] reads it where the surface light field holds nothing near a point: most of a
/// ceiling no camera looks at is still the ceiling, where zero made the room's light on the
/// kitchen's walls 0.59–0.82 of the truth's (docs/clipped-lights.md).
fn patch_means(
    hits: &Hits,
    images: &[Image],
    is_light: &std::collections::HashSet<u32>,
    skip: &[Vec<bool>],
    patch: &[u32],
) -> Vec<Vec3> {
    let mut sums: HashMap<u32, (Vec3, u64)> = HashMap::new();
    for (v, hv) in hits.iter().enumerate() {
        for (i, h) in hv.iter().enumerate() {
            if let Some(h) = h.filter(|h| !is_light.contains(&h.tri()) && !flagged(skip, v, i)) {
                let e = sums.entry(patch[h.tri() as usize]).or_default();
                e.0 += images[v].data[i];
                e.1 += 1;
            }
        }
    }
    patch
        .iter()
        .map(|p| sums.get(p).map_or(Vec3::ZERO, |(s, n)| *s / *n as f32))
        .collect()
}

/// The surface light field of everything but the lights and the pixels `skip`, each pixel's
/// radiance through `f`.
pub(crate) fn surface_light_field(
    hits: &Hits,
    images: &[Image],
    is_light: &std::collections::HashSet<u32>,
    skip: &[Vec<bool>],
    f: impl Fn(Vec3) -> Vec3,
) -> Option<fipt_bake::slf::SurfaceLightField> {
    let cube = Cube::around(hits.iter().flatten().flatten().map(|h| h.p), 1.1)?;
    let mut slf = SlfBuilder::with_fallback(cube, 128, 3);
    for (v, hv) in hits.iter().enumerate() {
        for (i, h) in hv.iter().enumerate() {
            if let Some(h) = h.filter(|h| !is_light.contains(&h.tri()) && !flagged(skip, v, i)) {
                slf.add(h.p, f(images[v].data[i]));
            }
        }
    }
    Some(slf.finish())
}

/// What a sample is measured against: the scene, its lights and its patches.
struct Surfaces<'a> {
    geometry: &'a Geometry,
    model: &'a crate::light_ends::LightModel,
    /// Triangles that touch a light: a lamp's faces seen too rarely clipped to count as the
    /// light, which glow rather than reflect.
    near_light: &'a std::collections::HashSet<u32>,
    patch: &'a [u32],
}

pub(crate) type Hits = [Vec<Option<fipt_shading::records::HitPoint>>];

impl Surfaces<'_> {
    /// Every `stride`-th pixel of every view that sees a lit, unclipped surface off the lights.
    fn samples(
        &self,
        views: &[View],
        images: &[Image],
        hits: &Hits,
        skip: &[Vec<bool>],
        stride: usize,
    ) -> Vec<Sample> {
        views
            .par_iter()
            .enumerate()
            .flat_map_iter(|(v, view)| {
                let (w, h) = (view.camera.width, view.camera.height);
                let mut out = vec![];
                for y in (stride / 2..h).step_by(stride) {
                    for x in (stride / 2..w).step_by(stride) {
                        let i = y * w + x;
                        let Some(hit) = hits[v][i].filter(|h| {
                            !flagged(skip, v, i)
                                && !self.model.is_light.contains(&h.tri())
                                && !self.near_light.contains(&h.tri())
                        }) else {
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
        let (a, d) = self.model.parts(self.geometry, eye, hit);
        Sample {
            at,
            patch: self.patch[hit.tri() as usize],
            i: seen,
            a,
            d,
        }
    }
}

/// The triangles (not lights) with a corner at a light triangle's corner (positions to 0.1 mm).
fn touching(
    mesh: &fipt_geom::Mesh,
    is_light: &std::collections::HashSet<u32>,
) -> std::collections::HashSet<u32> {
    let key = |p: Vec3| {
        let q = (p * 1e4).round();
        (q.x as i64, q.y as i64, q.z as i64)
    };
    let corners: std::collections::HashSet<(i64, i64, i64)> = is_light
        .iter()
        .flat_map(|&t| mesh.triangles[t as usize].map(|v| key(mesh.positions[v as usize])))
        .collect();
    (0..mesh.triangles.len() as u32)
        .filter(|t| !is_light.contains(t))
        .filter(|&t| {
            mesh.triangles[t as usize]
                .iter()
                .any(|&v| corners.contains(&key(mesh.positions[v as usize])))
        })
        .collect()
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
        for h in hv.iter().flatten().filter(|h| is_light.contains(&h.tri())) {
            let front = mesh.face_normal(h.tri() as usize).dot(eye - h.p) > 0.0;
            let e = votes.entry(h.tri()).or_default();
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

/// A(x): the mean radiance the SLF gives over cosine-distributed directions (lights and
/// misses count 0); where the SLF holds nothing near a point (no view saw it, nor its
/// neighbourhood), the mean the views see on its smooth patch (`fill`, per triangle).
pub(crate) fn gather(
    geometry: &Geometry,
    slf: &fipt_bake::slf::SurfaceLightField,
    fill: &[Vec3],
    is_light: &std::collections::HashSet<u32>,
    o: Vec3,
    n: Vec3,
    rng: &mut Pcg32,
) -> Vec3 {
    gather_points(geometry, is_light, o, n, GATHER, rng)
        .into_iter()
        .map(|p| {
            p.map_or(Vec3::ZERO, |(p, tri)| {
                let v = slf.lookup(p);
                if v == Vec3::ZERO {
                    fill.get(tri as usize).copied().unwrap_or(Vec3::ZERO)
                } else {
                    v
                }
            })
        })
        .sum::<Vec3>()
        / GATHER as f32
}

/// The surface points `count` cosine directions from `o` meet, with their triangles (None: a
/// miss or a light); [`gather`] looks up [`GATHER`] of them.
pub(crate) fn gather_points(
    geometry: &Geometry,
    is_light: &std::collections::HashSet<u32>,
    o: Vec3,
    n: Vec3,
    count: usize,
    rng: &mut Pcg32,
) -> Vec<Option<(Vec3, u32)>> {
    let (t, b) = n.any_orthonormal_pair();
    (0..count)
        .map(|_| {
            let (u1, u2) = (rng.next_f32(), rng.next_f32());
            let r = u1.sqrt();
            let phi = std::f32::consts::TAU * u2;
            let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
            geometry
                .bvh
                .closest_hit(o, d, 0.0, f32::INFINITY)
                .filter(|h| !is_light.contains(&h.tri))
                .map(|h| (fipt_geom::hit_point(&geometry.mesh, &h), h.tri))
        })
        .collect()
}

/// D(x): the Lambertian shading (irradiance / π) a light of unit radiance gives at `o`, each
/// triangle emitting on the side(s) `side` says it was seen from.
pub(crate) fn direct(
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

/// The indices of the samples on each patch.
fn by_patch(samples: &[Sample]) -> HashMap<u32, Vec<usize>> {
    let mut by: HashMap<u32, Vec<usize>> = HashMap::new();
    for (k, s) in samples.iter().enumerate() {
        by.entry(s.patch).or_default().push(k);
    }
    by
}

/// The radiances the search tries: a log grid from `level` to 10^DECADES × `level`.
fn grid(level: f32) -> Vec<f32> {
    (0..STEPS)
        .map(|k| level * 10f32.powf(DECADES * k as f32 / (STEPS - 1) as f32))
        .collect()
}

/// `samples` without the patches that are not one diffuse colour ([`MAX_QUARTILE_RATIO`]):
/// a patch's kd (luminance) is read with every light at one radiance of the search's grid in
/// turn (from `level` up), and the patch is kept where its quartiles come within the ratio
/// at any of them. One radiance for all lights is a coarse guess, but a wrong guess spreads
/// a diffuse patch's kd only as far as its lights' shares change across it, while a mirror's
/// kd follows what it reflects at every guess.
/// Also returns how many patches it left out.
fn one_colour(samples: Vec<Sample>, level: f32) -> (Vec<Sample>, usize) {
    let by_patch = by_patch(&samples);
    let grid = grid(level);
    let mixed: std::collections::HashSet<u32> = by_patch
        .par_iter()
        .filter(|(_, idx)| idx.len() >= 4)
        .filter(|(_, idx)| {
            let one_colour_at = |g: f32| {
                let mut kd: Vec<f32> = idx
                    .iter()
                    .map(|&k| {
                        let s = &samples[k];
                        let shade = luminance(s.a) + g * s.d.iter().sum::<f32>();
                        luminance(s.i) / shade.max(1e-12)
                    })
                    .collect();
                kd.sort_unstable_by(f32::total_cmp);
                let q = |f: f32| kd[((kd.len() - 1) as f32 * f).round() as usize];
                q(0.75) <= MAX_QUARTILE_RATIO * q(0.25)
            };
            !grid.iter().any(|&g| one_colour_at(g))
        })
        .map(|(&p, _)| p)
        .collect();
    let kept = samples
        .into_iter()
        .filter(|s| !mixed.contains(&s.patch))
        .collect();
    (kept, mixed.len())
}

/// The samples of each patch that holds at least [`MIN_PATCH_SAMPLES`] of them, in patch order.
fn patch_groups(samples: &[Sample]) -> Vec<Vec<usize>> {
    let mut groups: Vec<(u32, Vec<usize>)> = (by_patch(samples).into_iter())
        .filter(|(_, g)| g.len() >= MIN_PATCH_SAMPLES)
        .collect();
    groups.sort_unstable_by_key(|g| g.0);
    groups.into_iter().map(|g| g.1).collect()
}

/// Each channel on its own: coordinate descent over the lights, each light's radiance on a
/// log grid, in rounds until no light moves ([`MAX_ROUNDS`] at most: two lights that share
/// a wall make a valley the descent crosses a step or two at a time). A light no dimmer
/// than `seen_clipped` (the clip level of the views that see it clipped) takes its best
/// value at or above that while the others are searched: a light the flatness would set
/// under its clip level would pull the lights it shares surfaces with off theirs.
fn search(
    samples: &[Sample],
    lights: &[Vec<u32>],
    level: f32,
    seen_clipped: &[f32],
) -> Vec<LightEstimate> {
    let groups = patch_groups(samples);
    let grid = grid(level);
    let tenth = ((STEPS - 1) as f32 / DECADES) as usize;
    let mut out: Vec<LightEstimate> = lights
        .iter()
        .map(|t| LightEstimate {
            triangles: t.len(),
            radiance: [0.0; 3],
            levels: 0.0,
            contrast: f64::INFINITY,
            pinned: true,
            range: [0.0, f32::INFINITY],
            chosen_by: "flatness".into(),
        })
        .collect();
    for c in 0..3 {
        let mut l = vec![grid[STEPS / 2]; lights.len()];
        let mut curves = vec![vec![]; lights.len()];
        for _ in 0..MAX_ROUNDS {
            let before = l.clone();
            for e in 0..lights.len() {
                let curve: Vec<f64> = grid
                    .par_iter()
                    .map(|&g| {
                        let mut t = l.clone();
                        t[e] = g;
                        cost(samples, &groups, c, &t)
                    })
                    .collect();
                let floor = seen_clipped.get(e).copied().unwrap_or(0.0);
                let best = (0..STEPS)
                    .filter(|&k| grid[k] >= floor)
                    .min_by(|&a, &b| curve[a].total_cmp(&curve[b]))
                    .unwrap_or(STEPS - 1);
                l[e] = grid[best];
                curves[e] = curve;
            }
            if l == before {
                break;
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

/// The spread of log kd in `channel` for radiances `l`: the variance of log kd about each
/// patch's mean, pooled over the patches (`groups`). A wrong guess leaves the shading's
/// gradients and shadow edges in kd; a texture adds the same spread at every guess.
fn cost(samples: &[Sample], groups: &[Vec<usize>], channel: usize, l: &[f32]) -> f64 {
    let log_kd = |s: &Sample| {
        let shade = s.a[channel] + s.d.iter().zip(l).map(|(d, l)| d * l).sum::<f32>();
        (s.i[channel] as f64 / shade.max(1e-12) as f64).ln()
    };
    let (mut spread, mut n) = (0.0f64, 0usize);
    for g in groups {
        let (mut k, mut sum, mut sq) = (0usize, 0.0f64, 0.0f64);
        for x in g
            .iter()
            .map(|&j| log_kd(&samples[j]))
            .filter(|x| x.is_finite())
        {
            k += 1;
            sum += x;
            sq += x * x;
        }
        if k >= MIN_PATCH_SAMPLES {
            spread += (sq - sum * sum / k as f64).max(0.0);
            n += k;
        }
    }
    spread / n.max(1) as f64
}

/// Each light's range from the bounds, and its radiance where the flatness does not pin it
/// (or pins it outside the range): the albedo prior [`KD_BRIGHT`] inside the range, the
/// lights set together (each one's share of a sample's light depends on the others').
fn bound_and_choose(
    samples: &[Sample],
    out: &mut [LightEstimate],
    seen_clipped: &[f32],
    level: f32,
) {
    let n = out.len();
    // Start from the flatness estimates where pinned, else the clip bound.
    let mut l: Vec<Vec3> = out
        .iter()
        .enumerate()
        .map(|(e, x)| {
            if x.pinned {
                Vec3::from_array(x.radiance)
            } else {
                Vec3::splat(seen_clipped.get(e).copied().unwrap_or(level).max(1e-6))
            }
        })
        .collect();
    let mut range = vec![[Vec3::ZERO, Vec3::splat(f32::INFINITY)]; n];
    let mut bounded = vec![false; n];
    for _ in 0..4 {
        for e in 0..n {
            let clip = Vec3::splat(seen_clipped.get(e).copied().unwrap_or(0.0));
            let (lo, hi) = albedo_bounds(samples, &l, e, level)
                .unwrap_or((Vec3::ZERO, Vec3::splat(f32::INFINITY)));
            bounded[e] = lo.cmpgt(Vec3::ZERO).any() || hi.is_finite();
            range[e] = [lo.max(clip), hi.max(lo.max(clip))];
            l[e] = if out[e].pinned {
                l[e].clamp(range[e][0], range[e][1])
            } else {
                bright_prior(lo, range[e])
            };
        }
    }
    for (e, x) in out.iter_mut().enumerate() {
        let chosen = Vec3::from_array(x.radiance);
        let inside = chosen.cmpge(range[e][0]).all() && chosen.cmple(range[e][1]).all();
        x.chosen_by = match (x.pinned, inside, bounded[e]) {
            (true, true, _) => "flatness",
            (true, false, _) => "flatness, clamped to the range",
            (false, _, true) => "albedo",
            (false, _, false) => "lower bound",
        }
        .into();
        x.radiance = l[e].to_array();
        x.levels = luminance(l[e]) / level;
        x.range = [
            luminance(range[e][0]) / level,
            luminance(range[e][1]) / level,
        ];
    }
}

/// The samples light `e` lights most strongly (the fifth with the highest D_e: a choice that
/// does not depend on the radiances being estimated), each with the shading everything else
/// gives it per channel at radiances `l`: (sample, others' shading).
fn lit_by<'a>(samples: &'a [Sample], l: &[Vec3], e: usize) -> Vec<(&'a Sample, Vec3)> {
    let mut d: Vec<f32> = samples
        .iter()
        .map(|s| s.d[e])
        .filter(|&d| d > 0.0)
        .collect();
    if d.is_empty() {
        return vec![];
    }
    let k = ((d.len() as f64 * 0.8) as usize).min(d.len() - 1);
    let cut = *d.select_nth_unstable_by(k, f32::total_cmp).1;
    samples
        .iter()
        .filter(|s| s.d[e] > 0.0 && s.d[e] >= cut)
        .map(|s| {
            let others = s.a
                + s.d
                    .iter()
                    .zip(l)
                    .enumerate()
                    .filter(|(j, _)| *j != e)
                    .map(|(_, (d, l))| *l * *d)
                    .sum::<Vec3>();
            (s, others)
        })
        .collect()
}

/// The strongly lit samples of light `e` grouped by smooth patch (patches of at least
/// [`MIN_PATCH_SAMPLES`]): a patch's median albedo is its colour, whatever highlight or
/// misregistered edge covers less than half of it.
fn lit_patches<'a>(samples: &'a [Sample], l: &[Vec3], e: usize) -> Vec<Vec<(&'a Sample, Vec3)>> {
    let mut by: std::collections::BTreeMap<u32, Vec<(&Sample, Vec3)>> = Default::default();
    for (s, o) in lit_by(samples, l, e) {
        by.entry(s.patch).or_default().push((s, o));
    }
    by.into_values()
        .filter(|p| p.len() >= MIN_PATCH_SAMPLES)
        .collect()
}

/// A patch's median albedo in channel `c` with light `e` at `x`.
fn patch_kd(p: &[(&Sample, Vec3)], e: usize, c: usize, x: f32) -> f32 {
    let mut kd: Vec<f32> = p
        .iter()
        .map(|(s, o)| s.i[c] / (o[c] + x * s.d[e]).max(1e-12))
        .collect();
    let m = kd.len() / 2;
    *kd.select_nth_unstable_by(m, f32::total_cmp).1
}

/// The radiance of light `e` in channel `c` at which `f` (falling as the light grows) equals
/// `target`, by bisection on a log scale over [lo, hi].
fn solve_falling(f: impl Fn(f32) -> f32, target: f32, lo: f32, hi: f32) -> f32 {
    let (mut a, mut b) = (lo.max(1e-6).ln(), hi.max(lo.max(1e-6)).ln());
    if f(a.exp()) <= target {
        return a.exp();
    }
    if f(b.exp()) >= target {
        return b.exp();
    }
    for _ in 0..40 {
        let m = 0.5 * (a + b);
        if f(m.exp()) > target {
            a = m
        } else {
            b = m
        }
    }
    (0.5 * (a + b)).exp()
}

/// Per channel, the range of light `e`'s radiance that keeps the median albedo of every patch
/// it lights strongly within [KD_MIN, KD_MAX], the other lights at `l` (elsewhere the others'
/// light hides it).
fn albedo_bounds(samples: &[Sample], l: &[Vec3], e: usize, level: f32) -> Option<(Vec3, Vec3)> {
    let patches = lit_patches(samples, l, e);
    if patches.is_empty() {
        return None;
    }
    // The search bracket, in clip levels: a light from a millionth to 10⁹ of them.
    let (a, b) = (1e-6 * level, 1e9 * level);
    let (mut lo, mut hi) = (Vec3::ZERO, Vec3::splat(f32::INFINITY));
    for c in 0..3 {
        for p in &patches {
            let f = |x: f32| patch_kd(p, e, c, x);
            // At least what brings the patch down to KD_MAX, where some radiance does (a
            // patch no radiance brings under it glows: a screen, a light not found, and
            // bounds nothing); at most what keeps it at KD_MIN, where the others' light alone
            // leaves it above.
            if f(0.0) > KD_MAX && f(b) <= KD_MAX {
                lo[c] = lo[c].max(solve_falling(f, KD_MAX, a, b));
            }
            if f(a) >= KD_MIN && f(b) < KD_MIN {
                hi[c] = hi[c].min(solve_falling(f, KD_MIN, a, b));
            }
        }
    }
    Some((lo, hi))
}

/// Light `e`'s radiance where the views do not pin it: per channel, its albedo lower bound
/// (the brightest surface it lights strongly at [`KD_MAX`]) scaled so that surface reads
/// [`KD_BRIGHT`] instead, inside `range` (the clip bound may be higher); no channel under a
/// [`MAX_TINT`]th of the brightest (lights are white to warm or cool, not one primary: a
/// channel that rises alone is a coloured surface's clipping). Scaling the bound, rather
/// than solving that surface for KD_BRIGHT, keeps the choice where the light's own share of
/// the surface's light is small (there, a small change of albedo asks a large one of it).
fn bright_prior(albedo_lo: Vec3, range: [Vec3; 2]) -> Vec3 {
    let x = (albedo_lo * (KD_MAX / KD_BRIGHT)).clamp(range[0], range[1]);
    x.max(Vec3::splat(x.max_element() / MAX_TINT)).min(range[1])
}

mod truth;
pub use truth::{shading_at_radiances, SampleShading};

#[cfg(test)]
mod tests;
