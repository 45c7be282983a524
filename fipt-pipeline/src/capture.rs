//! What a run knows of its views as a capture: whether they are LDR (and which pixels clip),
//! each view's exposure relative to the others (fitted on the surfaces they share: the mesh
//! gives exact correspondences), and the warnings a user must read. `report.json`'s `capture`.
use fipt_core::capture::{clipped_mask, ldr_check, LdrCheck, ViewLdr};
use fipt_core::color::luminance;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_geom::Geometry;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

/// Cells per axis of the scene's bounds over which views are compared.
const CELLS: f32 = 256.0;
/// A view needs this many surface cells shared with other views for its gain to be fitted.
pub const MIN_SHARED_CELLS: usize = 20;
/// Views whose fitted exposures spread wider than this ratio disagree (the fit's own error on
/// views of one exposure: ×1.07 on `studio-mitsuba`, its glossy and metal surfaces); LDR views
/// are divided by their gains only then.
pub const GAIN_SPREAD_WARN: f32 = 1.15;

/// Each view's exposure relative to the others, from the surfaces they share.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GainFit {
    /// Per training view: its radiance / the views' common radiance (geometric mean 1).
    pub gains: Vec<f32>,
    /// Views that share fewer than [`MIN_SHARED_CELLS`] usable cells with the others (most
    /// of the view clipped or black): their gain is left at 1.
    pub unfitted: Vec<usize>,
    /// Largest / smallest gain.
    pub spread: f32,
    /// Surface cells seen (unclipped, not dark) by at least two views, and (cell, view) pairs.
    pub cells: usize,
    pub pairs: usize,
    /// RMS of the log residual after the fit (view-dependent light, noise, misregistration).
    pub residual_log_rms: f32,
}

/// `report.json`'s `capture`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CaptureReport {
    /// The LDR check of the training views.
    #[serde(flatten)]
    pub check: LdrCheck,
    /// The value LDR views clip at (1 for 8-bit files), before any gain.
    pub clip_level: Option<f32>,
    /// The fitted exposures, and whether the views were divided by them (LDR views only).
    pub exposure_fit: Option<GainFit>,
    pub exposures_applied: bool,
    /// Known exposures from `capture.json`, applied first.
    pub exposures_known: bool,
    /// What the user must know, with numbers (also printed).
    pub warnings: Vec<String>,
    /// Per training view, its clipped pixels (LDR views only).
    #[serde(skip)]
    pub clipped: Vec<Vec<bool>>,
    /// Per training view, the clipped pixels the material loss leaves out (clipped but not on
    /// a light: a highlight or a bright wall whose radiance is only bounded below).
    #[serde(skip)]
    pub left_out: Vec<Vec<bool>>,
    /// The lights seen only clipped, and the convention their radiance was set by.
    pub clipped_lights: Option<ClippedLights>,
    /// How the mesh's edges line up with the views'.
    pub edges: EdgeCheck,
}

/// Triangles whose every view clips: lights whose radiance the views do not give.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ClippedLights {
    pub triangles: usize,
    /// Their pixels, set to `assumed` × the clip level.
    pub pixels: usize,
    pub assumed: f32,
    /// Other clipped pixels, left out of the material loss.
    pub left_out_pixels: usize,
    pub convention: String,
    /// Per connected light, its estimated radiance ([`crate::light_scale`]).
    pub estimates: Vec<crate::light_scale::LightEstimate>,
}

/// A connected set of clipped triangles seen by fewer pixels (over all views) is a highlight.
const MIN_LIGHT_PIXELS: usize = 16;
/// A triangle counts as a clipped light when this share of its pixels clip (over all views).
const CLIPPED_TRIANGLE_SHARE: f64 = 0.9;
/// The radiance assumed for a clipped light, in clip levels: not identifiable from LDR views,
/// fixed by this convention (a lamp is typically one to two orders of magnitude brighter than
/// the surfaces a camera meters for; what it lights then fixes the scale of kd).
pub const CLIPPED_LIGHT_LEVELS: f32 = 16.0;

