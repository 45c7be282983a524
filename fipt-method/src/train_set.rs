//! The training set of a round: the training views' pixels that hit the mesh (less the clipped
//! ones off the lights, the bleed beside bright edges and those over the set's limit) with their
//! shadings, segments and the search's targets.
use crate::bail;
use crate::error::Result;
use crate::scene::SceneRef;
use crate::search::Searched;
use fipt_bake::bake_store::StoredShadings;
use fipt_core::dataset::GtKind;
use fipt_neural::train::SegmentSource;
use fipt_neural::{Bounds, TrainConfig, TrainingSet};
use glam::Vec3;
use rayon::prelude::*;
use std::path::PathBuf;

/// Leaves out of one view's points (view `v`) those outside the uniform random `share` kept
/// from (`seed`, view, pixel).
fn keep_share(pts: &mut [Option<Vec3>], v: usize, seed: u64, share: f64) {
    for (i, p) in pts.iter_mut().enumerate() {
        if p.is_some() && !fipt_core::rng::pixel_kept(seed, v, i, share) {
            *p = None;
        }
    }
}

/// [`keep_share`] over every view, the share set so that about `limit` hits remain; returns
/// how many it left out (what [`SetPoints::limit`] does one view at a time).
#[cfg(test)]
fn keep_at_most(points: &mut [Vec<Option<Vec3>>], limit: usize, seed: u64) -> usize {
    let all = points.iter().flatten().flatten().count();
    if all <= limit {
        return 0;
    }
    for (v, pts) in points.iter_mut().enumerate() {
        keep_share(pts, v, seed, limit as f64 / all as f64);
    }
    all - points.iter().flatten().flatten().count()
}

/// Each training view's points for the set, made one view at a time (the primary hits traced
/// again): none where a clipped pixel lies off the lights, beside a bright edge
/// ([`fipt_core::image::bleed_mask`]: `train.bleed_radius`, `bleed_contrast`), or outside the
/// uniform share [`SetPoints::limit`] keeps. Only one view's points are held at a time.
struct SetPoints<'a> {
    scene: &'a SceneRef<'a>,
    /// (radius, contrast, floor: 1 % of the median luminance over every training view, so
    /// that a view into a dark corner, whose noise is no edge, keeps its pixels).
    bleed: Option<(usize, f32, f32)>,
    /// The share kept from (seed, view, pixel), when the hits exceed the set's limit.
    keep: Option<(u64, f64)>,
    /// The hits left after the masks, over every view.
    hits: usize,
    /// The median pixel footprint of every view's hits, as
    /// [`fipt_shading::records::view_footprint`] finds it, from the same pass.
    footprint: Option<f32>,
    /// The hits the bleed mask left out, of how many.
    bled: (usize, usize),
}

impl<'a> SetPoints<'a> {
    fn new(scene: &'a SceneRef<'a>, cfg: &TrainConfig) -> Self {
        let bleed = (cfg.bleed_radius > 0).then(|| {
            let median = fipt_core::image::median_luminance(&scene.images);
            (cfg.bleed_radius as usize, cfg.bleed_contrast, 0.01 * median)
        });
        let mut pick = SetPoints {
            scene,
            bleed,
            keep: None,
            hits: 0,
            footprint: None,
            bled: (0, 0),
        };
        // A few views at a time on every core (the footprints' median does not depend on
        // their order).
        let (mut dropped, mut all, mut foot) = (0usize, 0usize, vec![]);
        for chunk in view_chunks(scene.images.len()) {
            let masked: Vec<_> = (chunk.into_par_iter())
                .map(|v| {
                    let mut foot = vec![];
                    let (kept, hit) = pick.masked(v, &mut foot);
                    (kept, hit, foot)
                })
                .collect();
            for (kept, hit, f) in masked {
                (dropped, all) = (dropped + hit - kept, all + hit);
                foot.extend(f);
            }
        }
        pick.hits = all - dropped;
        pick.footprint = fipt_shading::records::median(foot);
        pick.bled = (dropped, all);
        pick
    }

    /// Says how many hits the bleed mask left out.
    fn note_bleed(&self) {
        let (dropped, all) = self.bled;
        if let Some((radius, contrast, _)) = self.bleed {
            crate::note!(
                "training set: {dropped} of {all} pixels ({:.2} %) left out within {radius} px of one {contrast}× brighter (train.bleed_radius, bleed_contrast)",
                100.0 * dropped as f64 / all.max(1) as f64,
            );
        }
    }

