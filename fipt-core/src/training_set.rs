//! The training pixels a [`crate::trainer::FieldTrainer`] fits a field to: every training
//! pixel's shadings, image value and position, gathered view by view, with the segment ids and
//! the search's targets attached. Plain data: a method builds it, a trainer reads it.
use crate::cube::Cube;
use crate::error::{CoreError, Result};
use crate::image::Image;
use crate::shading::{ViewShadings, NUM_LEVELS};
use glam::Vec3;

/// The segment id of a sample in no segment.
pub const NO_SEGMENT: u32 = u32::MAX;

/// How many times brighter than the brightest reflection its shadings allow (kd = ks = 1 at the
/// roughness level that reflects most) a pixel must be to count as a light's.
pub const UNREFLECTABLE: f32 = 4.0;

/// Whether a pixel is more than [`UNREFLECTABLE`] times brighter (summed over channels) than
/// any material could make it under its shadings: a light's pixel, which no albedo explains.
pub fn unreflectable(
    ld: [f32; 3],
    ls0: &[[f32; 3]; NUM_LEVELS],
    ls1: &[[f32; 3]; NUM_LEVELS],
    gt: [f32; 3],
) -> bool {
    let most = |ls: &[[f32; 3]; NUM_LEVELS]| {
        ls.iter()
            .map(|l| l.iter().sum::<f32>())
            .fold(0f32, f32::max)
    };
    let bound = ld.iter().sum::<f32>() + most(ls0) + most(ls1);
    gt.iter().sum::<f32>() > UNREFLECTABLE * bound
}

/// The training pixels, structure of arrays.
pub struct TrainingSet {
    /// The box the positions are relative to ([`Cube::unit`]).
    pub bounds: Cube,
    /// How many views the set was gathered from (some may have left no pixel in it).
    pub views: usize,
    /// The world size of a pixel's footprint on the surface (the median over the views), when
    /// the builder knows it: a trainer may size its finest detail by it.
    pub footprint: Option<f32>,
    pub levels: [f32; NUM_LEVELS],
    /// Unit-cube positions of the primary hits.
    pub unit: Vec<[f32; 3]>,
    pub ld: Vec<[f32; 3]>,
    /// [Ld1, Ld2] of each sample when the shadings' diffuse part depends on σ, else empty.
    pub ld_poly: Vec<[[f32; 3]; 2]>,
    pub ls0: Vec<[[f32; 3]; NUM_LEVELS]>,
    pub ls1: Vec<[[f32; 3]; NUM_LEVELS]>,
    pub gt: Vec<[f32; 3]>,
    /// (view, pixel) of each sample.
    pub origin: Vec<(u32, u32)>,
    /// Morton code of each sample's position: batches are processed in this order, so that
    /// neighbouring rows share hash-grid cells and cache lines.
    pub morton: Vec<u64>,
    /// Dense segment id of each sample ([`NO_SEGMENT`] for none); empty without segments
    /// ([`TrainingSet::with_segments`]).
    pub segment: Vec<u32>,
    /// Number of distinct segment ids.
    pub segments: usize,
    /// The ids are semantic classes ([`TrainingSet::with_classes`]), not parts.
    pub semantic: bool,
    /// The material search's (σ*, m*) per sample (NaN: none); empty without a search
    /// ([`TrainingSet::with_targets`]).
    pub target: Vec<[f32; 2]>,
}

/// 3 × 21-bit Morton code of a unit-cube point.
fn morton(p: [f32; 3]) -> u64 {
    fn spread(x: u64) -> u64 {
        let mut x = x & 0x1F_FFFF;
        x = (x | x << 32) & 0x1F00000000FFFF;
        x = (x | x << 16) & 0x1F0000FF0000FF;
        x = (x | x << 8) & 0x100F00F00F00F00F;
        x = (x | x << 4) & 0x10C30C30C30C30C3;
        (x | x << 2) & 0x1249249249249249
    }
    let q = |v: f32| (v.clamp(0.0, 1.0) * 2_097_151.0) as u64;
    spread(q(p[0])) | spread(q(p[1])) << 1 | spread(q(p[2])) << 2
}

