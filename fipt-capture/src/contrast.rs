//! The tone curve's contrast from the light transport, where the views alone cannot give it.
//!
//! Without known exposures, a camera response h and the member h^γ of its family (the gains
//! raised with it) explain the same photos for every γ (`capture::response`): decoded radiance
//! is known only up to a power, x ↦ x^γ. The light transport is not: off the lights a rough
//! surface's radiance is I = kd · (A + Σ_e L_e D_e), where D_e (what light e gives at unit
//! radiance) is geometry and A (what the rest of the room gives) is read from the views. At the
//! wrong power the albedo I^γ / (A_γ + Σ L_e D_e) keeps a share of the light's fall-off: it
//! rises (γ too high) or falls (too low) where the surface is lit more. For each γ on a grid
//! the lights' radiances are searched to make kd flattest, and the curve of
//! the remaining spread of log kd inside the mesh's smooth patches (in the units of γ = 1, so
//! a texture's edges cost the same at every γ) says which power the light transport asks for.
use crate::light_scale::{self, Sample};
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_geom::Geometry;
use glam::Vec3;
use rayon::prelude::*;

/// The powers the curve is measured at, relative to the views as decoded: 0.5 … 1.5 in steps
/// of 0.05 (1.0 exactly among them).
pub const GAMMAS: [f32; 21] = {
    let mut g = [0f32; 21];
    let mut k = 0;
    while k < 21 {
        g[k] = (10 + k) as f32 / 20.0;
        k += 1;
    }
    g
};

/// Cosine directions per sample for A. Each sample's directions are the same ones (A's error
/// is then smooth along a surface, like light), and with 64 of them that error pulled the
/// estimate 0.1–0.2 above the truth on most copies (section 6 of docs/phone-captures.md).
const GATHER: usize = 512;

/// One point of the curve: the power and the pixel-weighted variance of log kd inside the
/// mesh's smooth patches with the lights at their best, in the units of γ = 1.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ContrastPoint {
    pub gamma: f32,
    pub variance: f64,
}

/// Samples for the curve: about this many, whatever the views' size.
const SAMPLES: usize = 60_000;
/// Patches with fewer samples are left out.
const MIN_PATCH: usize = 20;