    /// View `v`'s hits left after the clipped and bleed masks, and before the bleed mask;
    /// appends the footprints of all its hits to `foot`.
    fn masked(&self, v: usize, foot: &mut Vec<f32>) -> (usize, usize) {
        let mut hit = 0;
        let pts = self.unkept(v, Some(foot), &mut |before| hit += usize::from(before));
        (pts.iter().flatten().count(), hit)
    }

    /// Keeps a uniform random share of the hits, each kept or not from (`seed`, view, pixel),
    /// so that about `limit` remain (`train.set_cap`); returns the hits before the share when
    /// there is one.
    fn limit(&mut self, limit: Option<usize>, seed: u64) -> Option<usize> {
        self.keep = Some((seed, self.share(limit)?));
        Some(self.hits)
    }

    /// The share of the hits kept so that about `limit` remain; None when all are.
    fn share(&self, limit: Option<usize>) -> Option<f64> {
        let all = self.hits;
        let limit = limit.filter(|&l| all > l)?;
        Some(limit as f64 / all as f64)
    }

    /// View `v`'s points after the masks, before the share; `seen` is told of every pixel
    /// whether it hit the mesh and was not clipped; `foot` gets the footprints of its hits.
    fn unkept(
        &self,
        v: usize,
        foot: Option<&mut Vec<f32>>,
        seen: &mut dyn FnMut(bool),
    ) -> Vec<Option<Vec3>> {
        let scene = self.scene;
        let view = &scene.ds.train().views[v];
        let records = fipt_shading::records::primary_records(scene.geometry, view);
        if let Some(foot) = foot {
            fipt_shading::records::push_footprints(view, &records, foot);
        }
        let mut pts: Vec<Option<Vec3>> = records.iter().map(|r| r.map(|r| r.hit.p)).collect();
        drop(records);
        // Clipped pixels off the lights: their radiance is only bounded below.
        if let Some(out) = scene.left_out.get(v) {
            for (p, _) in pts.iter_mut().zip(out).filter(|(_, o)| **o) {
                *p = None;
            }
        }
        for p in &pts {
            seen(p.is_some());
        }
        if let Some((radius, contrast, floor)) = self.bleed {
            let bleed = fipt_core::image::bleed_mask(&scene.images[v], radius, contrast, floor);
            for (p, b) in pts.iter_mut().zip(bleed) {
                if b {
                    *p = None;
                }
            }
        }
        pts
    }

    /// View `v`'s points for the set.
    fn view(&self, v: usize) -> Vec<Option<Vec3>> {
        let mut pts = self.unkept(v, None, &mut |_| {});
        if let Some((seed, share)) = self.keep {
            keep_share(&mut pts, v, seed, share);
        }
        pts
    }
}

/// The views `0..n` in chunks of a few views per core: what one parallel pass holds at once.
fn view_chunks(n: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
    let k = 2 * rayon::current_num_threads().max(1);
    (0..n).step_by(k).map(move |a| a..(a + k).min(n))
}

/// Where the segment prior's ids come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SegmentKind {
    /// The scene's part ids (`IndexMA/`).
    Parts,
    /// Its semantic classes (`segmentation/`).
    Classes,
    /// Smooth connected patches of the mesh (the search's `mesh` regions, 30°).
    Mesh,
}

impl SegmentKind {
    /// The search's name of the same regions (`Searched::source`).
    fn search_source(self) -> &'static str {
        match self {
            SegmentKind::Parts => "parts",
            SegmentKind::Classes => "semantic",
            SegmentKind::Mesh => "mesh",
        }
    }
}

/// A mesh patch grows across dihedral angles up to this (the search's `mesh_angle_deg`).
const MESH_SEGMENT_ANGLE_DEG: f32 = 30.0;

