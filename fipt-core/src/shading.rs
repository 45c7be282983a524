//! The factorised shading model (method §3) and the contracts of the stages that compute it.
//!
//! L(x, ωo) = Le + kd·Ld(x) + ks·Ls0(x, ωo, σ) + Ls1(x, ωo, σ): the diffuse shading Ld and the
//! two specular shadings Ls0/Ls1 are baked once per training pixel, Ls0/Ls1 at
//! [`NUM_LEVELS`] roughness levels and linearly interpolated in σ ([`lerp_levels`]). Under a
//! reflectance model whose diffuse lobe depends on σ (`principled`), Ld is the polynomial
//! Ld0 + σ·Ld1 + σ²·Ld2 (exact, see [`crate::reflectance`]) and the shadings carry Ld1, Ld2.
//! [`ShadingBaker`] computes them first from the observed radiance alone; a
//! [`ShadingRefiner`] re-computes them once a material field and emitters are known.
use crate::color::Rgb;
use crate::dataset::View;
use crate::emitter::Emitter;
use crate::error::Result;
use crate::field::MaterialField;
use crate::image::Image;
use glam::Vec3;

/// Number of roughness levels at which the specular shadings are baked.
pub const NUM_LEVELS: usize = 6;

/// The reference's levels: linspace(0.02, 1.0, 6).
pub const DEFAULT_LEVELS: [f32; NUM_LEVELS] = [0.02, 0.216, 0.412, 0.608, 0.804, 1.0];

/// Piecewise-linear interpolation of per-level values at roughness `sigma` (clamped to the
/// first/last level). Exact at the levels, continuous between them. `levels` must increase.
#[inline]
pub fn lerp_levels(levels: &[f32; NUM_LEVELS], values: &[Rgb; NUM_LEVELS], sigma: f32) -> Rgb {
    let (i, t) = level_segment(levels, sigma);
    values[i] * (1.0 - t) + values[i + 1] * t
}