/// The curve over [`GAMMAS`] for the views `images` as decoded (`hits`: what each pixel
/// sees), with the sources `lights` (triangle groups, their radiance searched at each γ) and
/// the pixels `skip` left out; `level` the clip level.
fn curve(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    hits: &light_scale::Hits,
    lights: &[Vec<u32>],
    skip: &[Vec<bool>],
    level: f32,
) -> Option<Probe> {
    // Without a source sampled on its area every light is read through the light field: the
    // curve then measures that field's noise (section 6 of docs/phone-captures.md).
    if lights.is_empty() {
        return None;
    }
    let pixels: usize = images.iter().map(|i| i.data.len()).sum();
    let stride = ((pixels as f64 / SAMPLES as f64).sqrt().ceil() as usize).max(4);
    let (samples, model) =
        light_scale::samples_and_model(geometry, views, images, hits, lights, skip, stride)?;
    // The surface light field of the views raised to each power, and each sample's A at
    // each: the directions traced once, every field read at each point they meet.
    let fields: Vec<fipt_bake::slf::SurfaceLightField> = GAMMAS
        .par_iter()
        .map(|&g| {
            light_scale::surface_light_field(hits, images, &model.is_light, skip, |x| {
                x.max(Vec3::ZERO).powf(g)
            })
        })
        .collect::<Option<_>>()?;
    // Each sample's A at each power, and whether the light field gives it any light along
    // the directions the clipped-light estimate reads (the first [`light_scale::GATHER`]).
    let ambient: Vec<([Vec3; GAMMAS.len()], bool)> = samples
        .par_iter()
        .map(|s| {
            let (v, x, y) = s.at;
            let hit = hits[v][y * views[v].camera.width + x].expect("a sample sees a surface");
            let points = model.gathered(geometry, views[v].camera.origin, hit, GATHER);
            let mut a = [Vec3::ZERO; GAMMAS.len()];
            let mut lit = false;
            for (k, p) in points.iter().enumerate() {
                let Some(p) = p else { continue };
                for (a, f) in a.iter_mut().zip(&fields) {
                    let r = f.lookup(*p);
                    lit |= k < light_scale::GATHER && r.max_element() > 0.0;
                    *a += r;
                }
            }
            (a.map(|a| a / points.len().max(1) as f32), lit)
        })
        .collect();
    drop(fields);
    // A sample the model gives no light at all (its gathered directions miss, meet lights or
    // meet what no view saw, and no light reaches it) says nothing of the contrast. Read from
    // the light field alone, not the patch means the clipped-light estimate falls back on:
    // the contrast is measured as before.
    let (samples, ambient): (Vec<Sample>, Vec<[Vec3; GAMMAS.len()]>) = samples
        .into_iter()
        .zip(ambient)
        .filter(|(s, (_, lit))| *lit || s.d.iter().any(|&d| d > 0.0))
        .map(|(s, (a, _))| (s, a))
        .unzip();
    let groups = PatchIndex::of(&samples);
    if groups.count == 0 {
        return None;
    }
    let point = |k: usize| -> ContrastPoint {
        let g = GAMMAS[k];
        let at: Vec<Sample> = samples
            .par_iter()
            .zip(&ambient)
            .map(|(s, a)| Sample {
                at: s.at,
                patch: s.patch,
                i: s.i.powf(g),
                a: a[k],
                d: s.d.clone(),
            })
            .collect();
        let v: f64 = (0..3)
            .into_par_iter()
            .map(|c| best_variance(&at, &groups, lights.len(), c, level.powf(g)))
            // Summed in order: the same bits at every run (the views are raised by the result).
            .collect::<Vec<f64>>()
            .into_iter()
            .sum::<f64>()
            / 3.0;
        ContrastPoint {
            gamma: g,
            variance: v / (g as f64 * g as f64),
        }
    };
    Some(Probe {
        curve: (0..GAMMAS.len()).map(point).collect(),
        sources: lights.len(),
        samples: samples.len(),
    })
}

/// A contrast curve and what it was measured on.
#[derive(Clone, Debug)]
pub struct Probe {
    pub curve: Vec<ContrastPoint>,
    /// Lights and bright surfaces sampled on their area, and surface samples.
    pub sources: usize,
    pub samples: usize,
}

/// The index of the curve's lowest point.
fn lowest(curve: &[ContrastPoint]) -> usize {
    (0..curve.len())
        .min_by(|&a, &b| curve[a].variance.total_cmp(&curve[b].variance))
        .unwrap_or(0)
}

/// A channel under this share of the samples' median luminance is left out: its log is
/// noise and quantisation (the red of a green wall, a black object).
const DARK: f32 = 0.1;

/// Each sample's patch as a dense index, for patches of [`MIN_PATCH`] samples or more, and
/// its channels too dark to use ([`DARK`]).
struct PatchIndex {
    of: Vec<Option<usize>>,
    count: usize,
    dark: Vec<[bool; 3]>,
}

impl PatchIndex {
    fn of(samples: &[Sample]) -> Self {
        let mut n: std::collections::HashMap<u32, usize> = Default::default();
        for s in samples {
            *n.entry(s.patch).or_default() += 1;
        }
        let mut dense: std::collections::HashMap<u32, usize> = Default::default();
        let mut keys: Vec<u32> = n
            .iter()
            .filter(|(_, &c)| c >= MIN_PATCH)
            .map(|(&p, _)| p)
            .collect();
        keys.sort_unstable();
        for (k, p) in keys.iter().enumerate() {
            dense.insert(*p, k);
        }
        let mut y: Vec<f32> = samples
            .iter()
            .map(|s| fipt_core::color::luminance(s.i))
            .collect();
        let m = y.len() / 2;
        let median = if y.is_empty() {
            0.0
        } else {
            *y.select_nth_unstable_by(m, f32::total_cmp).1
        };
        Self {
            of: samples
                .iter()
                .map(|s| dense.get(&s.patch).copied())
                .collect(),
            count: keys.len(),
            dark: samples
                .iter()
                .map(|s| s.i.to_array().map(|x| x < DARK * median))
                .collect(),
        }
    }
}