/// The ids the segment prior reads as `source` asks (None: no prior), with a fingerprint.
pub(crate) fn segment_ids(
    scene: &SceneRef,
    source: SegmentSource,
) -> Result<Option<(SegmentKind, String)>> {
    let split = scene.ds.train();
    let has_parts = split.has_gt(GtKind::IndexMA);
    let has_classes = split.has_gt(GtKind::Segmentation);
    let kind = match source {
        SegmentSource::None => return Ok(None),
        SegmentSource::Auto | SegmentSource::Parts if has_parts => GtKind::IndexMA,
        SegmentSource::Auto | SegmentSource::Semantic if has_classes => GtKind::Segmentation,
        SegmentSource::Auto | SegmentSource::Mesh => {
            return Ok(Some((
                SegmentKind::Mesh,
                format!("mesh-patches:{MESH_SEGMENT_ANGLE_DEG}"),
            )))
        }
        SegmentSource::Parts => bail!(
            "train.segments = \"parts\" but {} has no IndexMA/ folder (use \"auto\", \"mesh\" or \"none\")",
            split.dir.display()
        ),
        SegmentSource::Semantic => bail!(
            "train.segments = \"semantic\" but {} has no segmentation/ folder (use \"auto\", \"mesh\" or \"none\")",
            split.dir.display()
        ),
    };
    let files: Vec<PathBuf> = (0..split.views.len())
        .map(|k| split.gt_path(kind, k))
        .collect();
    let hash = fipt_core::fsutil::hash_files(&files)?;
    let seg = if kind == GtKind::IndexMA {
        SegmentKind::Parts
    } else {
        SegmentKind::Classes
    };
    Ok(Some((seg, format!("{}:{hash}", kind.folder()))))
}

/// The ids of the training views `views`, read when the set reaches them (every view's ids
/// at once took 8 bytes a pixel of every view): a part or class id, or the mesh patch the
/// pixel centre's ray hits (−1: none).
struct ViewIds<'a> {
    scene: &'a SceneRef<'a>,
    kind: SegmentKind,
    /// Each triangle's smooth patch, for [`SegmentKind::Mesh`].
    patch: Vec<u32>,
    /// The search's second sides, by view: (pixel, k).
    sides: std::collections::BTreeMap<u32, Vec<(u32, u32)>>,
    /// The id of the second side of divided region k is `base + k`: above every id.
    base: i64,
}

impl ViewIds<'_> {
    fn read(&self, views: &[usize]) -> Result<Vec<Vec<i64>>> {
        let mut ids = match self.kind {
            SegmentKind::Parts => crate::segments::view_ids(self.scene, GtKind::IndexMA, views)?,
            SegmentKind::Classes => {
                crate::segments::view_ids(self.scene, GtKind::Segmentation, views)?
            }
            SegmentKind::Mesh => {
                let train = &self.scene.ds.train().views;
                views
                    .par_iter()
                    .map(|&v| {
                        fipt_shading::records::hit_points(self.scene.geometry, &train[v])
                            .iter()
                            .map(|h| h.map_or(-1, |h| self.patch[h.tri() as usize] as i64))
                            .collect()
                    })
                    .collect()
            }
        };
        for (&v, ids) in views.iter().zip(&mut ids) {
            if let Some(sides) = self.sides.get(&(v as u32)) {
                divide_ids(ids, sides, self.base);
            }
        }
        Ok(ids)
    }
}

/// Attaches the ids `found` by [`segment_ids`] to the training set.
pub(crate) fn with_segments(
    scene: &SceneRef,
    data: TrainingSet,
    found: Option<&(SegmentKind, String)>,
    search: Option<&Searched>,
) -> Result<TrainingSet> {
    let Some((kind, _)) = found else {
        return Ok(data);
    };
    let (patch, patches) = if *kind == SegmentKind::Mesh {
        fipt_geom::patches::smooth_patches_of(
            scene.positions,
            scene.triangles,
            MESH_SEGMENT_ANGLE_DEG,
        )
    } else {
        (vec![], 0)
    };
    let mut sides = std::collections::BTreeMap::<u32, Vec<(u32, u32)>>::new();
    for &(v, i, k) in second_sides(search, *kind).into_iter().flatten() {
        sides.entry(v).or_default().push((i, k));
    }
    // Above every id: the patches' count, or the search's labels (the same parts, as
    // `second_sides` requires). The ids are renumbered densely in order of appearance, so
    // any base above them gives the same set.
    let labels = search.map_or(0, |s| s.regions.iter().map(|r| r.0).max().unwrap_or(0));
    let reader = ViewIds {
        scene,
        kind: *kind,
        patch,
        sides,
        base: (patches as i64).max(labels).max(0) + 1,
    };
    let n = scene.ds.train().views.len();
    let read = |views: &[usize]| {
        (reader.read(views)).map_err(|e| fipt_core::CoreError::Component(Box::new(e)))
    };
    Ok(if *kind == SegmentKind::Classes {
        let d = data.with_classes_by(n, read)?;
        crate::note!("semantic prior on {} classes (segmentation/)", d.segments);
        d
    } else {
        let d = data.with_segments_by(n, read)?;
        let from = if *kind == SegmentKind::Parts {
            "parts (IndexMA/)"
        } else {
            "smooth patches of the mesh"
        };
        crate::note!("segment prior on {} {from}", d.segments);
        d
    })
}