/// The segment `[levels[i], levels[i+1]]` holding σ (clamped to the levels' range; NaN → the
/// first level) and the position `t ∈ [0, 1]` in it: the weights of [`lerp_levels`].
#[inline]
pub fn level_segment(levels: &[f32; NUM_LEVELS], sigma: f32) -> (usize, f32) {
    let s = if sigma.is_nan() {
        levels[0]
    } else {
        sigma.clamp(levels[0], levels[NUM_LEVELS - 1])
    };
    let mut i = 0;
    while i + 2 < NUM_LEVELS && s > levels[i + 1] {
        i += 1;
    }
    let (a, b) = (levels[i], levels[i + 1]);
    let t = if b > a {
        ((s - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (i, t)
}

/// Baked shadings of one view, pixel-major (row by row from the top).
#[derive(Clone, Debug, PartialEq)]
pub struct ViewShadings {
    pub width: usize,
    pub height: usize,
    pub levels: [f32; NUM_LEVELS],
    /// Ld per pixel (Ld0 when [`ViewShadings::ld_poly`] is not empty).
    pub ld: Vec<Rgb>,
    /// [Ld1, Ld2] per pixel when the model's diffuse lobe depends on σ, else empty.
    pub ld_poly: Vec<[Rgb; 2]>,
    /// Ls0 per pixel and level.
    pub ls0: Vec<[Rgb; NUM_LEVELS]>,
    /// Ls1 per pixel and level.
    pub ls1: Vec<[Rgb; NUM_LEVELS]>,
    /// Whether the pixel-centre ray hit the mesh (shadings are 0 elsewhere).
    pub valid: Vec<bool>,
}

impl ViewShadings {
    /// All-zero shadings for a `width × height` view.
    pub fn zeros(width: usize, height: usize, levels: [f32; NUM_LEVELS]) -> Self {
        let n = width * height;
        ViewShadings {
            width,
            height,
            levels,
            ld: vec![Vec3::ZERO; n],
            ld_poly: Vec::new(),
            ls0: vec![[Vec3::ZERO; NUM_LEVELS]; n],
            ls1: vec![[Vec3::ZERO; NUM_LEVELS]; n],
            valid: vec![false; n],
        }
    }

    /// All-zero shadings whose diffuse shading is a polynomial in σ when `poly`.
    pub fn zeros_for(width: usize, height: usize, levels: [f32; NUM_LEVELS], poly: bool) -> Self {
        let mut s = Self::zeros(width, height, levels);
        if poly {
            s.ld_poly = vec![[Vec3::ZERO; 2]; width * height];
        }
        s
    }

    /// The pixels `idx` (in that order) as one row: what a stage that reads only some pixels
    /// keeps of a view.
    pub fn select(&self, idx: &[u32]) -> ViewShadings {
        let pick = |i: &u32| *i as usize;
        ViewShadings {
            width: idx.len(),
            height: 1,
            levels: self.levels,
            ld: idx.iter().map(|i| self.ld[pick(i)]).collect(),
            ld_poly: if self.ld_poly.is_empty() {
                vec![]
            } else {
                idx.iter().map(|i| self.ld_poly[pick(i)]).collect()
            },
            ls0: idx.iter().map(|i| self.ls0[pick(i)]).collect(),
            ls1: idx.iter().map(|i| self.ls1[pick(i)]).collect(),
            valid: idx.iter().map(|i| self.valid[pick(i)]).collect(),
        }
    }

    /// [Ld1, Ld2] of pixel `i`, or None when Ld does not depend on σ.
    #[inline]
    pub fn poly(&self, i: usize) -> Option<&[Rgb; 2]> {
        self.ld_poly.get(i)
    }

    /// The diffuse shading of pixel `i` at roughness σ.
    #[inline]
    pub fn diffuse(&self, i: usize, sigma: f32) -> Rgb {
        crate::reflectance::diffuse_at(self.ld[i], self.poly(i), sigma).0
    }

    /// Reflected radiance of pixel `i` for material (kd, ks, σ): kd·Ld(σ) + ks·Ls0(σ) + Ls1(σ).
    #[inline]
    pub fn reflected(&self, i: usize, kd: Rgb, ks: Rgb, sigma: f32) -> Rgb {
        crate::reflectance::image(
            kd,
            ks,
            self.diffuse(i, sigma),
            lerp_levels(&self.levels, &self.ls0[i], sigma),
            lerp_levels(&self.levels, &self.ls1[i], sigma),
        )
    }
}

/// A surface hit as the shading stages see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    /// Distance along the unit ray direction.
    pub t: f32,
    /// Mesh triangle index.
    pub tri: u32,
    /// Hit point.
    pub p: Vec3,
    /// Unit geometric normal (stored winding, not flipped).
    pub ng: Vec3,
    /// Unit shading normal on the side of `ng`.
    pub ns: Vec3,
}

/// The ray queries the shading stages need; implemented by fipt-geom's `Geometry`.
pub trait RayQuery: Sync {
    /// Closest hit along `origin + t·dir`, t > 0 (`dir` unit length).
    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit>;
    /// Whether anything lies on `origin + t·dir` for t in (0, tmax).
    fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool;
    /// A ray origin moved off the surface at `p` to the side of `n`.
    fn offset(&self, p: Vec3, n: Vec3) -> Vec3;
    /// Axis-aligned bounds of the geometry.
    fn bounds(&self) -> (Vec3, Vec3);
}

/// Progress callback: `(units done so far in this call, total units)`.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Receives each finished view's shadings by view index, in view order: the caller writes it
/// and lets it go, so that a stage need not hold every view at once.
pub type ViewSink<'a> = &'a mut dyn FnMut(usize, ViewShadings) -> Result<()>;

/// A stage's output and what it reports about the work (counts, timings), as JSON for
/// `report.json` and the stage's manifest.
pub struct Reported<T> {
    pub output: T,
    pub report: serde_json::Value,
}

/// Which views of a per-view stage one process computes, for spreading a stage over the tasks
/// of a job array: view `k` is in shard `index` of `count` when `k % count == index` (every
/// shard gets a spread of the views). [`Shard::ALL`] is the whole stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// Every view: the unsharded stage.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Shard `index` (0-based) of `count`; `None` unless `index < count`.
    pub fn new(index: usize, count: usize) -> Option<Shard> {
        (index < count).then_some(Shard { index, count })
    }

    /// Whether view `k` is this shard's.
    pub fn contains(&self, k: usize) -> bool {
        k % self.count == self.index
    }

    /// Whether this is the whole stage.
    pub fn is_all(&self) -> bool {
        self.count == 1
    }

    /// Per view of `n`: whether it is this shard's.
    pub fn mask(&self, n: usize) -> Vec<bool> {
        (0..n).map(|k| self.contains(k)).collect()
    }
}

impl std::str::FromStr for Shard {
    type Err = String;
    /// `K/N`: shard K (0-based) of N.
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let bad = || {
            format!("shard `{s}`: use K/N with 0 ≤ K < N (e.g. 0/4; a Slurm array gives K as $SLURM_ARRAY_TASK_ID)")
        };
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        Shard::new(k, n).ok_or_else(bad)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Which hit pixels of its views a per-view stage computes: every one ([`PixelDraw::ALL`]) or
/// the uniform random `share` that [`crate::rng::pixel_kept`] keeps from (`seed`, view,
/// pixel). Draws with one seed nest: a pixel drawn at one share is drawn at every larger one,
/// so a stage computed for a draw serves every consumer whose own share (same seed) is no
/// larger. A run draws before its bake the union of what its consumers will read (the
/// training set's and the search's shares), so that the bake and the refinement pay for
/// those pixels only.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PixelDraw {
    pub seed: u64,
    /// In (0, 1]; 1: every pixel.
    pub share: f64,
}

impl Default for PixelDraw {
    fn default() -> Self {
        PixelDraw::ALL
    }
}

impl PixelDraw {
    /// Every pixel.
    pub const ALL: PixelDraw = PixelDraw {
        seed: 0,
        share: 1.0,
    };

    /// The draw of `share` from `seed`; every pixel when `share` is None or at least 1.
    pub fn new(seed: u64, share: Option<f64>) -> PixelDraw {
        match share {
            Some(share) if share < 1.0 => PixelDraw {
                seed,
                share: share.max(0.0),
            },
            _ => PixelDraw::ALL,
        }
    }

    /// Whether every pixel is drawn.
    pub fn is_all(&self) -> bool {
        self.share >= 1.0
    }

    /// Whether pixel `pixel` of view `view` is drawn.
    #[inline]
    pub fn keeps(&self, view: usize, pixel: usize) -> bool {
        crate::rng::pixel_kept(self.seed, view, pixel, self.share)
    }

    /// What a cache key adds for this draw: nothing for every pixel (keys of stages made
    /// before draws existed stay valid), else its seed and share.
    pub fn key_tag(&self) -> String {
        if self.is_all() {
            String::new()
        } else {
            format!("|{}|{}", self.seed, self.share)
        }
    }

    /// Whether every pixel `other` draws is drawn here.
    pub fn covers(&self, other: &PixelDraw) -> bool {
        self.is_all() || (self.seed == other.seed && self.share >= other.share)
    }

    /// View `view`'s per-pixel entries with those not drawn set to None (a miss, to a stage).
    pub fn clear_undrawn<T>(&self, view: usize, pixels: &mut [Option<T>]) {
        if self.is_all() {
            return;
        }
        for (i, p) in pixels.iter_mut().enumerate() {
            if p.is_some() && !self.keeps(view, i) {
                *p = None;
            }
        }
    }
}

impl std::fmt::Display for PixelDraw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.is_all() {
            write!(f, "every pixel")
        } else {
            write!(
                f,
                "a {:.2} % share (seed {})",
                100.0 * self.share,
                self.seed
            )
        }
    }
}