/// Guesses per light: a log grid over [`DECADES`] decades from a hundredth of the clip level
/// (a bright source the views do not clip may lie under it).
const STEPS: usize = 21;
const DECADES: f32 = 5.0;

/// The least patch variance of log kd in `channel` over the lights' radiances: coordinate
/// descent on a log grid, two rounds, then each light refined between its grid neighbours.
fn best_variance(
    samples: &[Sample],
    groups: &PatchIndex,
    lights: usize,
    c: usize,
    level: f32,
) -> f64 {
    let step = DECADES / (STEPS - 1) as f32;
    let at = |k: f32| level * 0.01 * 10f32.powf(step * k);
    let mut k = vec![(STEPS / 2) as f32; lights];
    let cost = |k: &[f32]| {
        variance(
            samples,
            groups,
            c,
            &k.iter().map(|&k| at(k)).collect::<Vec<_>>(),
        )
    };
    let mut best = cost(&k);
    for _ in 0..2 {
        for e in 0..lights {
            for x in 0..STEPS {
                let mut t = k.clone();
                t[e] = x as f32;
                let v = cost(&t);
                if v < best {
                    best = v;
                    k = t;
                }
            }
        }
    }
    // Golden-section search within one grid step either side.
    let r = 0.5 * (5f32.sqrt() - 1.0);
    for e in 0..lights {
        let (mut a, mut b) = (k[e] - 1.0, k[e] + 1.0);
        for _ in 0..12 {
            let (x1, x2) = (b - r * (b - a), a + r * (b - a));
            let mut t1 = k.clone();
            t1[e] = x1;
            let mut t2 = k.clone();
            t2[e] = x2;
            if cost(&t1) < cost(&t2) {
                b = x2;
            } else {
                a = x1;
            }
        }
        let mut t = k.clone();
        t[e] = 0.5 * (a + b);
        let v = cost(&t);
        if v < best {
            best = v;
            k = t;
        }
    }
    best
}

/// The pixel-weighted mean over patches of the variance of log kd in channel `c` with the
/// lights at `l`.
fn variance(samples: &[Sample], groups: &PatchIndex, c: usize, l: &[f32]) -> f64 {
    let mut sums = vec![[0f64; 3]; groups.count];
    for ((s, g), dark) in samples.iter().zip(&groups.of).zip(&groups.dark) {
        let Some(g) = g.filter(|_| !dark[c]) else {
            continue;
        };
        let shade = s.a[c] + s.d.iter().zip(l).map(|(d, l)| d * l).sum::<f32>();
        let kd = (s.i[c] as f64 / shade.max(1e-12) as f64).ln();
        let e = &mut sums[g];
        e[0] += 1.0;
        e[1] += kd;
        e[2] += kd * kd;
    }
    let (num, den) = sums.iter().fold((0.0, 0.0), |(a, b), [n, x, xx]| {
        (a + xx - x * x / n.max(1.0), b + n)
    });
    num / f64::max(den, 1.0)
}