impl TrainingSet {
    /// Gathers every pixel with a primary hit and valid shadings. `points[v][i]` is the primary
    /// hit of pixel `i` of view `v` (None on a miss).
    pub fn new(
        points: &[Vec<Option<Vec3>>],
        shadings: &[ViewShadings],
        images: &[Image],
        bounds: &Cube,
    ) -> Result<Self> {
        if points.len() != shadings.len() || images.len() != shadings.len() {
            return Err(CoreError::config(
                "training set",
                format!(
                    "{} point sets, {} shadings, {} images: one of each per view is needed",
                    points.len(),
                    shadings.len(),
                    images.len()
                ),
            ));
        }
        Self::from_views(points, images, bounds, |v| Ok(shadings[v].clone()))
    }

    /// [`TrainingSet::new`] with each view's shadings asked of `shading(v)` in view order and
    /// let go after its pixels are gathered (the set then never sits beside every view's
    /// shadings). `shading`'s errors pass through.
    pub fn from_views<E: From<CoreError>>(
        points: &[Vec<Option<Vec3>>],
        images: &[Image],
        bounds: &Cube,
        shading: impl FnMut(usize) -> std::result::Result<ViewShadings, E>,
    ) -> std::result::Result<Self, E> {
        let hits = points.iter().flatten().flatten().count();
        Self::from_view_points(
            (points.len(), hits),
            |v| Ok(points[v].clone()),
            images,
            bounds,
            shading,
        )
    }

    /// [`TrainingSet::from_views`] with each view's points also made on demand, by
    /// `points(v)` in view order, so that no more than one view's points are held; `counts`
    /// is (views, hits over all views: the arrays are reserved once, so that growing never
    /// holds two copies).
    pub fn from_view_points<E: From<CoreError>>(
        counts: (usize, usize),
        mut points: impl FnMut(usize) -> std::result::Result<Vec<Option<Vec3>>, E>,
        images: &[Image],
        bounds: &Cube,
        mut shading: impl FnMut(usize) -> std::result::Result<ViewShadings, E>,
    ) -> std::result::Result<Self, E> {
        let (views, hits) = counts;
        if images.len() != views {
            return Err(CoreError::config(
                "training set",
                format!(
                    "{views} point sets, {} images: one of each per view is needed",
                    images.len()
                ),
            )
            .into());
        }
        let mut set = TrainingSet {
            bounds: *bounds,
            views,
            footprint: None,
            levels: crate::shading::DEFAULT_LEVELS,
            unit: vec![],
            ld: vec![],
            ld_poly: vec![],
            ls0: vec![],
            ls1: vec![],
            gt: vec![],
            origin: vec![],
            morton: vec![],
            segment: vec![],
            segments: 0,
            semantic: false,
            target: vec![],
        };
        set.reserve(hits);
        let mut poly = false;
        for (v, img) in images.iter().enumerate() {
            let pts = points(v)?;
            let sh = shading(v)?;
            if v == 0 {
                (set.levels, poly) = (sh.levels, !sh.ld_poly.is_empty());
            }
            if v == 0 && poly {
                set.ld_poly.reserve(hits);
            }
            set.push_view(v, &pts, &sh, img, bounds, poly)?;
        }
        Ok(set)
    }

    fn reserve(&mut self, n: usize) {
        self.unit.reserve(n);
        self.morton.reserve(n);
        self.ld.reserve(n);
        self.ls0.reserve(n);
        self.ls1.reserve(n);
        self.gt.reserve(n);
        self.origin.reserve(n);
    }

    /// Appends view `v`'s pixels with a primary hit and valid shadings.
    fn push_view(
        &mut self,
        v: usize,
        pts: &[Option<Vec3>],
        sh: &ViewShadings,
        img: &Image,
        bounds: &Cube,
        poly: bool,
    ) -> Result<()> {
        let n = sh.width * sh.height;
        if poly == sh.ld_poly.is_empty() {
            return Err(CoreError::config(
                "training set",
                format!("view {v}: shadings of two reflectance models are mixed"),
            ));
        }
        if pts.len() != n || img.data.len() != n || sh.levels != self.levels {
            return Err(CoreError::config(
                "training set",
                format!(
                    "view {v}: sizes or roughness levels differ between shadings, hits and image"
                ),
            ));
        }
        for i in 0..n {
            let Some(p) = pts[i] else { continue };
            if !sh.valid[i] {
                continue;
            }
            let arr = |x: &[Vec3; NUM_LEVELS]| x.map(|c| c.to_array());
            self.unit.push(bounds.unit(p));
            self.morton.push(morton(bounds.unit(p)));
            self.ld.push(sh.ld[i].to_array());
            if let Some(p) = sh.poly(i) {
                self.ld_poly.push(p.map(|c| c.to_array()));
            }
            self.ls0.push(arr(&sh.ls0[i]));
            self.ls1.push(arr(&sh.ls1[i]));
            self.gt.push(img.data[i].to_array());
            self.origin.push((v as u32, i as u32));
        }
        Ok(())
    }