/// What a per-view stage computes: `shard`'s views, and of their hit pixels those `pixels`
/// draws. A stage may compute more (a superset is correct, not faster); the pixels it leaves
/// out read as misses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scope {
    pub shard: Shard,
    pub pixels: PixelDraw,
}

impl Scope {
    /// Every view, every pixel.
    pub const ALL: Scope = Scope {
        shard: Shard::ALL,
        pixels: PixelDraw::ALL,
    };
}

impl From<Shard> for Scope {
    /// Every pixel of `shard`'s views.
    fn from(shard: Shard) -> Scope {
        Scope {
            shard,
            pixels: PixelDraw::ALL,
        }
    }
}

/// Computes the shadings of the training views (initial bake, method §4.2).
pub trait ShadingBaker {
    /// A short name for reports.
    fn name(&self) -> &str;
    /// What this baker leaves out or does otherwise under its settings and model (one
    /// sentence each), for the run's log and `report.json`'s `modeled`. None by default.
    fn caveats(&self) -> Vec<String> {
        vec![]
    }
    /// Shadings of every view in `views` (HDR `images` in the same order), and the bake's report.
    fn bake(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        progress: Progress,
    ) -> Result<Reported<Vec<ViewShadings>>>;

    /// The shadings of `shard`'s views, bit-identical to those [`ShadingBaker::bake`] gives
    /// them; the other views' entries may be left empty. What is shared by all views (an
    /// incident-light cache) is built from all of them in every shard. The default bakes every
    /// view (correct, not faster); a baker that can skip views overrides it.
    fn bake_shard(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        shard: Shard,
        progress: Progress,
    ) -> Result<Reported<Vec<ViewShadings>>> {
        let _ = shard;
        self.bake(geometry, views, images, progress)
    }

