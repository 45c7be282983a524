//! The training pixels' primary hits and what is sized from them: every stage that computes
//! shadings per pixel (the bake, the refinement, the search) starts from these.
use fipt_core::dataset::View;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::{RayQuery, Shard, SurfaceHit, ViewShadings, NUM_LEVELS};
use glam::Vec3;
use rayon::prelude::*;

/// A training pixel's primary hit, normal facing the viewer.
#[derive(Clone, Copy, Debug)]
pub struct PixelRecord {
    pub hit: SurfaceHit,
    /// Facing geometric normal.
    pub ng: Vec3,
    /// Facing shading normal.
    pub ns: Vec3,
    /// Direction to the viewer.
    pub wo: Vec3,
}

/// What the stages after the bake need of a pixel's primary hit: where it is and on which
/// triangle.
pub trait PrimaryHit {
    fn point(&self) -> Vec3;
    fn triangle(&self) -> u32;
}

impl PrimaryHit for PixelRecord {
    fn point(&self) -> Vec3 {
        self.hit.p
    }
    fn triangle(&self) -> u32 {
        self.hit.tri
    }
}

/// A primary hit's point and triangle alone: 16 bytes where a [`PixelRecord`] takes 80, for
/// the hits that a whole run keeps. The triangle is kept as `tri + 1` in a `NonZeroU32`, so
/// that `Option<HitPoint>` takes 16 bytes too (20 with a plain `u32`: 1.2 GB instead of 1 GB
/// for the 61 M hits of 200 views of 640 × 480).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitPoint {
    pub p: Vec3,
    tri_plus_one: std::num::NonZeroU32,
}

impl HitPoint {
    /// The hit at `p` on triangle `tri` (any index but `u32::MAX`, which no mesh reaches).
    #[inline]
    pub fn new(p: Vec3, tri: u32) -> HitPoint {
        HitPoint {
            p,
            tri_plus_one: std::num::NonZeroU32::new(tri.wrapping_add(1))
                .expect("a triangle index below u32::MAX"),
        }
    }
    /// The triangle hit.
    #[inline]
    pub fn tri(&self) -> u32 {
        self.tri_plus_one.get() - 1
    }
}

impl PrimaryHit for HitPoint {
    fn point(&self) -> Vec3 {
        self.p
    }
    fn triangle(&self) -> u32 {
        self.tri()
    }
}

/// The point and triangle of every pixel centre's primary hit of a view.
pub fn hit_points(geometry: &dyn RayQuery, view: &View) -> Vec<Option<HitPoint>> {
    // A new allocation of the hits' size: `into_iter().map().collect()` would reuse the
    // records' buffer in place, and a whole run's hits then kept the records' size (about
    // 5× theirs: several GiB at 200 views of 640 × 480).
    points_of(&primary_records(geometry, view))
}

/// The hit points of one view's primary `records`, in an allocation of their own size.
pub fn points_of(records: &[Option<PixelRecord>]) -> Vec<Option<HitPoint>> {
    let mut hits = Vec::with_capacity(records.len());
    hits.extend(
        records
            .iter()
            .map(|r| r.as_ref().map(|r| HitPoint::new(r.hit.p, r.hit.tri))),
    );
    hits
}

/// [`hit_points`] of every view and their median pixel footprint ([`view_footprint`]), each
/// view traced once for both.
pub fn hit_points_and_footprint(
    geometry: &dyn RayQuery,
    views: &[View],
) -> (Vec<Vec<Option<HitPoint>>>, Option<f32>) {
    let mut foot = vec![];
    let hits = views
        .iter()
        .map(|v| {
            let records = primary_records(geometry, v);
            push_footprints(v, &records, &mut foot);
            points_of(&records)
        })
        .collect();
    (hits, median(foot))
}

/// Primary hits of every pixel centre of a view.
pub fn primary_records(geometry: &dyn RayQuery, view: &View) -> Vec<Option<PixelRecord>> {
    let cam = &view.camera;
    (0..cam.width * cam.height)
        .into_par_iter()
        .map(|i| {
            let (o, d) = cam.pixel_center_ray(i % cam.width, i / cam.width);
            geometry.intersect(o, d).map(|hit| {
                let flip = if hit.ng.dot(d) > 0.0 { -1.0 } else { 1.0 };
                let ng = hit.ng * flip;
                let mut ns = hit.ns * flip;
                if ns.dot(ng) < 0.0 {
                    ns = ng;
                }
                PixelRecord {
                    hit,
                    ng,
                    ns,
                    wo: -d,
                }
            })
        })
        .collect()
}

/// The median pixel footprint of `views`' primary hits (hit distance / focal length in pixels),
/// the one [`view_points`] returns, without keeping the points: one view's hits at a time.
pub fn view_footprint(geometry: &dyn RayQuery, views: &[View]) -> Option<f32> {
    let mut foot = vec![];
    for v in views {
        push_footprints(v, &primary_records(geometry, v), &mut foot);
    }
    median(foot)
}