/// For LDR views: the pixels of triangles that clip in every view they are seen from (lights)
/// are set to [`CLIPPED_LIGHT_LEVELS`] × the clip level of their view (white), so that the
/// stages see a light; the other clipped pixels are marked to be left out of the material
/// loss. `gains` are the views' fitted exposures (the clip level of view k is level / g_k).
pub fn restore_clipped_lights(
    geometry: &Geometry,
    views: &[View],
    images: &mut [Image],
    report: &mut CaptureReport,
) {
    let Some(level) = report.clip_level else {
        return;
    };
    if report.clipped.is_empty() {
        return;
    }
    let hits: Vec<Vec<Option<u32>>> = views
        .par_iter()
        .map(|v| {
            fipt_shading::records::hit_points(geometry, v)
                .into_iter()
                .map(|h| h.map(|h| h.tri))
                .collect()
        })
        .collect();
    let mut count: HashMap<u32, (usize, usize)> = HashMap::new();
    for (v, hv) in hits.iter().enumerate() {
        for (i, t) in hv.iter().enumerate() {
            if let Some(t) = t {
                let e = count.entry(*t).or_default();
                e.0 += usize::from(report.clipped[v][i]);
                e.1 += 1;
            }
        }
    }
    let light = |t: u32| {
        count
            .get(&t)
            .is_some_and(|&(c, n)| n >= 3 && c as f64 >= CLIPPED_TRIANGLE_SHARE * n as f64)
    };
    let gains = report
        .exposure_fit
        .as_ref()
        .filter(|_| report.exposures_applied)
        .map(|f| f.gains.clone());
    let mut cl = ClippedLights {
        assumed: CLIPPED_LIGHT_LEVELS,
        ..Default::default()
    };
    // The connected lights, each its own radiance.
    let (piece, _) = fipt_geom::patches::patches_among(&geometry.mesh, 180.0, light);
    let mut groups: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
    for t in (0..geometry.mesh.triangles.len() as u32).filter(|&t| light(t)) {
        groups.entry(piece[t as usize]).or_default().push(t);
    }
    // A light is seen by a few pixels at least: fewer are a highlight's (left out).
    let lights: Vec<Vec<u32>> = groups
        .into_values()
        .filter(|g| g.iter().map(|t| count[t].1).sum::<usize>() >= MIN_LIGHT_PIXELS)
        .collect();
    let kept: std::collections::HashSet<u32> = lights.iter().flatten().copied().collect();
    let light = |t: u32| kept.contains(&t);
    let skip: Vec<Vec<bool>> = report.clipped.clone();
    let estimates = crate::light_scale::estimate(geometry, views, images, &lights, &skip, level);
    let mut radiance: HashMap<u32, glam::Vec3> = HashMap::new();
    for (e, tris) in lights.iter().enumerate() {
        let est = estimates
            .as_ref()
            .and_then(|v| v.get(e))
            .filter(|x| x.pinned);
        if let Some(x) = est {
            for &t in tris {
                radiance.insert(t, glam::Vec3::from_array(x.radiance));
            }
        }
    }
    cl.estimates = estimates.unwrap_or_default();
    cl.triangles = lights.iter().map(Vec::len).sum();
    report.left_out = vec![];
    for (v, img) in images.iter_mut().enumerate() {
        let g = gains.as_ref().map_or(1.0, |g| g[v]);
        let mut out = vec![false; img.data.len()];
        for (i, p) in img.data.iter_mut().enumerate() {
            if !report.clipped[v][i] {
                continue;
            }
            match hits[v][i].filter(|&t| light(t)) {
                Some(t) => {
                    *p = radiance
                        .get(&t)
                        .copied()
                        .unwrap_or(glam::Vec3::splat(CLIPPED_LIGHT_LEVELS * level / g));
                    cl.pixels += 1;
                }
                None => {
                    out[i] = true;
                    cl.left_out_pixels += 1;
                }
            }
        }
        report.left_out.push(out);
    }
    let said: Vec<String> = cl
        .estimates
        .iter()
        .map(|e| {
            if e.pinned {
                format!("{} triangles: {:.1} clip levels, RGB {:.2?} (the curve rises {:.0} % at 10× off)", e.triangles, e.levels, e.radiance, 100.0 * e.contrast)
            } else {
                format!("{} triangles: NOT PINNED by the views (the curve rises {:.1} % at 10× off), set by convention to {} clip levels", e.triangles, 100.0 * e.contrast, CLIPPED_LIGHT_LEVELS)
            }
        })
        .collect();
    cl.convention = format!(
        "{} triangles clip in at least {:.0} % of their pixels over all views: {} light(s) whose radiance the LDR views do not give. Estimated from the surfaces they light (the radiance per channel at which kd varies least along smooth patches): {}. The absolute scale of radiance and kd rests on this estimate; {} other clipped pixels are left out of the material loss",
        cl.triangles,
        100.0 * CLIPPED_TRIANGLE_SHARE,
        lights.len(),
        if said.is_empty() { "no estimate (no sample)".to_string() } else { said.join("; ") },
        cl.left_out_pixels
    );
    report.warnings.push(cl.convention.clone());
    report.clipped_lights = Some(cl);
}