/// Gives the pixels `(pixel, k)` of one view on the second side of the k-th region the search
/// divided (by colour or gloss) the id `base + k` (`base`: above every id of the scene).
fn divide_ids(ids: &mut [i64], sides: &[(u32, u32)], base: i64) {
    for &(i, k) in sides {
        if let Some(id) = ids.get_mut(i as usize) {
            *id = base + k as i64;
        }
    }
}

/// The search's second sides of divided regions when they split the segment ids: the search's
/// regions are the scene's parts and so are the segments.
pub(crate) fn second_sides(
    search: Option<&Searched>,
    kind: SegmentKind,
) -> Option<&[(u32, u32, u32)]> {
    search
        .filter(|s| {
            kind != SegmentKind::Classes
                && s.source == kind.search_source()
                && !s.second_sides.is_empty()
        })
        .map(|s| &s.second_sides[..])
}

/// A fingerprint of the training set's search targets (part of the training's cache key).
pub(crate) fn targets_fingerprint(data: &TrainingSet) -> String {
    let bytes: Vec<u8> = data
        .target
        .iter()
        .flat_map(|t| [t[0].to_le_bytes(), t[1].to_le_bytes()])
        .flatten()
        .collect();
    fipt_core::fsutil::hash_bytes(&bytes)
}

/// The share of the hit pixels the training set will keep (`train.set_cap`, drawn from
/// `train.seed`), before any shading exists: 1 when it keeps every one. `hits`: the views'
/// hits before the masks (when no more than the cap, the masks' pass is spared).
pub(crate) fn drawn_share(scene: &SceneRef, cfg: &TrainConfig, hits: usize) -> f64 {
    match cfg.set_limit().filter(|&l| hits > l) {
        Some(limit) => SetPoints::new(scene, cfg).share(Some(limit)).unwrap_or(1.0),
        None => 1.0,
    }
}

/// The box of the points `pick` keeps over views `0..views` (as `Bounds::around` takes it:
/// finite points) and their count, the views on every core.
fn kept_bounds(pick: &SetPoints, views: usize) -> (Vec3, Vec3, usize) {
    (0..views)
        .into_par_iter()
        .map(|v| {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            let mut hits = 0usize;
            for p in pick.view(v).into_iter().flatten() {
                hits += 1;
                if p.is_finite() {
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
            }
            (lo, hi, hits)
        })
        .reduce(
            || {
                (
                    Vec3::splat(f32::INFINITY),
                    Vec3::splat(f32::NEG_INFINITY),
                    0,
                )
            },
            |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 + b.2),
        )
}

/// The training set of the points `pick` keeps and their stored shadings: each view's points
/// and shadings are made a few views at a time on every core, and the set takes them in view
/// order.
fn gather(
    pick: &SetPoints,
    shadings: &StoredShadings,
    images: &[fipt_core::image::Image],
    bounds: &Bounds,
    hits: usize,
) -> Result<TrainingSet> {
    let views = images.len();
    let ahead = std::cell::RefCell::new(std::collections::VecDeque::new());
    let fetch = |v: usize| -> Result<()> {
        let mut q = ahead.borrow_mut();
        if q.front().is_some_and(|f: &(usize, _, _)| f.0 == v) {
            return Ok(());
        }
        q.clear();
        let chunk: Vec<usize> = (v..views)
            .take(rayon::current_num_threads().max(1))
            .collect();
        let got = (chunk.par_iter())
            .map(|&k| Ok((k, pick.view(k), shadings.view(k)?)))
            .collect::<Result<Vec<_>>>()?;
        q.extend(got);
        Ok(())
    };
    TrainingSet::from_view_points(
        (views, hits),
        |v| {
            fetch(v)?;
            let mut q = ahead.borrow_mut();
            Ok::<_, crate::RunError>(std::mem::take(&mut q[0].1))
        },
        images,
        bounds,
        |v| {
            fetch(v)?;
            let (_, _, sh) = ahead.borrow_mut().pop_front().expect("fetched");
            Ok(sh)
        },
    )
}

/// The training set of a round: the training views' pixels that hit the mesh, less the clipped
/// ones off the lights, the bleed beside bright edges and those over the set's limit, with
/// their shadings, segments and the search's targets.
pub(crate) struct BuiltSet {
    pub(crate) data: TrainingSet,
    pub(crate) left_out: usize,
    pub(crate) lights: usize,
    pub(crate) targets_id: Option<String>,
}

