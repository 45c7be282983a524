//! Multi-resolution hash-grid encoding as a candle custom op, with a sparse Adam for its tables.
//!
//! Level l has a grid of `resolution(l) = floor(base · scale^l)` cells per axis over the unit
//! cube; a point's features at that level are the trilinear interpolation of the feature
//! vectors stored at the 8 corners of its cell. Coarse levels whose `(r+1)³` corners fit in the
//! table are indexed densely; finer levels hash corners into `2^log2_table` entries. The
//! encoding of a point is the concatenation of its level features (level-major).
//!
//! The tables live in [`HashGrid`], not in a candle `Var`: candle's backward would materialise
//! a dense gradient the size of all tables (tens of MB) every step, and a dense Adam over them
//! costs ~50 ms on 2 cores whatever the batch. Instead the op's backward (called by candle's
//! autograd, so the MLP after it keeps candle's gradients) accumulates into the grid's own
//! gradient buffer and records which entries were touched; [`HashGrid::adam_step`] then updates
//! only those entries (lazy Adam: moments of untouched entries are left as they are). The
//! training loop uses [`HashGrid::accumulate_and_step`], which does both level by level inside
//! the backward, while a level's touched entries are still in cache.
//!
//! Level resolutions are computed once, in [`HashGrid::new`], and every code path reads that
//! table: recomputing `base·scale^l` at two call sites can round differently and move corners.
use crate::error::{NeuralError, Result};
use candle_core::{CpuStorage, CustomOp1, Layout, Shape, Tensor};
use fipt_core::rng::Pcg32;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock};
use std::time::Instant;

/// Sizes of a hash-grid encoding.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HashGridConfig {
    /// Number of levels.
    pub levels: usize,
    /// Features per level.
    pub features: usize,
    /// log2 of the entries per hashed level.
    pub log2_table: u32,
    /// Cells per axis of the coarsest level.
    pub base_resolution: u32,
    /// Growth of the resolution from one level to the next.
    pub per_level_scale: f32,
    /// Initial features are uniform in ±init_scale.
    pub init_scale: f32,
}

impl Default for HashGridConfig {
    /// 16 levels × 2 features × 2^19, base 16, scale 1.38 (finest ≈ 2,000 cells across).
    fn default() -> Self {
        HashGridConfig {
            levels: 16,
            features: 2,
            log2_table: 19,
            base_resolution: 16,
            per_level_scale: 1.38,
            init_scale: 1e-4,
        }
    }
}

impl HashGridConfig {
    /// The reference's sizes: 32 levels × 2 features × 2^19, base 16, scale 1.3.
    pub const fn reference() -> Self {
        HashGridConfig {
            levels: 32,
            features: 2,
            log2_table: 19,
            base_resolution: 16,
            per_level_scale: 1.3,
            init_scale: 1e-4,
        }
    }

    /// Width of the encoding (levels × features).
    pub fn output_dim(&self) -> usize {
        self.levels * self.features
    }

    /// Checks the sizes; `what` names the configuration in errors.
    pub fn validate(&self, what: &str) -> Result<()> {
        let bad = |m: String| Err(NeuralError::config(what, m));
        if self.levels == 0 || self.levels > 64 {
            return bad(format!("levels = {} (use 1..=64)", self.levels));
        }
        if self.features == 0 || self.features > 8 {
            return bad(format!("features = {} (use 1..=8)", self.features));
        }
        if !(4..=24).contains(&self.log2_table) {
            return bad(format!("log2_table = {} (use 4..=24)", self.log2_table));
        }
        if self.base_resolution == 0 {
            return bad("base_resolution must be at least 1".into());
        }
        if !(self.per_level_scale >= 1.0 && self.per_level_scale <= 4.0) {
            return bad(format!(
                "per_level_scale = {} (use 1..=4)",
                self.per_level_scale
            ));
        }
        if !(self.init_scale >= 0.0 && self.init_scale.is_finite()) {
            return bad(format!("init_scale = {}", self.init_scale));
        }
        Ok(())
    }
}

/// One level of the grid, fixed at construction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    /// Cells per axis (corners per axis = resolution + 1).
    pub resolution: u32,
    /// First entry of the level in the table.
    pub offset: usize,
    /// Entries of the level.
    pub size: usize,
    /// Dense (one entry per corner) or hashed.
    pub dense: bool,
}