    /// Attaches segment ids: `ids[v][i]` is the id of pixel `i` of view `v` (a part or
    /// semantic id as stored in the scene; negative for none). Ids are renumbered densely.
    pub fn with_segments(self, ids: &[Vec<i64>]) -> Result<Self> {
        self.with_segments_by(ids.len(), |views| {
            Ok(views.iter().map(|&v| ids[v].clone()).collect())
        })
    }

    /// [`TrainingSet::with_segments`] with the ids read a few views at a time: `ids_of(views)`
    /// gives those views' ids (of `n_views`), so that every view's ids need not be held at
    /// once (8 bytes a pixel of every view). A set whose pixels are grouped by view (as
    /// built) reads each view once.
    pub fn with_segments_by(
        mut self,
        n_views: usize,
        mut ids_of: impl FnMut(&[usize]) -> Result<Vec<Vec<i64>>>,
    ) -> Result<Self> {
        const CHUNK: usize = 16;
        // The views in order of first appearance, and where each first appears.
        let mut first = std::collections::BTreeMap::new();
        let mut views: Vec<usize> = vec![];
        for &(v, _) in &self.origin {
            first.entry(v as usize).or_insert_with(|| {
                views.push(v as usize);
                views.len() - 1
            });
        }
        if let Some(&v) = views.iter().find(|&&v| v >= n_views) {
            return Err(CoreError::config(
                "segments",
                format!("no ids for view {v}: one id per pixel of every view is needed"),
            ));
        }
        let mut dense: std::collections::BTreeMap<i64, u32> = Default::default();
        let mut held: Vec<(usize, Vec<i64>)> = vec![];
        let mut width = None;
        let mut segment = Vec::with_capacity(self.len());
        for &(v, i) in &self.origin {
            let v = v as usize;
            let h = match held.iter().position(|h| h.0 == v) {
                Some(h) => h,
                None => {
                    let at = first[&v];
                    let chunk = &views[at..(at + CHUNK).min(views.len())];
                    let read = ids_of(chunk)?;
                    if read.len() != chunk.len() {
                        return Err(CoreError::config(
                            "segments",
                            format!("{} views' ids given for {}", read.len(), chunk.len()),
                        ));
                    }
                    held = chunk.iter().copied().zip(read).collect();
                    for (w, view) in &held {
                        match width {
                            None => width = Some((*w, view.len())),
                            Some((w0, n)) if n != view.len() => {
                                return Err(CoreError::config(
                                    "segments",
                                    format!("view {w} has {} ids, view {w0} {n}", view.len()),
                                ))
                            }
                            _ => {}
                        }
                    }
                    0 // the chunk starts at view v
                }
            };
            let id = (held[h].1.get(i as usize)).copied().ok_or_else(|| {
                CoreError::config(
                    "segments",
                    format!(
                        "no id for pixel {i} of view {v}: one id per pixel of every view is needed"
                    ),
                )
            })?;
            segment.push(if id < 0 {
                NO_SEGMENT
            } else {
                let next = dense.len() as u32;
                *dense.entry(id).or_insert(next)
            });
        }
        self.segments = dense.len();
        self.segment = segment;
        Ok(self)
    }

    /// Attaches the material search's targets: `targets[v][i]` is (σ*, m*) of pixel `i` of view
    /// `v`, None where the search has none (the default prior applies there).
    pub fn with_targets(self, targets: &[Vec<Option<[f32; 2]>>]) -> Result<Self> {
        self.with_targets_by(|v, i| targets.get(v).and_then(|view| view.get(i)).copied())
    }

