//! The diffuse shading Ld and its cache, for every [`ReflectanceModel`].
//!
//! Under FIPT's Lambert lobe Ld = (1/π)∫ Li cos θi dω does not depend on the view. Under
//! `principled` the diffuse factor is b0 + σ·b1 + σ²·b2 (see [`fipt_core::reflectance`]) and
//! each b_k depends on ωo, but only through F_o = (1 − cos θo)⁵ and ωi·ωo:
//!
//! * b0 = (1 − F_o/2)·(1 − F_i/2),
//! * b1 = (1 + ωi·ωo)·(F_o + F_i·(1 − F_o)),
//! * b2 = (1 + ωi·ωo)²·F_o·F_i.
//!
//! So a few view-independent moments of the incident light ([`DiffuseMoments`]: Σ L, Σ L·ωi,
//! Σ L·F_i, Σ L·F_i·ωi, Σ L·F_i·ωi ωiᵀ, Σ L·(1 − F_i/2)) give Ld0, Ld1 and Ld2 exactly for any
//! ωo ([`DiffuseMoments::shading`]), and the diffuse cache (one integral per surface cell, shared
//! by every pixel of every view that sees it) serves both models.
use crate::stream::SampleStream;
use fipt_core::brdf::Frame;
use fipt_core::color::Rgb;
use fipt_core::hash::GridMap as HashMap;
use fipt_core::parted::PartedMap;
use fipt_core::reflectance::{schlick_weight, ReflectanceModel};
use fipt_core::rng::Pcg32;
use fipt_core::shading::{RayQuery, ViewShadings};
use fipt_shading::brdf::sample_cosine_hemisphere;
use fipt_shading::incident::{power_heuristic, IncidentLight, Incoming, Pending};
use fipt_shading::records::PixelRecord;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

/// View-independent integrals of the incident light at a point (each an estimate of
/// (1/π)∫ Li·g(ωi)·cos θi dω for the g named), from which the diffuse shadings of any view follow.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiffuseMoments {
    /// g = 1: Lambert's Ld.
    pub m0: Rgb,
    /// g = ωi (world), per axis.
    pub m1: [Rgb; 3],
    /// g = 1 − F_i/2.
    pub a: Rgb,
    /// g = F_i.
    pub n0: Rgb,
    /// g = F_i·ωi.
    pub n1: [Rgb; 3],
    /// g = F_i·ωi ωiᵀ (xx, xy, xz, yy, yz, zz).
    pub q: [Rgb; 6],
}

impl DiffuseMoments {
    /// Adds one sample of weight `l` (radiance × estimator weight) from world direction `wi`
    /// with cosine `cos` to the normal; only m0 unless `full`.
    #[inline]
    fn add(&mut self, wi: Vec3, cos: f32, l: Rgb, full: bool) {
        self.m0 += l;
        if !full {
            return;
        }
        let fi = schlick_weight(cos);
        let lf = l * fi;
        self.a += l * (1.0 - 0.5 * fi);
        self.n0 += lf;
        for k in 0..3 {
            self.m1[k] += l * wi[k];
            self.n1[k] += lf * wi[k];
        }
        let (x, y, z) = (wi.x, wi.y, wi.z);
        for (q, w) in self
            .q
            .iter_mut()
            .zip([x * x, x * y, x * z, y * y, y * z, z * z])
        {
            *q += lf * w;
        }
    }

    fn scale(&mut self, s: f32) {
        self.m0 *= s;
        self.a *= s;
        self.n0 *= s;
        self.m1.iter_mut().chain(&mut self.n1).for_each(|v| *v *= s);
        self.q.iter_mut().for_each(|v| *v *= s);
    }

    fn accumulate(&mut self, o: &DiffuseMoments) {
        self.m0 += o.m0;
        self.a += o.a;
        self.n0 += o.n0;
        for k in 0..3 {
            self.m1[k] += o.m1[k];
            self.n1[k] += o.n1[k];
        }
        for k in 0..6 {
            self.q[k] += o.q[k];
        }
    }