/// The corners and trilinear weights of a point at one level.
#[inline]
fn corners(level: &Level, p: [f32; 3]) -> ([usize; 8], [f32; 8]) {
    let r = level.resolution;
    let mut cell = [0u32; 3];
    let mut frac = [0f32; 3];
    for a in 0..3 {
        let x = if p[a].is_nan() {
            0.0
        } else {
            p[a].clamp(0.0, 1.0) * r as f32
        };
        // x ≥ 0, so truncation is floor (without a libm call on baseline x86-64).
        let c = (x as u32).min(r - 1);
        cell[a] = c;
        frac[a] = (x - c as f32).clamp(0.0, 1.0);
    }
    let mut idx = [0usize; 8];
    let mut w = [0f32; 8];
    for (k, (i, wk)) in idx.iter_mut().zip(&mut w).enumerate() {
        let mut weight = 1.0;
        let mut c = [0u32; 3];
        for a in 0..3 {
            let bit = (k >> a) & 1;
            c[a] = cell[a] + bit as u32;
            weight *= if bit == 1 { frac[a] } else { 1.0 - frac[a] };
        }
        *i = level.offset + entry(level, c);
        *wk = weight;
    }
    (idx, w)
}

/// Entry of corner `c` within its level.
#[inline]
fn entry(level: &Level, c: [u32; 3]) -> usize {
    if level.dense {
        let n = level.resolution as usize + 1;
        c[0] as usize + n * (c[1] as usize + n * c[2] as usize)
    } else {
        let h = c[0] ^ c[1].wrapping_mul(2_654_435_761) ^ c[2].wrapping_mul(805_459_861);
        h as usize & (level.size - 1)
    }
}

/// Points processed ahead of the one being used: their records are prefetched, so that the
/// random table accesses of several points are in flight at once.
const AHEAD: usize = 8;

/// Calls `f(i, corners, weights)` for every point at `level`, in order (corners indexed from
/// the level's start), after prefetching the records of the points [`AHEAD`] further on:
/// `record` floats each in the level's `records` (an address range only, so that `f` may hold
/// the records mutably).
#[inline]
fn for_each_cell(
    level: &Level,
    points: &[[f32; 3]],
    records: Range<*const f32>,
    record: usize,
    mut f: impl FnMut(usize, &[usize; 8], &[f32; 8]),
) {
    let mut ring = [([0usize; 8], [0f32; 8]); AHEAD];
    for i in 0..points.len() + AHEAD {
        if i >= AHEAD {
            let (idx, w) = &ring[(i - AHEAD) % AHEAD];
            f(i - AHEAD, idx, w);
        }
        if let Some(p) = points.get(i) {
            let (mut idx, w) = corners(level, *p);
            for e in &mut idx {
                *e -= level.offset;
                prefetch(&records, *e * record);
            }
            ring[i % AHEAD] = (idx, w);
        }
    }
}

/// A hint to fetch the cache line of element `at` of `buf` (no effect out of range).
#[inline(always)]
fn prefetch(buf: &Range<*const f32>, at: usize) {
    let p = buf.start.wrapping_add(at);
    if p < buf.end {
        fipt_core::memory::prefetch(p);
    }
}

/// The tables with their gradient and optimiser state.
struct Tables {
    /// One record per entry, `[param × F, grad × F, m × F, v × F]` (32 bytes for F = 2): the
    /// forward's gather, the backward's scatter and the Adam update of an entry all touch the
    /// same cache line, where separate arrays cost three or four random memory accesses per
    /// touched entry and step.
    rec: Vec<f32>,
    /// Per level, a bit per entry: touched since the last step. A bitmap (64 KiB for a 2^19
    /// table) stays in cache where a per-entry stamp was one more random memory access per
    /// corner, and sweeping it yields the touched entries in table order without a sort.
    dirty: Vec<Vec<u64>>,
    steps: u64,
}

/// Record components.
const PARAM: usize = 0;
const GRAD: usize = 1;
const M: usize = 2;
const V: usize = 3;