    /// [`ShadingBaker::bake_shard`] handing each of `shard`'s views to `sink` as it is done;
    /// returns the report. Of those views' hit pixels it computes at least those
    /// `scope.pixels` draws; the others may read as misses. The default bakes every pixel of
    /// the shard, then hands its views over; a baker that can hold one view at a time and
    /// skip pixels overrides it (the stage's memory then does not grow with the number of
    /// views, nor its time with the pixels no one reads).
    fn bake_into(
        &self,
        geometry: &dyn RayQuery,
        views: &[View],
        images: &[Image],
        scope: Scope,
        progress: Progress,
        sink: ViewSink,
    ) -> Result<serde_json::Value> {
        let baked = self.bake_shard(geometry, views, images, scope.shard, progress)?;
        hand_over(baked, scope.shard, sink)
    }
}

/// Hands a stage's `shard` views to `sink`, in order; returns the report.
fn hand_over(
    done: Reported<Vec<ViewShadings>>,
    shard: Shard,
    sink: ViewSink,
) -> Result<serde_json::Value> {
    for (k, s) in done.output.into_iter().enumerate() {
        if shard.contains(k) {
            sink(k, s)?;
        }
    }
    Ok(done.report)
}

/// What a [`ShadingRefiner`] works from: the scene, the training views and their images, the
/// material field of the last training round and the extracted emitters.
pub struct RefineInputs<'a> {
    pub geometry: &'a dyn RayQuery,
    /// Mesh vertex positions and triangles (the triangle indices of `emitters` and of
    /// [`SurfaceHit::tri`] index `triangles`).
    pub positions: &'a [Vec3],
    pub triangles: &'a [[u32; 3]],
    pub views: &'a [View],
    pub images: &'a [Image],
    pub field: &'a dyn MaterialField,
    pub emitters: &'a [Emitter],
}

/// Re-computes the shadings of the training views once materials and emitters are known
/// (method §4.5, path growing), for the next training round.
pub trait ShadingRefiner {
    /// A short name for reports.
    fn name(&self) -> &str;
    /// As [`ShadingBaker::caveats`].
    fn caveats(&self) -> Vec<String> {
        vec![]
    }
    /// Shadings of every view of `inputs.views`, in the same order, and the refinement's report.
    fn refine(
        &self,
        inputs: &RefineInputs,
        progress: Progress,
    ) -> Result<Reported<Vec<ViewShadings>>>;

    /// The shadings of `shard`'s views, bit-identical to those of [`ShadingRefiner::refine`];
    /// the other views' entries may be left empty. The default refines every view.
    fn refine_shard(
        &self,
        inputs: &RefineInputs,
        shard: Shard,
        progress: Progress,
    ) -> Result<Reported<Vec<ViewShadings>>> {
        let _ = shard;
        self.refine(inputs, progress)
    }