/// Checks the training images, fits their exposures on shared surfaces and, for LDR views,
/// divides each by its fitted gain. Returns what it found.
pub fn examine(
    geometry: &Geometry,
    views: &[View],
    images: &mut [Image],
    files_ldr: bool,
) -> CaptureReport {
    let per_view: Vec<(usize, ViewLdr)> = images
        .par_iter()
        .enumerate()
        .map(|(k, img)| (k, ViewLdr::of(img)))
        .collect();
    let check = ldr_check(&per_view, files_ldr);
    let mut r = CaptureReport {
        warnings: crate::inspect::ldr_warnings("train", &check),
        ..Default::default()
    };
    if check.ldr {
        let level = per_view.iter().map(|(_, v)| v.max).fold(0.0f32, f32::max);
        let level = if files_ldr || level <= 1.0 + 1e-3 {
            1.0
        } else {
            level
        };
        r.clip_level = Some(level);
        r.clipped = images.iter().map(|i| clipped_mask(i, level)).collect();
    }
    let fit = fit_gains(geometry, views, images, &r.clipped, r.clip_level);
    if let Some(f) = &fit {
        if !f.unfitted.is_empty() {
            r.warnings.push(format!(
                "train: views {:?} share fewer than {MIN_SHARED_CELLS} usable surface cells with the others (mostly clipped, black or alone): their exposure is unknown and left as it is",
                f.unfitted
            ));
        }
        if f.spread > GAIN_SPREAD_WARN {
            r.warnings.push(format!(
                "train: the views' exposures disagree on the surfaces they share: fitted gains {:.3} … {:.3} (×{:.2}) over {} surface cells{}",
                f.gains.iter().cloned().fold(f32::INFINITY, f32::min),
                f.gains.iter().cloned().fold(0.0f32, f32::max),
                f.spread,
                f.cells,
                if check.ldr { "; each view is divided by its gain (auto-exposure)" } else { "; HDR views are used as they are" }
            ));
        }
        if check.ldr && f.spread > GAIN_SPREAD_WARN {
            for (img, g) in images.iter_mut().zip(&f.gains) {
                for p in &mut img.data {
                    *p /= *g;
                }
            }
            r.exposures_applied = true;
        }
    }
    r.exposure_fit = fit;
    r.check = check;
    r.edges = edge_alignment(geometry, views, images);
    r.warnings.extend(edge_warning(&r.edges));
    r
}