pub(crate) fn build_set(
    scene: &SceneRef,
    shadings: &StoredShadings,
    cfg: &TrainConfig,
    segments: Option<&(SegmentKind, String)>,
    search: Option<&Searched>,
) -> Result<BuiltSet> {
    let mut pick = SetPoints::new(scene, cfg);
    pick.note_bleed();
    let footprint = pick.footprint;
    let before = pick.limit(cfg.set_limit(), cfg.seed);
    let wanted = fipt_core::shading::PixelDraw::new(cfg.seed, pick.keep.map(|k| k.1));
    if let Some(why) = crate::bake::uncovered(&shadings.pixels, &wanted) {
        bail!(
            "the shadings in {}: {why} (train.set_cap, train.seed): run with the settings that made them, or with --force",
            shadings.dir.display()
        );
    }
    // The box of the kept points (as `Bounds::around` takes it: finite points), and their
    // count (the set's arrays are reserved once).
    let (lo, hi, hits) = kept_bounds(&pick, scene.images.len());
    let left_out = before.map_or(0, |all| {
        crate::note!(
            "training set: {hits} of {all} pixels kept ({:.1} %): a round draws at most {} (train.set_cap × steps × batch)",
            100.0 * hits as f64 / all.max(1) as f64,
            cfg.set_limit().unwrap_or(0)
        );
        all - hits
    });
    let Some(bounds) = Bounds::around([lo, hi], 1.1) else {
        bail!("no training pixel hits the mesh: check the poses (`fipt info`)")
    };
    let mut data = gather(&pick, shadings, &scene.images, &bounds, hits)?;
    data.footprint = footprint;
    let lights = data.lights();
    if !cfg.emitter_material {
        crate::note!(
            "training set: {lights} of {} pixels ({:.2} %) are over {}× brighter than any reflection their shadings allow (a light's): they train the emission mask only (train.emitter_material)",
            data.len(),
            100.0 * lights as f64 / data.len().max(1) as f64,
            fipt_core::training_set::UNREFLECTABLE
        );
    }
    let mut data = with_segments(scene, data, segments, search)?;
    let mut targets_id = None;
    if let Some(t) = search.map(|s| &s.targets) {
        data = data.with_targets_by(|v, i| t.get(v, i))?;
        targets_id = Some(targets_fingerprint(&data));
    }
    Ok(BuiltSet {
        data,
        left_out,
        lights,
        targets_id,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A divided region's second side gets an id of its own per region (`base + k`); the
    /// first side, the background (-1) and pixels out of range are left alone.
    #[test]
    fn second_sides_become_parts_of_their_own() {
        let mut ids = vec![3, 3, 5, 0, -1];
        divide_ids(&mut ids, &[(0, 0), (2, 1), (99, 0)], 6);
        assert_eq!(ids, vec![6, 3, 7, 0, -1]);
    }

    /// The set keeps about `limit` of its hits, the same ones for the same seed, a uniform
    /// share of every view, and nothing is touched when the hits fit.
    #[test]
    fn keep_at_most_keeps_a_seeded_uniform_share() {
        let view = |n: usize| -> Vec<Option<Vec3>> {
            (0..n).map(|i| (i % 10 != 0).then_some(Vec3::ONE)).collect()
        };
        let points = vec![view(20_000), view(40_000)];
        let hits = |p: &[Vec<Option<Vec3>>]| -> Vec<usize> {
            p.iter().map(|v| v.iter().flatten().count()).collect()
        };
        let mut a = points.clone();
        assert_eq!(keep_at_most(&mut a, 60_000, 9), 0);
        assert_eq!(a, points);
        let left = keep_at_most(&mut a, 13_500, 9);
        let kept = hits(&a);
        assert_eq!(kept.iter().sum::<usize>() + left, 54_000);
        // Binomial: 13,500 ± 3 standard deviations (about 3·√(13,500·0.75)).
        assert!(
            kept.iter().sum::<usize>().abs_diff(13_500) < 310,
            "{kept:?}"
        );
        assert!(
            kept[0].abs_diff(4_500) < 200 && kept[1].abs_diff(9_000) < 250,
            "{kept:?}"
        );
        // Only hits are kept, and the same seed keeps the same pixels.
        assert!(a
            .iter()
            .flatten()
            .enumerate()
            .all(|(i, p)| p.is_none() || i % 10 != 0));
        let mut b = points.clone();
        keep_at_most(&mut b, 13_500, 9);
        assert_eq!(a, b);
        let mut c = points.clone();
        keep_at_most(&mut c, 13_500, 10);
        assert_ne!(a, c);
    }
}