/// The contrast curve of a loaded capture: its clipped lights and its brightest surfaces (see
/// [`bright_sources`]) searched as lights, its clipped pixels and those its `masks` leave out
/// not used.
pub fn probe(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    masks: &[Option<Vec<bool>>],
    report: &crate::capture::CaptureReport,
) -> Option<Probe> {
    let clipped_px: Vec<Vec<bool>> = (0..images.len())
        .map(|k| match report.clipped.get(k) {
            Some(c) if !c.is_empty() => c.clone(),
            _ => vec![false; images[k].data.len()],
        })
        .collect();
    // Clipped or masked (people, screens: `fit_gains` and the response leave them out too).
    let skip: Vec<Vec<bool>> = clipped_px
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let keep = masks.get(k).and_then(|m| m.as_ref());
            c.iter()
                .enumerate()
                .map(|(i, &c)| c || keep.is_some_and(|m| !m[i]))
                .collect()
        })
        .collect();
    let hits: Vec<Vec<Option<fipt_shading::records::HitPoint>>> = views
        .par_iter()
        .map(|v| fipt_shading::records::hit_points(geometry, v))
        .collect();
    let clipped = if report.clipped.is_empty() {
        vec![]
    } else {
        let triangles: Vec<Vec<Option<u32>>> = hits
            .iter()
            .map(|hv| hv.iter().map(|h| h.map(|h| h.tri())).collect())
            .collect();
        crate::capture::clipped::lights_seen(&geometry.mesh, &triangles, &report.clipped)
    };
    let lights = bright_sources(&geometry.mesh, &hits, images, &clipped_px, &skip, clipped);
    let level = report.clip_level.unwrap_or(1.0);
    curve(geometry, views, images, &hits, &lights, &skip, level)
}

/// A surface whose median pixel is this many times the views' median is a source whose
/// light is sampled on its area (read through the surface light field, a small bright source
/// is hit by a few of the gathered directions or none, and that noise is not the contrast's).
const BRIGHT: f32 = 8.0;
/// At most this many sources, the clipped lights among them: those that send the views the
/// most light (a clipped pixel counted at the brightest unclipped one).
const MAX_SOURCES: usize = 8;

/// The lights `clipped` and the connected pieces of triangles whose median pixel is
/// [`BRIGHT`] times the views' median or clipped (`clipped_px`), seen by 16 pixels or more
/// (the pixels `skip` that are not clipped left out); the [`MAX_SOURCES`] that send the views
/// the most light.
fn bright_sources(
    mesh: &fipt_geom::Mesh,
    hits: &light_scale::Hits,
    images: &[Image],
    clipped_px: &[Vec<bool>],
    skip: &[Vec<bool>],
    clipped: Vec<Vec<u32>>,
) -> Vec<Vec<u32>> {
    use fipt_core::color::luminance;
    let taken: std::collections::HashSet<u32> = clipped.iter().flatten().copied().collect();
    // Per triangle its pixels' luminances, a clipped pixel as +∞.
    let mut seen: std::collections::HashMap<u32, Vec<f32>> = Default::default();
    let mut all = vec![];
    for (v, hv) in hits.iter().enumerate() {
        for (i, h) in hv.iter().enumerate() {
            let Some(h) = h.filter(|_| clipped_px[v][i] || !skip[v][i]) else {
                continue;
            };
            let y = if clipped_px[v][i] {
                f32::INFINITY
            } else {
                let y = luminance(images[v].data[i]);
                all.push(y);
                y
            };
            seen.entry(h.tri()).or_default().push(y);
        }
    }
    if all.is_empty() {
        return clipped;
    }
    let top = all.iter().copied().fold(0.0f32, f32::max);
    let m = all.len() / 2;
    let median = *all.select_nth_unstable_by(m, f32::total_cmp).1;
    let flux = |t: &u32| -> f64 {
        seen.get(t)
            .map_or(0.0, |ys| ys.iter().map(|&y| y.min(top) as f64).sum())
    };
    let bright: std::collections::HashSet<u32> = seen
        .iter()
        .filter(|(t, ys)| {
            let mut ys = (*ys).clone();
            let k = ys.len() / 2;
            !taken.contains(t)
                && ys.len() >= 3
                && *ys.select_nth_unstable_by(k, f32::total_cmp).1 >= BRIGHT * median
        })
        .map(|(&t, _)| t)
        .collect();
    let (piece, _) = fipt_geom::patches::patches_among(mesh, 180.0, |t| bright.contains(&t));
    let mut groups: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
    for &t in &bright {
        groups.entry(piece[t as usize]).or_default().push(t);
    }
    let pixels = |g: &[u32]| {
        g.iter()
            .map(|t| seen.get(t).map_or(0, Vec::len))
            .sum::<usize>()
    };
    let mut all_sources: Vec<(f64, Vec<u32>)> = clipped
        .into_iter()
        .chain(groups.into_values().filter(|g| pixels(g) >= 16))
        .map(|mut g| {
            g.sort_unstable();
            (g.iter().map(flux).sum(), g)
        })
        .collect();
    all_sources.sort_by(|a, b| b.0.total_cmp(&a.0).then_with(|| a.1.cmp(&b.1)));
    all_sources
        .into_iter()
        .take(MAX_SOURCES)
        .map(|(_, g)| g)
        .collect()
}