/// One Adam update of a record (`f` features) from its accumulated gradient, which is
/// cleared.
#[inline]
fn adam_record(r: &mut [f32], f: usize, cfg: &AdamConfig, (lr_t, inv_sqrt_bc2): (f32, f32)) {
    for j in 0..f {
        let g = std::mem::take(&mut r[GRAD * f + j]);
        let m = cfg.beta1 * r[M * f + j] + (1.0 - cfg.beta1) * g;
        let v = cfg.beta2 * r[V * f + j] + (1.0 - cfg.beta2) * g * g;
        r[M * f + j] = m;
        r[V * f + j] = v;
        // lr·(m/bc1)/(√(v/bc2) + ε) with the corrections folded into two per-step constants:
        // one square root and one division per value (the update is bound by them).
        r[PARAM * f + j] -= lr_t * m / (v.sqrt() * inv_sqrt_bc2 + cfg.eps);
    }
}

/// Calls `f(e)` for every set bit `e` of `bits`, in increasing order, clearing them; the
/// records (`record` floats each in the address range `records`) of the next word's entries
/// are prefetched meanwhile.
#[inline]
fn drain_bits(
    bits: &mut [u64],
    records: Range<*const f32>,
    record: usize,
    mut f: impl FnMut(usize),
) {
    for wi in 0..bits.len() {
        if let Some(&next) = bits.get(wi + 1) {
            let mut w = next;
            while w != 0 {
                prefetch(
                    &records,
                    ((wi + 1) * 64 + w.trailing_zeros() as usize) * record,
                );
                w &= w - 1;
            }
        }
        let mut w = std::mem::take(&mut bits[wi]);
        while w != 0 {
            f(wi * 64 + w.trailing_zeros() as usize);
            w &= w - 1;
        }
    }
}

/// Adam hyper-parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdamConfig {
    pub lr: f32,
    pub beta1: f32,
    pub beta2: f32,
    pub eps: f32,
}

impl Default for AdamConfig {
    fn default() -> Self {
        AdamConfig {
            lr: 1e-3,
            beta1: 0.9,
            beta2: 0.99,
            eps: 1e-15,
        }
    }
}

/// Time spent in the encoding, for benchmarks (nanoseconds, cumulative).
#[derive(Debug, Default)]
pub struct GridTimers {
    pub forward_ns: AtomicU64,
    pub backward_ns: AtomicU64,
    pub adam_ns: AtomicU64,
    /// The part of `adam_ns` spent inside the backward ([`HashGrid::accumulate_and_step`]),
    /// excluded from `backward_ns`.
    pub update_in_backward_ns: AtomicU64,
}

/// A multi-resolution hash grid: level table, feature tables and their optimiser state.
pub struct HashGrid {
    config: HashGridConfig,
    levels: Vec<Level>,
    tables: RwLock<Tables>,
    pub timers: GridTimers,
}

impl HashGrid {
    /// A grid with features uniform in ±init_scale drawn from `seed`.
    pub fn new(config: HashGridConfig, seed: u64) -> Result<Self> {
        config.validate("hash grid")?;
        let table = 1usize << config.log2_table;
        let mut levels = Vec::with_capacity(config.levels);
        let mut offset = 0;
        for l in 0..config.levels {
            let r = (config.base_resolution as f64 * (config.per_level_scale as f64).powi(l as i32))
                .floor()
                .clamp(1.0, 1e6) as u32;
            let corners = (r as usize + 1).pow(3);
            let dense = corners <= table;
            let size = if dense { corners } else { table };
            levels.push(Level {
                resolution: r,
                offset,
                size,
                dense,
            });
            offset += size;
        }
        let f = config.features;
        let mut rng = Pcg32::new(seed, 0x4A54);
        let s = config.init_scale;
        let mut rec = vec![0f32; offset * 4 * f];
        for r in rec.chunks_exact_mut(4 * f) {
            for v in &mut r[..f] {
                *v = (rng.next_f32() * 2.0 - 1.0) * s;
            }
        }
        Ok(HashGrid {
            tables: RwLock::new(Tables {
                rec,
                dirty: levels
                    .iter()
                    .map(|l| vec![0; l.size.div_ceil(64)])
                    .collect(),
                steps: 0,
            }),
            levels,
            config,
            timers: GridTimers::default(),
        })
    }