    /// [`ShadingRefiner::refine_shard`] handing each of `scope.shard`'s views to `sink` as it
    /// is done, with at least the hit pixels `scope.pixels` draws computed (the others may
    /// read as misses); returns the report. The default refines every pixel of the shard,
    /// then hands its views over.
    fn refine_into(
        &self,
        inputs: &RefineInputs,
        scope: Scope,
        progress: Progress,
        sink: ViewSink,
    ) -> Result<serde_json::Value> {
        let refined = self.refine_shard(inputs, scope.shard, progress)?;
        hand_over(refined, scope.shard, sink)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A selection is a row of the chosen pixels in the given order, each with all its
    /// shadings, and its reflected radiance is the view's at those pixels.
    #[test]
    fn select_keeps_the_chosen_pixels_in_order() {
        let mut v = ViewShadings::zeros_for(3, 2, DEFAULT_LEVELS, true);
        for i in 0..6 {
            let x = Vec3::splat(i as f32);
            v.ld[i] = x;
            v.ld_poly[i] = [x * 0.5, x * 0.25];
            v.ls0[i] = [x * 2.0; NUM_LEVELS];
            v.ls1[i] = [x * 3.0; NUM_LEVELS];
            v.valid[i] = i % 2 == 0;
        }
        let s = v.select(&[4, 1, 4]);
        assert_eq!((s.width, s.height, s.levels), (3, 1, v.levels));
        for (j, &i) in [4usize, 1, 4].iter().enumerate() {
            let (kd, ks) = (Vec3::new(0.3, 0.5, 0.7), Vec3::splat(0.04));
            assert_eq!(s.reflected(j, kd, ks, 0.4), v.reflected(i, kd, ks, 0.4));
            assert_eq!((s.ld_poly[j], s.valid[j]), (v.ld_poly[i], v.valid[i]));
        }
        let lambert = ViewShadings::zeros(2, 1, DEFAULT_LEVELS).select(&[1]);
        assert!(lambert.ld_poly.is_empty() && lambert.ld.len() == 1);
    }

    fn values() -> [Rgb; NUM_LEVELS] {
        std::array::from_fn(|i| Vec3::new(i as f32, (i * i) as f32, -(i as f32)))
    }

    #[test]
    fn shards_parse_and_partition_the_views() {
        let s: Shard = "1/3".parse().unwrap();
        assert_eq!(s, Shard { index: 1, count: 3 });
        assert_eq!(s.to_string(), "1/3");
        for bad in ["3/3", "1", "a/2", "0/0", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        // Every view in exactly one shard.
        for k in 0..10 {
            let owners = (0..3)
                .filter(|&i| Shard::new(i, 3).unwrap().contains(k))
                .count();
            assert_eq!(owners, 1);
        }
        assert!(Shard::ALL.is_all() && Shard::ALL.mask(4).iter().all(|&b| b));
    }

    #[test]
    fn lerp_is_exact_at_levels_and_continuous_between() {
        let v = values();
        for (i, &l) in DEFAULT_LEVELS.iter().enumerate() {
            assert_eq!(lerp_levels(&DEFAULT_LEVELS, &v, l), v[i], "level {i}");
        }
        // Continuity: small steps give small changes everywhere, including across levels.
        let mut prev = lerp_levels(&DEFAULT_LEVELS, &v, 0.0);
        let n = 10_000;
        for k in 1..=n {
            let s = k as f32 / n as f32 * 1.1;
            let cur = lerp_levels(&DEFAULT_LEVELS, &v, s);
            assert!(
                (cur - prev).abs().max_element() <= 25.0 * 1.1 / n as f32 / 0.196 + 1e-4,
                "jump at σ={s}"
            );
            prev = cur;
        }
        // Midpoint of the reference formula r = (σ−0.02)/0.98·5.
        let mid = lerp_levels(&DEFAULT_LEVELS, &v, 0.02 + 0.98 * 2.5 / 5.0);
        assert!((mid - (v[2] + v[3]) * 0.5).abs().max_element() < 1e-4);
        // Extremes are finite and clamped.
        for s in [0.02f32, 1.0, -1.0, 7.0, f32::NAN] {
            assert!(lerp_levels(&DEFAULT_LEVELS, &v, s).is_finite());
        }
        assert_eq!(lerp_levels(&DEFAULT_LEVELS, &v, 5.0), v[5]);
    }

    /// A draw keeps its share of the pixels (within 4 standard deviations), the draws of one
    /// seed nest (what a smaller share keeps, a larger one keeps), `covers` says so, and the
    /// pixels not drawn become misses.
    #[test]
    fn draws_keep_their_share_and_nest() {
        let (views, pixels) = (4, 5_000);
        let all = (views * pixels) as f64;
        let count = |d: &PixelDraw| {
            (0..views)
                .flat_map(|v| (0..pixels).map(move |i| (v, i)))
                .filter(|&(v, i)| d.keeps(v, i))
                .count() as f64
        };
        for share in [0.01, 0.13, 0.5, 0.9] {
            let d = PixelDraw::new(11, Some(share));
            let sd = (all * share * (1.0 - share)).sqrt();
            assert!((count(&d) - all * share).abs() < 4.0 * sd, "share {share}");
        }
        let (small, large) = (PixelDraw::new(11, Some(0.2)), PixelDraw::new(11, Some(0.6)));
        for v in 0..views {
            for i in 0..pixels {
                assert!(
                    !small.keeps(v, i) || large.keeps(v, i),
                    "view {v} pixel {i}"
                );
            }
        }
        assert!(large.covers(&small) && !small.covers(&large));
        assert!(
            !PixelDraw::new(12, Some(0.6)).covers(&small),
            "another seed draws others"
        );
        assert!(PixelDraw::ALL.covers(&small) && !small.covers(&PixelDraw::ALL));
        assert_eq!(PixelDraw::new(11, Some(1.0)), PixelDraw::ALL);
        assert_eq!(PixelDraw::new(11, None), PixelDraw::ALL);
        let mut row: Vec<Option<u32>> = (0..1000).map(|i| (i % 7 != 0).then_some(i)).collect();
        small.clear_undrawn(2, &mut row);
        for (i, p) in row.iter().enumerate() {
            assert_eq!(p.is_some(), i % 7 != 0 && small.keeps(2, i), "pixel {i}");
        }
        let mut same: Vec<Option<u32>> = vec![Some(1); 10];
        PixelDraw::ALL.clear_undrawn(0, &mut same);
        assert!(same.iter().all(Option::is_some));
        assert_eq!(
            Scope::from(Shard::new(1, 2).unwrap()).pixels,
            PixelDraw::ALL
        );
    }
}