/// Least squares of log radiance = log gain(view) + log radiance(cell) over the surface cells
/// that several views see unclipped and above 1/256 of the clip level or the median; the
/// gains' geometric mean is 1. None when fewer than two views share a cell.
pub fn fit_gains(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    clipped: &[Vec<bool>],
    clip_level: Option<f32>,
) -> Option<GainFit> {
    // 8-bit values under 16 steps carry a quantisation error over 3 %: not used.
    let ldr_floor = clip_level.map_or(0.0, |l| l * fipt_core::color::srgb_eotf(16.0 / 255.0));
    let b = geometry.mesh.bounds();
    let hits: Vec<Vec<Option<fipt_shading::records::HitPoint>>> = views
        .par_iter()
        .map(|view| fipt_shading::records::hit_points(geometry, view))
        .collect();
    // Cells of 3 pixel footprints (the median), at least 1/CELLS of the bounds: every cell
    // gathers several pixels of each view that sees it.
    let mut foot: Vec<f32> = hits
        .iter()
        .zip(views)
        .flat_map(|(h, view)| {
            h.iter()
                .step_by(16)
                .flatten()
                .map(move |h| (h.p - view.camera.origin).length() / view.camera.fx)
        })
        .collect();
    let cell = (3.0 * fipt_core::image::median(&mut foot))
        .max((b.max - b.min).max_element() / CELLS)
        .max(1e-6);
    // Per view: cell → (sum of log luminance, count).
    let per_view: Vec<HashMap<(i32, i32, i32), (f64, u32)>> = hits
        .par_iter()
        .zip(images)
        .enumerate()
        .map(|(v, (hits, img))| {
            let mut m: HashMap<(i32, i32, i32), (f64, u32)> = HashMap::new();
            let floor = 1e-3
                * fipt_core::image::median(
                    &mut img
                        .data
                        .iter()
                        .step_by(7)
                        .map(|&p| luminance(p))
                        .collect::<Vec<_>>(),
                );
            for (i, h) in hits.iter().enumerate() {
                let (Some(h), l) = (h, luminance(img.data[i])) else {
                    continue;
                };
                if clipped.get(v).is_some_and(|c| c[i]) || !(l > floor.max(ldr_floor).max(1e-8)) {
                    continue;
                }
                let q = ((h.p - b.min) / cell).floor();
                let e = m.entry((q.x as i32, q.y as i32, q.z as i32)).or_default();
                e.0 += (l as f64).ln();
                e.1 += 1;
            }
            m
        })
        .collect();
    // cell → [(view, mean log luminance)] for cells seen by two views or more.
    let mut cells: HashMap<(i32, i32, i32), Vec<(usize, f64)>> = HashMap::new();
    for (v, m) in per_view.iter().enumerate() {
        for (c, (s, n)) in m {
            if *n >= 2 {
                cells.entry(*c).or_default().push((v, s / *n as f64));
            }
        }
    }
    cells.retain(|_, obs| obs.len() >= 2);
    if cells.is_empty() {
        return None;
    }
    let all: Vec<&Vec<(usize, f64)>> = cells.values().collect();
    let nv = views.len();
    let (g, radiance) = alternate(&all, nv, None);
    // Leave out the cells the views disagree on most (highlights that move with the view, edges
    // a pose error shifts): above twice the median residual, then fit again.
    let rms: Vec<f64> = all
        .iter()
        .enumerate()
        .map(|(c, o)| {
            (o.iter()
                .map(|(v, y)| (y - radiance[c] - g[*v]).powi(2))
                .sum::<f64>()
                / o.len() as f64)
                .sqrt()
        })
        .collect();
    let mut sorted = rms.clone();
    let cut = 2.0
        * sorted
            .select_nth_unstable_by(rms.len() / 2, f64::total_cmp)
            .1
            .max(1e-3);
    let obs: Vec<&Vec<(usize, f64)>> = all
        .iter()
        .zip(&rms)
        .filter(|(_, r)| **r <= cut)
        .map(|(o, _)| *o)
        .collect();
    let (g, radiance) = alternate(&obs, nv, Some(g));
    // Views that share too few cells with the others keep gain 1 and are named.
    let mut shared = vec![0usize; nv];
    for o in &obs {
        for (v, _) in o.iter() {
            shared[*v] += 1;
        }
    }
    let unfitted: Vec<usize> = (0..nv).filter(|&v| shared[v] < MIN_SHARED_CELLS).collect();
    let mut g = g;
    let fitted = nv - unfitted.len();
    let mean = (0..nv)
        .filter(|v| !unfitted.contains(v))
        .map(|v| g[v])
        .sum::<f64>()
        / fitted.max(1) as f64;
    for (v, x) in g.iter_mut().enumerate() {
        *x = if unfitted.contains(&v) {
            0.0
        } else {
            *x - mean
        };
    }
    let pairs: usize = obs.iter().map(|o| o.len()).sum();
    let sq: f64 = obs
        .iter()
        .enumerate()
        .flat_map(|(c, o)| o.iter().map(move |(v, y)| (v, y, c)))
        .map(|(v, y, c)| (y - radiance[c] - g[*v]).powi(2))
        .sum();
    let gains: Vec<f32> = g.iter().map(|x| x.exp() as f32).collect();
    let spread = gains.iter().cloned().fold(0.0f32, f32::max)
        / gains.iter().cloned().fold(f32::INFINITY, f32::min);
    Some(GainFit {
        gains,
        unfitted,
        spread,
        cells: obs.len(),
        pairs,
        residual_log_rms: (sq / pairs.max(1) as f64).sqrt() as f32,
    })
}