    /// (Ld0, [Ld1, Ld2]) for the view direction `wo` (world, unit) at a surface of shading
    /// normal `ns`, under `model`.
    #[inline]
    pub fn shading(&self, model: ReflectanceModel, wo: Vec3, ns: Vec3) -> (Rgb, [Rgb; 2]) {
        if !model.diffuse_depends_on_roughness() {
            return (self.m0, [Vec3::ZERO; 2]);
        }
        let fo = schlick_weight(wo.dot(ns).max(0.0));
        let dot = |v: &[Rgb; 3]| v[0] * wo.x + v[1] * wo.y + v[2] * wo.z;
        let (x, y, z) = (wo.x, wo.y, wo.z);
        let q = &self.q;
        let quad = q[0] * (x * x)
            + q[3] * (y * y)
            + q[5] * (z * z)
            + (q[1] * (x * y) + q[2] * (x * z) + q[4] * (y * z)) * 2.0;
        let n1o = dot(&self.n1);
        (
            self.a * (1.0 - 0.5 * fo),
            [
                (self.m0 + dot(&self.m1)) * fo + (self.n0 + n1o) * (1.0 - fo),
                (self.n0 + n1o * 2.0 + quad) * fo,
            ],
        )
    }
}

/// What an estimate of the diffuse shading sums per incident sample (radiance × estimator
/// weight `l` from world direction `wi` at cosine `cos` to the shading normal).
trait DiffuseSum: Default {
    fn add(&mut self, wi: Vec3, cos: f32, l: Rgb);
    fn scale(&mut self, s: f32);
    fn accumulate(&mut self, o: &Self);
}

/// The moments, all of them when `FULL`, else m0 alone (Lambert's sum compiles to a plain sum).
#[derive(Default)]
struct Moments<const FULL: bool>(DiffuseMoments);

impl<const FULL: bool> DiffuseSum for Moments<FULL> {
    #[inline]
    fn add(&mut self, wi: Vec3, cos: f32, l: Rgb) {
        self.0.add(wi, cos, l, FULL)
    }
    fn scale(&mut self, s: f32) {
        self.0.scale(s)
    }
    fn accumulate(&mut self, o: &Self) {
        self.0.accumulate(&o.0)
    }
}

/// The model's diffuse basis summed directly for one view direction: what a lobe the moments
/// do not express (an external model's) needs, per pixel.
#[derive(Default)]
struct Direct {
    model: ReflectanceModel,
    wo: Vec3,
    cos_o: f32,
    sum: [Rgb; 3],
}

impl DiffuseSum for Direct {
    #[inline]
    fn add(&mut self, wi: Vec3, cos: f32, l: Rgb) {
        let b = self.model.diffuse_basis(self.cos_o, cos, wi.dot(self.wo));
        for (s, b) in self.sum.iter_mut().zip(b) {
            *s += l * b;
        }
    }
    fn scale(&mut self, s: f32) {
        self.sum.iter_mut().for_each(|v| *v *= s);
    }
    fn accumulate(&mut self, o: &Self) {
        for (s, v) in self.sum.iter_mut().zip(o.sum) {
            *s += v;
        }
    }
}

/// Whether [`DiffuseMoments`] (and so the diffuse cache, one integral per surface cell for every
/// view) express `model`'s diffuse lobe: Lambert's and Burley's do; an external model's is
/// integrated per pixel for its own view direction ([`diffuse_direct`]).
pub fn moments_express(model: ReflectanceModel) -> bool {
    !matches!(model, ReflectanceModel::External(_))
}

/// The caveat of a bake or refinement under `model` when the diffuse cache cannot express it.
pub fn diffuse_cache_caveat(model: ReflectanceModel) -> Vec<String> {
    if moments_express(model) {
        return vec![];
    }
    vec![format!(
        "diffuse cache off: its moments express the built-in lobes only, so `{model}`'s diffuse shading is integrated per pixel for each view direction (slower bake and refinement)"
    )]
}

/// Ld at a surface point: (1/π)∫ Li cos dω by `n` cosine samples (weight = Li) and, when the
/// light has emitters, `n_light` emitter samples, combined by the power heuristic. `rng` drives
/// the emitter samples and any path continuation.
#[allow(clippy::too_many_arguments)]
pub fn diffuse_shading<L: IncidentLight>(
    light: &L,
    geometry: &dyn RayQuery,
    p: Vec3,
    ng: Vec3,
    ns: Vec3,
    n: u32,
    n_light: u32,
    stream: &mut SampleStream,
    rng: &mut Pcg32,
) -> Rgb {
    diffuse_moments(light, geometry, p, ng, ns, n, n_light, stream, rng, false).m0
}