/// The decoding is raised to the curve's minimum where that lies at or below this power…
pub const MAX_APPLIED: f32 = 0.9;
/// …and the spread at γ = 1 exceeds the minimum's by this share or more.
pub const MIN_DEPTH: f64 = 0.003;

/// Whether a curve whose minimum is `gamma`, `depth` deep, is applied: only on the side below
/// 1 (a curve flatter than the decoding's is not corrected: an sRGB copy metered on the lights
/// read 1.35, 2.3 % deep; docs/phone-captures.md, section 9). A minimum at the grid's end is
/// none: the curve runs off the grid where the model misses part of the light.
pub fn applies(gamma: f32, depth: f64) -> bool {
    gamma > GAMMAS[0] && gamma <= MAX_APPLIED && depth >= MIN_DEPTH
}

/// What the light transport said of the views' contrast (`report.json` `capture.contrast`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ContrastFit {
    /// The power of the decoded views at which kd is flattest (a parabola through the curve's
    /// lowest point and its neighbours), and how much higher the spread is at γ = 1.
    pub gamma: f32,
    pub depth: f64,
    /// Whether the views were decoded again at that power.
    pub applied: bool,
    pub curve: Vec<ContrastPoint>,
    /// Lights and bright surfaces sampled on their area, surface samples, and the time taken.
    pub sources: usize,
    pub samples: usize,
    pub seconds: f32,
}

/// Whether a capture leaves the contrast open: LDR views, all 8-bit files, no stated
/// response and no known exposures.
pub fn asks_for_it(ds: &fipt_core::dataset::Dataset, r: &crate::capture::CaptureReport) -> bool {
    r.check.ldr
        && r.response.is_some()
        && !ds.capture.response_stated
        && ds.known_exposures().is_none()
}

/// Fits the contrast ([`probe`]) and, where the curve asks for more contrast than the views
/// were decoded with ([`applies`]), raises the views, their clip levels,
/// the response the report shows and the fitted gains to that power; says what it found.
pub fn fit_and_apply(
    geometry: &Geometry,
    views: &[View],
    images: &mut [Image],
    masks: &[Option<Vec<bool>>],
    r: &mut crate::capture::CaptureReport,
) {
    let t = std::time::Instant::now();
    let Some(Probe {
        curve,
        sources,
        samples,
    }) = probe(geometry, views, images, masks, r)
    else {
        return;
    };
    let (gamma, depth) = minimum(&curve);
    let applied = applies(gamma, depth);
    let spread = r.exposure_fit.as_ref().map_or(1.0, |f| f.spread);
    if applied {
        raise(images, r, gamma);
    }
    let fit = ContrastFit {
        gamma,
        depth,
        applied,
        curve,
        sources,
        samples,
        seconds: t.elapsed().as_secs_f32(),
    };
    let said = format!(
        "train: the light transport puts the views' contrast at γ = {gamma:.2} of their decoding (kd flattest along the lights' fall-off; {:.1} % more spread at γ = 1)",
        100.0 * depth
    );
    if applied {
        r.warnings.push(format!(
            "{said}: the camera's tone curve has more contrast than the response fitted from the views (without known exposures they cannot tell it from a wider spread of exposures); the views are decoded again at that power, which brings the gains' spread from ×{:.2} to ×{:.2}",
            spread,
            spread.powf(gamma),
        ));
    } else if let Some(w) = off_the_grid(&fit.curve, depth) {
        r.warnings.push(w);
    } else {
        crate::note!(
            "{said}: left as decoded (applied at {} < γ ≤ {MAX_APPLIED} with {:.1} % or more)",
            GAMMAS[0],
            100.0 * MIN_DEPTH
        );
    }
    r.contrast = Some(fit);
}