/// Alternating least squares of y(view, cell) = g(view) + r(cell), with each view's g the
/// median of its residuals (robust to highlights) and the g's mean 0; from `start` if given.
fn alternate(
    obs: &[&Vec<(usize, f64)>],
    nv: usize,
    start: Option<Vec<f64>>,
) -> (Vec<f64>, Vec<f64>) {
    let mut g = start.unwrap_or_else(|| vec![0f64; nv]);
    let mut radiance = vec![0f64; obs.len()];
    for _ in 0..100 {
        for (c, o) in obs.iter().enumerate() {
            radiance[c] = o.iter().map(|(v, y)| y - g[*v]).sum::<f64>() / o.len() as f64;
        }
        let mut res: Vec<Vec<f64>> = vec![vec![]; nv];
        for (c, o) in obs.iter().enumerate() {
            for (v, y) in o.iter() {
                res[*v].push(y - radiance[c]);
            }
        }
        for v in 0..nv {
            if !res[v].is_empty() {
                let m = res[v].len() / 2;
                g[v] = *res[v].select_nth_unstable_by(m, f64::total_cmp).1;
            }
        }
        let mean = g.iter().sum::<f64>() / nv as f64;
        g.iter_mut().for_each(|x| *x -= mean);
    }
    (g, radiance)
}

/// How well the mesh's edges line up with the views' edges.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EdgeCheck {
    /// Per view: the image shift (pixels, x and y) that best lays the views' edges (gradient
    /// of log luminance) over the mesh's (silhouettes, creases, depth jumps); None for a view
    /// with too few mesh edges.
    pub shifts: Vec<Option<[f32; 2]>>,
    /// The median length of the shifts, pixels.
    pub median_px: f32,
    /// Views whose shift is at least [`EDGE_OFF_PX`].
    pub views_off: Vec<usize>,
}

/// A view whose edges are this many pixels off the mesh's is misregistered.
pub const EDGE_OFF_PX: f32 = 0.75;
/// Shifts tried in each direction, pixels.
const MAX_SHIFT: i32 = 3;

/// Lays each view's edges over the mesh's edges seen from its camera and measures the shift
/// that fits them best (sub-pixel, from a parabola through the best whole shift and its
/// neighbours). Exact poses and mesh give shifts near 0; poses off by a fraction of a degree
/// or a mesh off by millimetres move them.
pub fn edge_alignment(geometry: &Geometry, views: &[View], images: &[Image]) -> EdgeCheck {
    let (patch, _) = fipt_geom::patches::smooth_patches(&geometry.mesh, 30.0);
    let shifts: Vec<Option<[f32; 2]>> = views
        .par_iter()
        .zip(images)
        .map(|(view, img)| {
            let hits = fipt_shading::records::hit_points(geometry, view);
            view_shift(view, img, &hits, &patch)
        })
        .collect();
    let mut len: Vec<f32> = shifts
        .iter()
        .flatten()
        .map(|s| (s[0] * s[0] + s[1] * s[1]).sqrt())
        .collect();
    let views_off = shifts
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_some_and(|s| (s[0] * s[0] + s[1] * s[1]).sqrt() >= EDGE_OFF_PX))
        .map(|(k, _)| k)
        .collect();
    EdgeCheck {
        median_px: fipt_core::image::median(&mut len),
        shifts,
        views_off,
    }
}

