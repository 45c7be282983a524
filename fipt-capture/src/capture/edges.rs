//! How well the mesh's edges line up with the views'.
use fipt_core::color::luminance;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_geom::Geometry;
use rayon::prelude::*;
use serde::Serialize;

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
    let edges = mesh_edges(view, img, hits, patch)?;
    let log_l = log_luminance(img);
    let n = (2 * MAX_SHIFT + 1) as usize;
    let score = shift_scores(&edges, &log_l, img.width, img.height);
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

/// The mesh's edges seen from `view` (silhouettes, depth jumps, patch boundaries) between a
/// pixel and its right (`true`) or lower neighbour; None under 50 of them.
fn mesh_edges(
    view: &View,
    img: &Image,
    hits: &[Option<fipt_shading::records::HitPoint>],
    patch: &[u32],
) -> Option<Vec<(i32, i32, bool)>> {
    let (w, h) = (img.width, img.height);
    let depth = |i: usize| hits[i].map(|x| (x.p - view.camera.origin).length());
    let key = |i: usize| hits[i].map(|x| patch[x.tri() as usize]);
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
    (edges.len() >= 50).then_some(edges)
}

fn log_luminance(img: &Image) -> Vec<f32> {
    img.data
        .iter()
        .map(|&p| (luminance(p).max(0.0) + 1e-4).ln())
        .collect()
}

/// |Δ log L| between a pixel and its right or lower neighbour (0 off the image).
fn gradient(log_l: &[f32], w: usize, h: usize, x: i32, y: i32, right: bool) -> f32 {
    let (x2, y2) = if right { (x + 1, y) } else { (x, y + 1) };
    if x < 0 || y < 0 || x2 >= w as i32 || y2 >= h as i32 {
        return 0.0;
    }
    (log_l[y2 as usize * w + x2 as usize] - log_l[y as usize * w + x as usize]).abs()
}

/// The summed image gradient on the mesh's edges for each shift of the ±[`MAX_SHIFT`] grid
/// (row-major, x fastest).
fn shift_scores(edges: &[(i32, i32, bool)], log_l: &[f32], w: usize, h: usize) -> Vec<f32> {
    let n = (2 * MAX_SHIFT + 1) as usize;
    let mut score = vec![0f32; n * n];
    for (sy, row) in score.chunks_mut(n).enumerate() {
        for (sx, s) in row.iter_mut().enumerate() {
            let (dx, dy) = (sx as i32 - MAX_SHIFT, sy as i32 - MAX_SHIFT);
            *s = edges
                .iter()
                .map(|&(x, y, r)| gradient(log_l, w, h, x + dx, y + dy, r))
                .sum();
        }
    }
    score
}

/// How much sharper the image is on the mesh's edges than elsewhere, per view: the mean
/// |Δ log L| on the mesh's edges at their best shift over its mean across all neighbours
/// (None: under 50 mesh edges, or a flat image). Views seen from their true poses read well
/// above 1; from poses in another convention, near 1.
pub fn edge_contrast(geometry: &Geometry, views: &[View], images: &[Image]) -> Vec<Option<f32>> {
    let (patch, _) = fipt_geom::patches::smooth_patches(&geometry.mesh, 30.0);
    views
        .par_iter()
        .zip(images)
        .map(|(view, img)| {
            let hits = fipt_shading::records::hit_points(geometry, view);
            let edges = mesh_edges(view, img, &hits, &patch)?;
            let (w, h) = (img.width, img.height);
            let log_l = log_luminance(img);
            let best = shift_scores(&edges, &log_l, w, h)
                .into_iter()
                .fold(0.0f32, f32::max);
            let mut all = 0.0f64;
            for y in 0..h as i32 {
                for x in 0..w as i32 {
                    all += (gradient(&log_l, w, h, x, y, true)
                        + gradient(&log_l, w, h, x, y, false)) as f64;
                }
            }
            let mean_all = all / (2 * w * h) as f64;
            (mean_all > 1e-6).then(|| (best as f64 / edges.len() as f64 / mean_all) as f32)
        })
        .collect()
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