/// The [`DiffuseMoments`] at a surface point, by the estimator of [`diffuse_shading`] (the same
/// samples); all of them when `full`, else m0 alone.
#[allow(clippy::too_many_arguments)]
pub fn diffuse_moments<L: IncidentLight>(
    light: &L,
    geometry: &dyn RayQuery,
    p: Vec3,
    ng: Vec3,
    ns: Vec3,
    n: u32,
    n_light: u32,
    stream: &mut SampleStream,
    rng: &mut Pcg32,
    full: bool,
) -> DiffuseMoments {
    let at = (p, ng, ns);
    if full {
        estimate(
            light,
            geometry,
            at,
            n,
            n_light,
            stream,
            rng,
            Moments::<true>::default,
        )
        .0
    } else {
        estimate(
            light,
            geometry,
            at,
            n,
            n_light,
            stream,
            rng,
            Moments::<false>::default,
        )
        .0
    }
}

/// (Ld0, [Ld1, Ld2]) of `model` at a surface point seen from `wo` (world, unit), by the
/// estimator of [`diffuse_shading`] (the same samples), summing the model's diffuse basis
/// directly: for lobes [`moments_express`] refuses.
#[allow(clippy::too_many_arguments)]
pub fn diffuse_direct<L: IncidentLight>(
    light: &L,
    geometry: &dyn RayQuery,
    (p, ng, ns): (Vec3, Vec3, Vec3),
    wo: Vec3,
    model: ReflectanceModel,
    n: u32,
    n_light: u32,
    stream: &mut SampleStream,
    rng: &mut Pcg32,
) -> (Rgb, [Rgb; 2]) {
    let cos_o = wo.dot(ns).max(1e-6);
    let empty = || Direct {
        model,
        wo,
        cos_o,
        sum: [Vec3::ZERO; 3],
    };
    let d = estimate(light, geometry, (p, ng, ns), n, n_light, stream, rng, empty);
    (d.sum[0], [d.sum[1], d.sum[2]])
}

/// The estimator of the diffuse shading at `at` = (p, ng, ns): `n` cosine samples and `n_light`
/// emitter samples combined by the power heuristic, each technique's sum scaled by its count;
/// `empty()` starts a sum.
#[allow(clippy::too_many_arguments)]
fn estimate<L: IncidentLight, S: DiffuseSum>(
    light: &L,
    geometry: &dyn RayQuery,
    (p, ng, ns): (Vec3, Vec3, Vec3),
    n: u32,
    n_light: u32,
    stream: &mut SampleStream,
    rng: &mut Pcg32,
    empty: impl Fn() -> S,
) -> S {
    let n_light = if light.has_emitters() { n_light } else { 0 };
    let mut sum = empty();
    if n == 0 && n_light == 0 {
        return sum;
    }
    let frame = Frame::from_normal(ns);
    let origin = geometry.offset(p, ng);
    // MIS weights compare the two techniques' per-sample densities (power heuristic), not
    // n·pdf: the cosine technique's many samples reach a small lamp in a random number of
    // hits, which the lamp's own samples do not suffer from.
    if n > 0 {
        let mut s = empty();
        // One sample in flight, as in the specular mixture: its light's memory is fetched while
        // the next sample's ray is traced; the samples are added in the order drawn.
        let mut in_flight: Option<(Vec3, f32, Pending)> = None;
        let mut settle = |(wi, cos, pending): (Vec3, f32, Pending), rng: &mut Pcg32| {
            let l = match light.finish(pending, rng) {
                Incoming::Miss => return,
                Incoming::Radiance(l) => l,
                Incoming::Emitter { le, light_pdf } if n_light > 0 => {
                    let p_cos = wi.dot(ns).max(0.0) * FRAC_1_PI;
                    le * power_heuristic(p_cos, light_pdf)
                }
                Incoming::Emitter { le, .. } => le,
            };
            s.add(wi, cos, l);
        };
        for _ in 0..n {
            let wl = sample_cosine_hemisphere(stream.next());
            let wi = frame.to_world(wl);
            if wi.dot(ng) <= 0.0 {
                continue;
            }
            let begun = (wi, wl.z, light.begin(origin, wi, rng));
            if let Some(previous) = in_flight.replace(begun) {
                settle(previous, rng);
            }
        }
        if let Some(last) = in_flight.take() {
            settle(last, rng);
        }
        s.scale(1.0 / n as f32);
        sum.accumulate(&s);
    }
    if n_light > 0 {
        let mut s = empty();
        for _ in 0..n_light {
            let Some(ls) = light.sample_emitter(origin, rng) else {
                continue;
            };
            let cos = ls.wi.dot(ns);
            if cos <= 0.0 || ls.wi.dot(ng) <= 0.0 {
                continue;
            }
            let p_cos = cos * FRAC_1_PI;
            // f·cos/p = Le·(cos/π)/pdf.
            let l = ls.le * (p_cos / ls.pdf * power_heuristic(ls.pdf, p_cos));
            s.add(ls.wi, cos, l);
        }
        s.scale(1.0 / n_light as f32);
        sum.accumulate(&s);
    }
    sum
}