    pub fn config(&self) -> &HashGridConfig {
        &self.config
    }
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }
    /// Number of trainable values.
    pub fn num_params(&self) -> usize {
        self.levels.last().map_or(0, |l| l.offset + l.size) * self.config.features
    }
    /// Width of the encoding.
    pub fn output_dim(&self) -> usize {
        self.config.output_dim()
    }
    /// A copy of the tables.
    pub fn params(&self) -> Vec<f32> {
        self.component(PARAM)
    }
    /// Adam steps taken.
    pub fn steps(&self) -> u64 {
        self.tables.read().unwrap().steps
    }

    /// Encodes points of the unit cube (`[x, y, z]` triples, clamped to [0, 1]) into
    /// `points.len() × output_dim` features, in parallel.
    pub fn encode(&self, points: &[[f32; 3]]) -> Vec<f32> {
        let d = self.output_dim();
        let f = self.config.features;
        let mut out = crate::ops::zeros_par(points.len() * d);
        let tables = self.tables.read().unwrap();
        let rec = &tables.rec;
        // Level by level over a block of points, the records of the next points prefetched.
        out.par_chunks_mut(d * 256)
            .zip(points.par_chunks(256))
            .for_each(|(rows, pts)| {
                for (l, level) in self.levels.iter().enumerate() {
                    let base = level.offset * 4 * f;
                    let recs = &rec[base..base + level.size * 4 * f];
                    for_each_cell(level, pts, recs.as_ptr_range(), 4 * f, |i, idx, w| {
                        let o = &mut rows[i * d + l * f..i * d + (l + 1) * f];
                        for k in 0..8 {
                            let e = &recs[idx[k] * 4 * f..idx[k] * 4 * f + f];
                            for j in 0..f {
                                o[j] += w[k] * e[j];
                            }
                        }
                    });
                }
            });
        out
    }

    /// Adds the gradient of the tables for `d loss / d encoding = grad_out` (row per point) to
    /// the accumulated gradient, one level per task (levels own disjoint table ranges).
    pub fn accumulate_grad(&self, points: &[[f32; 3]], grad_out: &[f32]) {
        self.backward(points, grad_out, None);
    }

    /// [`HashGrid::accumulate_grad`] then [`HashGrid::adam_step`], level by level: a level's
    /// records are updated right after its gradient is complete, while they are still in
    /// cache (the separate Adam pass read them all from memory again). The result is the same
    /// as the two calls, bit for bit.
    pub fn accumulate_and_step(&self, points: &[[f32; 3]], grad_out: &[f32], cfg: &AdamConfig) {
        self.backward(points, grad_out, Some(cfg));
    }

    fn backward(&self, points: &[[f32; 3]], grad_out: &[f32], step: Option<&AdamConfig>) {
        let d = self.output_dim();
        let f = self.config.features;
        assert_eq!(grad_out.len(), points.len() * d, "gradient shape");
        let mut guard = self.tables.write().unwrap();
        let tb = &mut *guard;
        let bias = step.map(|cfg| {
            tb.steps += 1;
            bias_corrections(cfg, tb.steps)
        });
        let update_ns = AtomicU64::new(0);
        let mut rec_slices = split_levels(&mut tb.rec, &self.levels, 4 * f);
        rec_slices
            .par_iter_mut()
            .zip(tb.dirty.par_iter_mut())
            .zip(self.levels.par_iter().enumerate())
            .for_each(|((rec, dirty), (l, level))| {
                let range = rec.as_ptr_range();
                for_each_cell(level, points, range, 4 * f, |i, idx, w| {
                    let go = &grad_out[i * d + l * f..i * d + (l + 1) * f];
                    if go.iter().all(|&x| x == 0.0) {
                        return;
                    }
                    for k in 0..8 {
                        let e = idx[k];
                        let g = &mut rec[e * 4 * f + GRAD * f..e * 4 * f + GRAD * f + f];
                        for j in 0..f {
                            g[j] += w[k] * go[j];
                        }
                        dirty[e >> 6] |= 1 << (e & 63);
                    }
                });
                if let (Some(cfg), Some(bias)) = (step, bias) {
                    let t0 = Instant::now();
                    drain_bits(dirty, rec.as_ptr_range(), 4 * f, |e| {
                        adam_record(&mut rec[e * 4 * f..(e + 1) * 4 * f], f, cfg, bias)
                    });
                    update_ns.fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
                }
            });
        // The updates ran inside the level tasks: book their share of the wall time (their
        // summed time over the threads) as the optimiser's; the op books the rest as backward.
        let update = update_ns.into_inner() / rayon::current_num_threads().max(1) as u64;
        self.timers.adam_ns.fetch_add(update, Ordering::Relaxed);
        self.timers
            .update_in_backward_ns
            .fetch_add(update, Ordering::Relaxed);
    }

    /// One lazy-Adam step on the entries touched since the last step; clears their gradient.
    pub fn adam_step(&self, cfg: &AdamConfig) {
        let t0 = Instant::now();
        let f = self.config.features;
        let mut guard = self.tables.write().unwrap();
        let tb = &mut *guard;
        tb.steps += 1;
        let bias = bias_corrections(cfg, tb.steps);
        split_levels(&mut tb.rec, &self.levels, 4 * f)
            .into_par_iter()
            .zip(tb.dirty.par_iter_mut())
            .for_each(|(rec, dirty)| {
                // In table order, the scattered entries become a forward sweep the hardware
                // prefetcher can follow.
                drain_bits(dirty, rec.as_ptr_range(), 4 * f, |e| {
                    adam_record(&mut rec[e * 4 * f..(e + 1) * 4 * f], f, cfg, bias)
                });
            });
        self.timers
            .adam_ns
            .fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
    }

    /// The accumulated (not yet applied) gradient, for tests.
    pub fn pending_grad(&self) -> Vec<f32> {
        self.component(GRAD)
    }

    /// Component `c` of the records, entry-major.
    fn component(&self, c: usize) -> Vec<f32> {
        let f = self.config.features;
        let tb = self.tables.read().unwrap();
        tb.rec
            .chunks_exact(4 * f)
            .flat_map(|r| r[c * f..(c + 1) * f].iter().copied())
            .collect()
    }

    /// Discards the accumulated gradient.
    pub fn zero_grad(&self) {
        let mut guard = self.tables.write().unwrap();
        let tb = &mut *guard;
        let f = self.config.features;
        for (level, dirty) in self.levels.iter().zip(&mut tb.dirty) {
            let base = tb.rec[level.offset * 4 * f..].as_ptr_range();
            drain_bits(dirty, base, 4 * f, |e| {
                let base = (level.offset + e) * 4 * f + GRAD * f;
                tb.rec[base..base + f].fill(0.0);
            });
        }
    }

    /// Tables and optimiser state for a checkpoint: (params, m, v, steps).
    pub fn state(&self) -> (Vec<f32>, Vec<f32>, Vec<f32>, u64) {
        (
            self.component(PARAM),
            self.component(M),
            self.component(V),
            self.steps(),
        )
    }

    /// Restores [`HashGrid::state`]; lengths must match this grid's.
    pub fn set_state(&self, params: Vec<f32>, m: Vec<f32>, v: Vec<f32>, steps: u64) -> Result<()> {
        let n = self.num_params();
        if params.len() != n || m.len() != n || v.len() != n {
            return Err(NeuralError::config(
                "hash grid checkpoint",
                format!(
                    "table sizes {}/{}/{} do not match this grid's {n} values (another configuration?)",
                    params.len(),
                    m.len(),
                    v.len()
                ),
            ));
        }
        let f = self.config.features;
        let mut tb = self.tables.write().unwrap();
        for (e, r) in tb.rec.chunks_exact_mut(4 * f).enumerate() {
            let src = e * f..(e + 1) * f;
            r[PARAM * f..PARAM * f + f].copy_from_slice(&params[src.clone()]);
            r[GRAD * f..GRAD * f + f].fill(0.0);
            r[M * f..M * f + f].copy_from_slice(&m[src.clone()]);
            r[V * f..V * f + f].copy_from_slice(&v[src]);
        }
        tb.dirty.iter_mut().for_each(|d| d.fill(0));
        tb.steps = steps;
        Ok(())
    }

    /// Overwrites one table value (finite-difference tests).
    pub fn set_param(&self, i: usize, value: f32) {
        let f = self.config.features;
        self.tables.write().unwrap().rec[(i / f) * 4 * f + PARAM * f + i % f] = value;
    }
}