/// Appends the footprint (hit distance / the larger focal length in pixels) of each hit of
/// one view's primary `records`: what [`view_footprint`] takes the median of.
pub fn push_footprints(view: &View, records: &[Option<PixelRecord>], foot: &mut Vec<f32>) {
    let f = view.camera.fx.max(view.camera.fy);
    foot.extend(records.iter().flatten().map(|r| r.hit.t / f));
}

/// Primary hit points of every pixel of `views`, and the median pixel footprint (hit
/// distance / focal length in pixels).
pub fn view_points(
    geometry: &dyn RayQuery,
    views: &[View],
) -> (Vec<Vec<Option<Vec3>>>, Option<f32>) {
    let mut foot = vec![];
    let pts = views
        .iter()
        .map(|v| {
            let f = v.camera.fx.max(v.camera.fy);
            primary_records(geometry, v)
                .iter()
                .map(|r| {
                    r.map(|r| {
                        foot.push(r.hit.t / f);
                        r.hit.p
                    })
                })
                .collect()
        })
        .collect();
    (pts, median(foot))
}

/// All-zero shadings of `model` for `views`, valid where the pixel-centre ray hit the mesh.
pub fn empty_shadings(
    views: &[View],
    records: &[Vec<Option<PixelRecord>>],
    levels: [f32; NUM_LEVELS],
    model: ReflectanceModel,
) -> Vec<ViewShadings> {
    empty_shadings_of(views, records, levels, model, Shard::ALL)
}

/// [`empty_shadings`] for `shard`'s views; the others get 0 × 0 shadings (a shard's memory
/// grows with its own views only).
pub fn empty_shadings_of(
    views: &[View],
    records: &[Vec<Option<PixelRecord>>],
    levels: [f32; NUM_LEVELS],
    model: ReflectanceModel,
    shard: Shard,
) -> Vec<ViewShadings> {
    let poly = model.diffuse_depends_on_roughness();
    views
        .iter()
        .zip(records)
        .enumerate()
        .map(|(k, (v, r))| {
            if !shard.contains(k) {
                return ViewShadings::zeros_for(0, 0, levels, poly);
            }
            let mut s = ViewShadings::zeros_for(v.camera.width, v.camera.height, levels, poly);
            for (i, rec) in r.iter().enumerate() {
                s.valid[i] = rec.is_some();
            }
            s
        })
        .collect()
}

/// The median pixel footprint (hit distance / focal length in pixels) over a sample of the
/// pixels of `views`.
pub fn median_footprint(views: &[View], records: &[Vec<Option<PixelRecord>>]) -> Option<f32> {
    let mut foot = Vec::new();
    for (v, r) in views.iter().zip(records) {
        footprint_samples(v, r, &mut foot);
    }
    median(foot)
}

/// Appends the footprints of a sample of one view's pixels (at most about 512), those
/// [`median_footprint`] takes the median of.
pub fn footprint_samples(view: &View, records: &[Option<PixelRecord>], foot: &mut Vec<f32>) {
    let step = (records.len() / 512).max(1);
    for rec in records.iter().step_by(step).flatten() {
        foot.push(rec.hit.t / view.camera.fx);
    }
}

/// What the shading stages need of every view's primary hits before any view's shadings, found
/// one view at a time (each view's hits are dropped after its pass): the cube around the hits
/// and the median pixel footprint.
pub struct HitsSummary {
    pub cube: Option<fipt_core::cube::Cube>,
    pub footprint: Option<f32>,
}

impl HitsSummary {
    /// The summary of `views`' hits (cube scaled by `scale` around them).
    pub fn of(geometry: &dyn RayQuery, views: &[View], scale: f32) -> Self {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut foot = Vec::new();
        for v in views {
            let r = primary_records(geometry, v);
            for rec in r.iter().flatten() {
                if rec.hit.p.is_finite() {
                    lo = lo.min(rec.hit.p);
                    hi = hi.max(rec.hit.p);
                }
            }
            footprint_samples(v, &r, &mut foot);
        }
        // The corners span the same box as the points (`Cube::around` takes their bounds).
        let cube = (lo.x <= hi.x)
            .then(|| fipt_core::cube::Cube::around([lo, hi], scale))
            .flatten();
        HitsSummary {
            cube,
            footprint: median(foot),
        }
    }
}

/// The shadings of one view with no shading yet, valid where the pixel-centre ray hit.
pub fn empty_view_shadings(
    view: &View,
    records: &[Option<PixelRecord>],
    levels: [f32; NUM_LEVELS],
    model: ReflectanceModel,
) -> ViewShadings {
    let cam = &view.camera;
    let poly = model.diffuse_depends_on_roughness();
    let mut s = ViewShadings::zeros_for(cam.width, cam.height, levels, poly);
    for (v, rec) in s.valid.iter_mut().zip(records) {
        *v = rec.is_some();
    }
    s
}

/// The median of `v` (None when empty).
pub fn median(mut v: Vec<f32>) -> Option<f32> {
    if v.is_empty() {
        return None;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    Some(*m)
}