/// One surface cell of the diffuse cache: the mean point and shading normal of the pixels
/// that fall in it.
#[derive(Clone, Copy, Debug)]
pub struct DiffuseCell {
    pub tri: u32,
    pub p: Vec3,
    /// Facing geometric normal.
    pub ng: Vec3,
    /// Mean facing shading normal.
    pub ns: Vec3,
    pub pixels: u32,
}

/// The diffuse cache's cells (triangle × side × a cubic cell of edge `cell`), built one view
/// at a time ([`DiffuseCells::add_view`]) so that no view's hits outlive their pass. The
/// moments of the incident light do not depend on the view, so they are integrated once per
/// cell ([`DiffuseCells::integrate`]) and shared by every pixel of every view that sees the
/// cell ([`DiffuseCells::scatter_view`]).
pub struct DiffuseCells {
    pub entries: Vec<DiffuseCell>,
    index: HashMap<CellKey, u32>,
    origin: Vec3,
    inv: f32,
    /// Per cell: whether a pixel of a view added with `used` true falls in it.
    used: Vec<bool>,
    /// The cells (and whether used) while views are added, filled on every thread.
    building: PartedMap<CellKey, (DiffuseCell, bool)>,
    finished: bool,
}

#[derive(Hash, PartialEq, Eq, Clone, Copy)]
struct CellKey {
    tri: u32,
    side: bool,
    cell: [i32; 3],
}

/// The cell of a pixel's hit, on the lattice of edge `1 / inv` anchored at `origin`.
fn cell_key(origin: Vec3, inv: f32, rec: &PixelRecord) -> CellKey {
    let q = ((rec.hit.p - origin) * inv).floor();
    CellKey {
        tri: rec.hit.tri,
        side: rec.ng.dot(rec.hit.ng) > 0.0,
        cell: [q.x as i32, q.y as i32, q.z as i32],
    }
}

/// The integrated cache: one colour per cell under Lambert (15× smaller), all the moments
/// under a model whose diffuse factor depends on the view.
pub enum CellShading {
    Lambert(Vec<Rgb>),
    Moments(Vec<DiffuseMoments>),
}

impl DiffuseCells {
    /// No cells yet, on a lattice of edge `cell` anchored at `origin`.
    pub fn new(origin: Vec3, cell: f32) -> Self {
        DiffuseCells {
            entries: vec![],
            index: HashMap::default(),
            origin,
            inv: 1.0 / cell,
            used: vec![],
            building: PartedMap::new(),
            finished: false,
        }
    }

    /// Adds one view's pixels (views in order: the cells are numbered by the pixel that first
    /// met them, whatever the number of threads, so results are deterministic); `used` marks
    /// their cells as needed (a shard's views).
    pub fn add_view(&mut self, records: &[Option<PixelRecord>], used: bool) {
        self.add_view_where(records, |_| used);
    }