/// One view's best shift of its image edges onto its mesh edges (None: under 50 mesh edges).
fn view_shift(
    view: &View,
    img: &Image,
    hits: &[Option<fipt_shading::records::HitPoint>],
    patch: &[u32],
) -> Option<[f32; 2]> {
    let (w, h) = (img.width, img.height);
    let depth = |i: usize| hits[i].map(|x| (x.p - view.camera.origin).length());
    let key = |i: usize| hits[i].map(|x| patch[x.tri as usize]);
    // Mesh edges between a pixel and its right or lower neighbour.
    let mut edges = vec![];
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            let i = y * w + x;
            for j in [i + 1, i + w] {
                let jump = match (depth(i), depth(j)) {
                    (Some(a), Some(b)) => (a / b).max(b / a) > 1.05 || key(i) != key(j),
                    (None, None) => false,
                    _ => true,
                };
                if jump {
                    edges.push((x as i32, y as i32, j == i + 1));
                }
            }
        }
    }
    if edges.len() < 50 {
        return None;
    }
    let log_l: Vec<f32> = img
        .data
        .iter()
        .map(|&p| (luminance(p).max(0.0) + 1e-4).ln())
        .collect();
    let grad = |x: i32, y: i32, right: bool| -> f32 {
        let (x2, y2) = if right { (x + 1, y) } else { (x, y + 1) };
        if x < 0 || y < 0 || x2 >= w as i32 || y2 >= h as i32 {
            return 0.0;
        }
        (log_l[y2 as usize * w + x2 as usize] - log_l[y as usize * w + x as usize]).abs()
    };
    let n = (2 * MAX_SHIFT + 1) as usize;
    let mut score = vec![0f32; n * n];
    for (sy, row) in score.chunks_mut(n).enumerate() {
        for (sx, s) in row.iter_mut().enumerate() {
            let (dx, dy) = (sx as i32 - MAX_SHIFT, sy as i32 - MAX_SHIFT);
            *s = edges.iter().map(|&(x, y, r)| grad(x + dx, y + dy, r)).sum();
        }
    }
    let best = (0..n * n).max_by(|&a, &b| score[a].total_cmp(&score[b]))?;
    let (bx, by) = (best % n, best / n);
    let sub = |m: f32, c: f32, p: f32| {
        let d = m - 2.0 * c + p;
        if d < 0.0 {
            (0.5 * (m - p) / d).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    };
    let at = |x: usize, y: usize| score[y * n + x];
    let fx = if bx > 0 && bx + 1 < n {
        sub(at(bx - 1, by), at(bx, by), at(bx + 1, by))
    } else {
        0.0
    };
    let fy = if by > 0 && by + 1 < n {
        sub(at(bx, by - 1), at(bx, by), at(bx, by + 1))
    } else {
        0.0
    };
    Some([
        bx as f32 - MAX_SHIFT as f32 + fx,
        by as f32 - MAX_SHIFT as f32 + fy,
    ])
}

/// The warning of views whose edges do not line up with the mesh's (None when they do).
pub fn edge_warning(e: &EdgeCheck) -> Option<String> {
    // A few noisy views of a small scene may misfit alone: many views, or the median.
    let many = e.views_off.len() >= 2 && e.views_off.len() * 4 >= e.shifts.len();
    if e.median_px < 0.5 && !many {
        return None;
    }
    let worst = e
        .shifts
        .iter()
        .flatten()
        .map(|s| (s[0] * s[0] + s[1] * s[1]).sqrt())
        .fold(0.0f32, f32::max);
    Some(format!(
        "train: the views' edges do not line up with the mesh's: off by a median {:.2} px (worst {:.2} px), {} of {} views by {EDGE_OFF_PX} px or more: poses (structure from motion?) or the mesh (a scan?) are off; the maps blur across edges and outline pixels mix surfaces",
        e.median_px,
        worst,
        e.views_off.len(),
        e.shifts.len()
    ))
}