    /// [`TrainingSet::with_targets`] with the targets looked up: `target(v, i)` is pixel `i` of
    /// view `v`'s (σ*, m*) or None, and None itself outside the views.
    pub fn with_targets_by(
        mut self,
        target: impl Fn(usize, usize) -> Option<Option<[f32; 2]>>,
    ) -> Result<Self> {
        let mut out = Vec::with_capacity(self.len());
        for &(v, i) in &self.origin {
            let t = target(v as usize, i as usize)
                .ok_or_else(|| {
                    CoreError::config(
                        "targets",
                        format!("no target entry for pixel {i} of view {v}: one per pixel of every view is needed"),
                    )
                })?;
            out.push(t.unwrap_or([f32::NAN; 2]));
        }
        self.target = out;
        Ok(self)
    }

    /// [`TrainingSet::with_segments`] for semantic classes: the semantic prior is used.
    pub fn with_classes(self, ids: &[Vec<i64>]) -> Result<Self> {
        let mut s = self.with_segments(ids)?;
        s.semantic = true;
        Ok(s)
    }

    /// [`TrainingSet::with_classes`] with the ids read a few views at a time, as
    /// [`TrainingSet::with_segments_by`].
    pub fn with_classes_by(
        self,
        n_views: usize,
        ids_of: impl FnMut(&[usize]) -> Result<Vec<Vec<i64>>>,
    ) -> Result<Self> {
        let mut s = self.with_segments_by(n_views, ids_of)?;
        s.semantic = true;
        Ok(s)
    }

    pub fn len(&self) -> usize {
        self.unit.len()
    }
    pub fn is_empty(&self) -> bool {
        self.unit.is_empty()
    }
    /// How many samples are a light's ([`unreflectable`]).
    pub fn lights(&self) -> usize {
        (0..self.len())
            .filter(|&j| unreflectable(self.ld[j], &self.ls0[j], &self.ls1[j], self.gt[j]))
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set of `origin` alone (what the segment ids read).
    fn set_of(origin: Vec<(u32, u32)>) -> TrainingSet {
        TrainingSet {
            bounds: Cube::around([Vec3::ZERO, Vec3::ONE], 1.0).unwrap(),
            views: 41,
            footprint: None,
            levels: crate::shading::DEFAULT_LEVELS,
            unit: vec![[0.0; 3]; origin.len()],
            ld: vec![],
            ld_poly: vec![],
            ls0: vec![],
            ls1: vec![],
            gt: vec![],
            origin,
            morton: vec![],
            segment: vec![],
            segments: 0,
            semantic: false,
            target: vec![],
        }
    }

    /// Read a few views at a time, the ids number the segments as read all at once, in the
    /// set's order or any other, and each view is read once when the set goes view by view.
    #[test]
    fn ids_read_by_chunks_number_the_segments_as_all_at_once() {
        let ids: Vec<Vec<i64>> = (0..40)
            .map(|v| (0..12).map(|i| ((v * 7 + i * 3) % 11) as i64 - 1).collect())
            .collect();
        let ordered: Vec<(u32, u32)> = (0..40u32)
            .filter(|v| v % 3 != 1)
            .flat_map(|v| {
                (0..12u32)
                    .filter(move |i| (v + i) % 2 == 0)
                    .map(move |i| (v, i))
            })
            .collect();
        let mut shuffled = ordered.clone();
        shuffled.reverse();
        shuffled.swap(3, 40);
        for origin in [ordered, shuffled] {
            let all = set_of(origin.clone()).with_segments(&ids).unwrap();
            let mut reads = vec![0; ids.len()];
            let by = set_of(origin.clone())
                .with_segments_by(ids.len(), |views| {
                    views.iter().for_each(|&v| reads[v] += 1);
                    Ok(views.iter().map(|&v| ids[v].clone()).collect())
                })
                .unwrap();
            assert_eq!((by.segment, by.segments), (all.segment, all.segments));
            // The swap took a pixel out of its view's group: one view at most is read twice.
            assert!(reads.iter().all(|&n| n <= 2), "{reads:?}");
            assert!(reads.iter().filter(|&&n| n == 2).count() <= 1, "{reads:?}");
        }
        // A view past the ids, and a view of another width, are errors naming them.
        let e = set_of(vec![(41, 0)]).with_segments(&ids).err().unwrap();
        assert!(e.to_string().contains("view 41"), "{e}");
        let mut uneven = ids.clone();
        uneven[2].push(0);
        let e = set_of(vec![(0, 0), (2, 0)])
            .with_segments(&uneven)
            .err()
            .unwrap();
        assert!(e.to_string().contains("view 2 has 13 ids"), "{e}");
    }
}