/// Adam's bias corrections at step `t` as `(lr / (1 − β1^t), 1 / √(1 − β2^t))`.
fn bias_corrections(cfg: &AdamConfig, t: u64) -> (f32, f32) {
    let t = t.min(i32::MAX as u64) as i32;
    (
        cfg.lr / (1.0 - cfg.beta1.powi(t)),
        1.0 / (1.0 - cfg.beta2.powi(t)).sqrt(),
    )
}

/// Splits a per-entry buffer (`width` values per entry) into per-level mutable slices.
fn split_levels<'a, T>(mut buf: &'a mut [T], levels: &[Level], width: usize) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(levels.len());
    for level in levels {
        let (a, b) = std::mem::take(&mut buf).split_at_mut(level.size * width);
        out.push(a);
        buf = b;
    }
    out
}

/// The encoding as a candle op: input `[n, 3]` points of the unit cube, output
/// `[n, levels·features]`. For gradients to flow, the input must track gradients (wrap it in a
/// `Var`); the op's backward accumulates into the grid and returns no input gradient. With
/// `step`, the backward also takes the tables' Adam step ([`HashGrid::accumulate_and_step`]):
/// the training loop's fast path.
#[derive(Clone)]
pub struct HashGridOp {
    pub grid: Arc<HashGrid>,
    pub step: Option<AdamConfig>,
}