    /// [`DiffuseCells::add_view`] with the cells of the pixels `used` accepts (by index in
    /// the view) marked used: every hit pixel still shapes its cell (its mean point and
    /// normal), so the cells, their order and their sample streams do not depend on which
    /// pixels a stage computes.
    pub fn add_view_where(
        &mut self,
        records: &[Option<PixelRecord>],
        used: impl Fn(usize) -> bool + Sync,
    ) {
        let (origin, inv) = (self.origin, self.inv);
        self.building.add_all(
            records,
            |_, rec| rec.as_ref().map(|rec| cell_key(origin, inv, rec)),
            |rec| {
                let rec = rec.as_ref().expect("a keyed pixel hits");
                let cell = DiffuseCell {
                    tri: rec.hit.tri,
                    p: Vec3::ZERO,
                    ng: rec.ng,
                    ns: Vec3::ZERO,
                    pixels: 0,
                };
                (cell, false)
            },
            |(e, u), i, rec| {
                let rec = rec.as_ref().expect("a keyed pixel hits");
                e.p += rec.hit.p;
                e.ns += rec.ns;
                e.pixels += 1;
                *u |= used(i);
            },
        );
    }

    /// Turns the sums into means, the cells numbered in the order their first pixel came;
    /// call once every view is added.
    pub fn finish(mut self) -> Self {
        let cells = std::mem::take(&mut self.building).into_first_seen();
        self.index = HashMap::default();
        self.index.reserve(cells.len());
        self.entries = Vec::with_capacity(cells.len());
        self.used = Vec::with_capacity(cells.len());
        for (id, (k, (mut e, u))) in cells.into_iter().enumerate() {
            e.p /= e.pixels as f32;
            e.ns = e.ns.normalize_or(e.ng);
            self.entries.push(e);
            self.used.push(u);
            self.index.insert(k, id as u32);
        }
        self.finished = true;
        self
    }

    /// Groups the pixels of `records` into cells of edge `cell` on a lattice anchored at
    /// `origin` (every view used).
    pub fn build(records: &[Vec<Option<PixelRecord>>], origin: Vec3, cell: f32) -> Self {
        let mut c = Self::new(origin, cell);
        for r in records {
            c.add_view(r, true);
        }
        c.finish()
    }

    /// Per cell: whether a pixel of a view added as used falls in it.
    pub fn used(&self) -> &[bool] {
        &self.used
    }

    /// Which cell each pixel of `records` (a view added before) falls in (`u32::MAX` where the
    /// pixel misses the mesh).
    pub fn assign_view(&self, records: &[Option<PixelRecord>]) -> Vec<u32> {
        debug_assert!(self.finished);
        records
            .par_iter()
            .map(|r| {
                r.as_ref()
                    .and_then(|r| self.index.get(&cell_key(self.origin, self.inv, r)).copied())
            })
            .map(|id| id.unwrap_or(u32::MAX))
            .collect()
    }

    /// Integrates every cell with `moments(cell index, cell)`.
    pub fn integrate(
        &self,
        model: ReflectanceModel,
        moments: impl Fn(usize, &DiffuseCell) -> DiffuseMoments + Sync,
    ) -> CellShading {
        let all = self.entries.par_iter().enumerate();
        if model.diffuse_depends_on_roughness() {
            CellShading::Moments(all.map(|(k, c)| moments(k, c)).collect())
        } else {
            CellShading::Lambert(all.map(|(k, c)| moments(k, c).m0).collect())
        }
    }

    /// Writes the diffuse shadings of `model` into the pixels of one view (`records` and `out`
    /// of the same view), each pixel with its own ωo.
    pub fn scatter_view(
        &self,
        shading: &CellShading,
        model: ReflectanceModel,
        records: &[Option<PixelRecord>],
        out: &mut ViewShadings,
    ) {
        let assign = self.assign_view(records);
        match shading {
            CellShading::Lambert(ld) => {
                for (l, &id) in out.ld.iter_mut().zip(&assign) {
                    if id != u32::MAX {
                        *l = ld[id as usize];
                    }
                }
            }
            CellShading::Moments(m) => {
                let ViewShadings { ld, ld_poly, .. } = out;
                ld.par_iter_mut()
                    .zip(ld_poly.par_iter_mut())
                    .zip(assign.par_iter().zip(records.par_iter()))
                    .for_each(|((l0, lp), (&id, rec))| {
                        if let (Some(rec), true) = (rec, id != u32::MAX) {
                            (*l0, *lp) = m[id as usize].shading(model, rec.wo, rec.ns);
                        }
                    });
            }
        }
    }
}