/// A curve lowest at an end of the grid is named from this depth: the walk's S-curve JPEG
/// copy without EXIF measured 3.0 %; a model that misses part of the light also tilts the
/// curve (an sRGB copy metered on the lights read 1.35, 2.3 % deep), so the bar is higher
/// than [`MIN_DEPTH`].
pub const OFF_GRID_DEPTH: f64 = 0.01;

/// The warning for a curve whose lowest point is an end of the grid, `depth` ([`minimum`])
/// at least [`OFF_GRID_DEPTH`]: the light transport asks for a power beyond the grid, so the
/// views' tone curve and exposures are not identified and nothing is corrected.
pub fn off_the_grid(curve: &[ContrastPoint], depth: f64) -> Option<String> {
    let k = lowest(curve);
    let end = (k == 0 || k + 1 == curve.len()) && curve.len() > 1;
    (end && depth >= OFF_GRID_DEPTH).then(|| {
        let (side, g) = if k == 0 { ("less", "≤") } else { ("more", "≥") };
        format!(
            "train: the camera's tone curve is NOT IDENTIFIED: the light transport asks for {side} contrast than the grid reaches (γ {g} {:.2} of the views' decoding, still falling at its end; {:.1} % more spread at γ = 1), so the views' response or their exposures are far from what was fitted, and kd and the lights may be off by a power (the gains' spread too). Give the exposures (EXIF, or capture.json `exposures`) or the camera's response (capture.json `response`)",
            curve[k].gamma,
            100.0 * depth
        )
    })
}

/// The curve's lowest point refined by a parabola through it and its neighbours, and the
/// spread at γ = 1 over it, less one.
pub fn minimum(curve: &[ContrastPoint]) -> (f32, f64) {
    let k = lowest(curve);
    let mut g = curve[k].gamma;
    if k > 0 && k + 1 < curve.len() {
        let (a, b, c) = (
            curve[k - 1].variance,
            curve[k].variance,
            curve[k + 1].variance,
        );
        // The neighbours may lie at unequal steps (the refined points): a parabola through
        // three points.
        let (x0, x1, x2) = (
            curve[k - 1].gamma as f64,
            curve[k].gamma as f64,
            curve[k + 1].gamma as f64,
        );
        let num = (x1 - x0).powi(2) * (b - c) - (x1 - x2).powi(2) * (b - a);
        let den = (x1 - x0) * (b - c) - (x1 - x2) * (b - a);
        if den.abs() > 0.0 {
            g = (x1 - 0.5 * num / den).clamp(x0, x2) as f32;
        }
    }
    let at_one = curve
        .iter()
        .find(|p| p.gamma == 1.0)
        .map_or(curve[k].variance, |p| p.variance);
    (g, at_one / curve[k].variance.max(1e-300) - 1.0)
}