impl HashGridOp {
    /// The encoding; its backward accumulates the tables' gradient.
    pub fn new(grid: Arc<HashGrid>) -> Self {
        HashGridOp { grid, step: None }
    }
    /// The encoding; its backward accumulates the gradient and steps the tables with `cfg`.
    pub fn stepping(grid: Arc<HashGrid>, cfg: AdamConfig) -> Self {
        HashGridOp {
            grid,
            step: Some(cfg),
        }
    }
}

fn points_of(storage: &CpuStorage, layout: &Layout) -> candle_core::Result<Vec<[f32; 3]>> {
    let dims = layout.shape().dims();
    if dims.len() != 2 || dims[1] != 3 {
        candle_core::bail!("hash grid: points must be [n, 3], got {:?}", dims);
    }
    let slice = crate::ops::contiguous(storage, layout, "hash grid points")?;
    Ok(slice.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

impl CustomOp1 for HashGridOp {
    fn name(&self) -> &'static str {
        "hash-grid"
    }

    fn cpu_fwd(
        &self,
        storage: &CpuStorage,
        layout: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let t0 = Instant::now();
        let pts = points_of(storage, layout)?;
        let out = self.grid.encode(&pts);
        let shape = Shape::from((pts.len(), self.grid.output_dim()));
        self.grid
            .timers
            .forward_ns
            .fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
        Ok((CpuStorage::F32(out), shape))
    }

    fn bwd(
        &self,
        arg: &Tensor,
        _res: &Tensor,
        grad_res: &Tensor,
    ) -> candle_core::Result<Option<Tensor>> {
        let t0 = Instant::now();
        let update0 = self
            .grid
            .timers
            .update_in_backward_ns
            .load(Ordering::Relaxed);
        // One flat copy; `to_vec2` would allocate a Vec per point on every training step.
        let flat = arg.flatten_all()?.to_vec1::<f32>()?;
        let pts: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let g = grad_res.flatten_all()?.to_vec1::<f32>()?;
        match &self.step {
            Some(cfg) => self.grid.accumulate_and_step(&pts, &g, cfg),
            None => self.grid.accumulate_grad(&pts, &g),
        }
        let update = self
            .grid
            .timers
            .update_in_backward_ns
            .load(Ordering::Relaxed)
            - update0;
        self.grid.timers.backward_ns.fetch_add(
            (t0.elapsed().as_nanos() as u64).saturating_sub(update),
            Ordering::Relaxed,
        );
        Ok(None)
    }
}

impl HashGrid {
    /// Table entries (global) and trilinear weights of `p`'s cell corners at `level`.
    pub fn corners_at(&self, level: usize, p: [f32; 3]) -> ([usize; 8], [f32; 8]) {
        corners(&self.levels[level], p)
    }
}