/// The views decoded at power `g` of their decoding: pixels, clip levels, the response the
/// report shows (sRGB's where the fitted one was not used) and the fitted gains.
fn raise(images: &mut [Image], r: &mut crate::capture::CaptureReport, g: f32) {
    images.par_iter_mut().for_each(|img| {
        for p in &mut img.data {
            *p = p.max(Vec3::ZERO).powf(g);
        }
    });
    for c in &mut r.view_clip {
        *c = c.powf(g);
    }
    r.clip_level = r.clip_level.map(|c| c.powf(g));
    r.clip_fraction = r.clip_fraction.powf(g);
    if let Some(resp) = &mut r.response {
        if !resp.applied {
            // The views were decoded as sRGB (the unused fit's table is not kept).
            let n = crate::capture::response::TABLE_VALUES;
            resp.linear = (0..n)
                .map(|k| fipt_core::color::srgb_eotf(k as f32 / (n - 1) as f32))
                .collect();
            resp.clip_linear = fipt_core::color::srgb_eotf(250.0 / 255.0);
        }
        resp.linear.iter_mut().for_each(|x| *x = x.powf(g));
        resp.clip_linear = resp.clip_linear.powf(g);
        resp.applied = true;
        resp.outcome = format!(
            "{}, raised to γ = {g:.2} by the light transport",
            resp.outcome
        );
    }
    // The gains describe the views as decoded, whether or not they were divided by them.
    if let Some(f) = r.exposure_fit.as_mut() {
        f.gains.iter_mut().for_each(|x| *x = x.powf(g));
        f.spread = f.spread.powf(g);
        f.residual_log_rms *= g;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve_of(f: impl Fn(f64) -> f64, gammas: &[f32]) -> Vec<ContrastPoint> {
        gammas
            .iter()
            .map(|&g| ContrastPoint {
                gamma: g,
                variance: f(g as f64),
            })
            .collect()
    }

    #[test]
    fn the_minimum_of_a_parabola_is_found_between_unequal_steps() {
        // Steps that differ either side of the lowest point tried (0.75).
        let g = [0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9, 1.0, 1.1];
        let c = curve_of(|x| 0.1 + 2.0 * (x - 0.77).powi(2), &g);
        let (gamma, depth) = minimum(&c);
        assert!((gamma - 0.77).abs() < 1e-4, "{gamma}");
        // At γ = 1 the spread is 0.1 + 2 · 0.23², over the lowest point tried (0.75): 0.1 + 2 · 0.02².
        let want = (0.1 + 2.0 * 0.23f64.powi(2)) / (0.1 + 2.0 * 0.02f64.powi(2)) - 1.0;
        assert!((depth - want).abs() < 1e-9, "{depth} {want}");
        // At the grid's end the end itself.
        let c = curve_of(|x| x, &g);
        assert_eq!(minimum(&c).0, 0.5);
    }

    #[test]
    fn the_grid_runs_from_half_to_one_and_a_half_in_twentieths_through_one_exactly() {
        assert_eq!((GAMMAS[0], GAMMAS[20]), (0.5, 1.5));
        assert!(GAMMAS
            .windows(2)
            .all(|w| ((w[1] - w[0]) - 0.05).abs() < 1e-6));
        // `minimum` reads the depth at γ = 1 by equality.
        assert_eq!(GAMMAS.iter().filter(|&&g| g == 1.0).count(), 1);
    }

    #[test]
    fn a_curve_is_applied_below_0_9_when_deep_enough_and_not_at_the_grid_end() {
        assert!(applies(0.9, 0.003) && applies(0.55, 0.01));
        assert!(!applies(0.9, 0.0029) && !applies(0.95, 0.05));
        // The side above 1 is left alone however deep (an sRGB copy metered on the lights
        // read 1.35, 2.3 % deep), and the grid's end is no minimum.
        assert!(!applies(1.35, 0.023) && !applies(1.45, 0.05));
        assert!(!applies(0.5, 0.2));
    }

    /// A curve still falling at either end of the grid is named, deep enough; one with its
    /// lowest point inside, or too shallow, is not.
    #[test]
    fn a_curve_off_the_grid_is_named() {
        let curve = |f: &dyn Fn(f32) -> f64| -> Vec<ContrastPoint> {
            GAMMAS
                .iter()
                .map(|&gamma| ContrastPoint {
                    gamma,
                    variance: f(gamma),
                })
                .collect()
        };
        for (c, says) in [
            (curve(&|g| 0.03 - 0.002 * g as f64), Some("more contrast")),
            (curve(&|g| 0.03 + 0.002 * g as f64), Some("less contrast")),
            (curve(&|g| 0.03 + ((g - 1.2) as f64).powi(2)), None),
            (curve(&|g| 0.03 - 0.00001 * g as f64), None),
        ] {
            let (_, depth) = minimum(&c);
            let w = off_the_grid(&c, depth);
            match says {
                Some(s) => assert!(
                    w.as_ref()
                        .is_some_and(|w| w.contains(s) && w.contains("NOT IDENTIFIED")),
                    "{w:?}"
                ),
                None => assert!(w.is_none(), "{w:?}"),
            }
        }
    }

    fn ldr_report(applied: bool) -> crate::capture::CaptureReport {
        let mut r = crate::capture::CaptureReport {
            clip_level: Some(1.0),
            view_clip: vec![0.5, 2.0],
            clip_fraction: 0.9,
            exposures_applied: true,
            exposure_fit: Some(crate::capture::GainFit {
                gains: vec![2.0, 0.5],
                spread: 4.0,
                ..Default::default()
            }),
            response: Some(crate::capture::ResponseFit {
                outcome: "srgb (assumed)".into(),
                applied,
                clip_linear: 0.9,
                // A run that kept sRGB reports no table; a fitted curve three values here.
                linear: if applied { vec![0.0, 0.2, 1.0] } else { vec![] },
                ..Default::default()
            }),
            ..Default::default()
        };
        r.check.ldr = true;
        r
    }

    #[test]
    fn raising_the_decoding_keeps_pixels_clip_levels_response_and_gains_together() {
        let g = 0.7f32;
        let mut r = ldr_report(false);
        let mut images = vec![Image::new(2, 1)];
        images[0].data = vec![Vec3::new(0.25, 1.0, 4.0), Vec3::new(-1e-3, 0.0, 1e-6)];
        raise(&mut images, &mut r, g);
        let p = images[0].data[0];
        assert!(
            (p - Vec3::new(0.25f32.powf(g), 1.0, 4f32.powf(g)))
                .abs()
                .max_element()
                < 1e-6
        );
        // Negative noise clamps to black, and nothing is NaN.
        assert_eq!(images[0].data[1].x, 0.0);
        assert!(images[0].data[1].is_finite());
        assert!(
            (r.view_clip[0] - 0.5f32.powf(g)).abs() < 1e-6
                && (r.view_clip[1] - 2f32.powf(g)).abs() < 1e-6
        );
        let resp = r.response.as_ref().unwrap();
        // sRGB was kept: the curve raised is sRGB's, a full table (stored 0, 1/32, …, 1).
        assert!(resp.applied);
        assert_eq!(resp.linear.len(), crate::capture::response::TABLE_VALUES);
        let half = fipt_core::color::srgb_eotf(0.5).powf(g);
        assert!((resp.linear[16] - half).abs() < 1e-6, "{:?}", resp.linear);
        assert!(resp.linear[0] == 0.0 && (resp.linear[32] - 1.0).abs() < 1e-6);
        let clip = fipt_core::color::srgb_eotf(250.0 / 255.0).powf(g);
        assert!((resp.clip_linear - clip).abs() < 1e-6);
        assert!(resp.outcome.contains("γ = 0.70"), "{}", resp.outcome);
        let f = r.exposure_fit.as_ref().unwrap();
        assert!((f.gains[0] - 2f32.powf(g)).abs() < 1e-6 && (f.spread - 4f32.powf(g)).abs() < 1e-6);
        // Gains not divided out (a spread under the auto-exposure threshold) are raised too:
        // they describe the views as decoded.
        let mut r = ldr_report(false);
        r.exposures_applied = false;
        raise(&mut [], &mut r, g);
        assert!((r.exposure_fit.unwrap().gains[1] - 0.5f32.powf(g)).abs() < 1e-6);
        // A fitted curve that was used is raised itself.
        let mut r = ldr_report(true);
        raise(&mut [], &mut r, g);
        let resp = r.response.unwrap();
        assert!(
            (resp.linear[1] - 0.2f32.powf(g)).abs() < 1e-6
                && (resp.clip_linear - 0.9f32.powf(g)).abs() < 1e-6
        );
    }
}
