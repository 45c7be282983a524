//! A ReLU multilayer perceptron whose forward and backward are one fused CPU op each.
//!
//! In plain candle ops, a training step of the field's two small MLPs (8192 rows, widths 64)
//! is ~25 separate ops per direction, most of them single-threaded element-wise passes that
//! allocate a fresh `[n, 64]` tensor: 35–45 ms a step on 2 cores, of which the matrix products
//! are ~5 ms. [`MlpOp`] runs the whole network on blocks of rows in parallel, each block's
//! layers staying in cache: matrix products by `gemm`, bias and ReLU in the same pass, the
//! hidden activations kept for the backward, and the parameter gradient summed over blocks in
//! a fixed order (deterministic whatever the thread count).
//!
//! The parameters are one candle `Var` per network (`<name>.params`), so candle's autograd and
//! the optimiser see an ordinary `[input, params] → output` op. Layer `i` occupies
//! `W_i` (`[out, in]`, row-major, `y = x·Wᵀ + b` as candle's `Linear`) then `b_i` (`[out]`).
use crate::error::{CandleContext, Result};
use crate::ops::{contiguous, with_cpu_f32, zeros_par};
use candle_core::{CpuStorage, CustomOp2, Layout, Module, Shape, Tensor, Var};
use candle_nn::VarBuilder;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::{Arc, Mutex};

/// Rows per parallel block: 8192-row batches give 32 blocks, and a block's activations
/// (`256 × 64` floats per layer) stay in L2.
const BLOCK: usize = 256;

/// Where one layer lives in the packed parameters.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LayerRange {
    pub input: usize,
    pub output: usize,
    /// `[output, input]`, row-major.
    pub weight: Range<usize>,
    /// `[output]`.
    pub bias: Range<usize>,
}

/// The layers of a network with widths `dims` (`dims[0]` in, `dims[last]` out).
pub fn layer_ranges(dims: &[usize]) -> Vec<LayerRange> {
    let mut at = 0;
    dims.windows(2)
        .map(|w| {
            let (input, output) = (w[0], w[1]);
            let weight = at..at + input * output;
            let bias = weight.end..weight.end + output;
            at = bias.end;
            LayerRange {
                input,
                output,
                weight,
                bias,
            }
        })
        .collect()
}

/// `input → width (× hidden) → output` with ReLU after every layer but the last.
pub struct Mlp {
    params: Var,
    dims: Vec<usize>,
}

impl Mlp {
    /// A network with its parameters (zeros; see [`Mlp::set_params`]) created in `vb` as
    /// `params`.
    pub fn new(
        vb: VarBuilder,
        input: usize,
        width: usize,
        hidden: usize,
        output: usize,
    ) -> Result<Self> {
        let mut dims = vec![input];
        dims.extend(std::iter::repeat_n(width, hidden));
        dims.push(output);
        let n = layer_ranges(&dims).last().map_or(0, |l| l.bias.end);
        let t = vb
            .get_with_hints(n, "params", candle_nn::Init::Const(0.0))
            .ctx("creating an MLP")?;
        // A VarMap hands out its variable itself: the optimiser and checkpoints then see the
        // values the op reads.
        let params = Var::from_tensor(&t).ctx("creating an MLP")?;
        Ok(Mlp { params, dims })
    }

    /// Widths from input to output.
    pub fn dims(&self) -> &[usize] {
        &self.dims
    }
    pub fn layers(&self) -> Vec<LayerRange> {
        layer_ranges(&self.dims)
    }
    /// The packed parameters.
    pub fn params(&self) -> &Var {
        &self.params
    }
    /// Overwrites the packed parameters (length checked).
    pub fn set_params(&self, values: Vec<f32>) -> Result<()> {
        let n = self.params.elem_count();
        let t = Tensor::from_vec(values, n, self.params.device()).ctx("MLP parameters")?;
        self.params.set(&t).ctx("MLP parameters")
    }

    /// The same network in plain candle ops (matmul, broadcast_add, relu), for tests and
    /// benchmarks against the fused op, and for devices without a fused kernel.
    pub fn forward_candle(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        Mlp::forward_candle_with(&self.layers(), x, self.params.as_tensor())
    }

    fn forward_candle_with(
        layers: &[LayerRange],
        x: &Tensor,
        p: &Tensor,
    ) -> candle_core::Result<Tensor> {
        let mut h = x.clone();
        for (i, l) in layers.iter().enumerate() {
            let w = p
                .narrow(0, l.weight.start, l.weight.len())?
                .reshape((l.output, l.input))?;
            let b = p.narrow(0, l.bias.start, l.bias.len())?;
            h = h.matmul(&w.t()?)?.broadcast_add(&b)?;
            if i + 1 < layers.len() {
                h = h.relu()?;
            }
        }
        Ok(h)
    }
}

impl Module for Mlp {
    /// The fused op on CPU (activations kept for the backward); plain candle ops elsewhere.
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        self.fused(x, self.params.as_tensor(), true)
    }
}

impl Mlp {
    /// [`Module::forward`] for queries: no gradient is recorded and the hidden activations
    /// are not kept (a 65,536-row query chunk kept 32 MB of them for a backward that never
    /// comes, as the parameters are a `Var`).
    pub fn forward_inference(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        self.fused(&x.detach(), &self.params.as_tensor().detach(), false)
    }

    fn fused(&self, x: &Tensor, params: &Tensor, keep: bool) -> candle_core::Result<Tensor> {
        if !x.device().is_cpu() {
            return Mlp::forward_candle_with(&self.layers(), x, params);
        }
        x.apply_op2(
            params,
            MlpOp {
                layers: self.layers(),
                dims: self.dims.clone(),
                stash: keep.then(|| Arc::new(Mutex::new(Vec::new()))),
            },
        )
    }
}

/// The fused forward/backward (see the module documentation). Input `[n, dims[0]]`, packed
/// parameters, output `[n, dims[last]]` before any activation.
#[derive(Clone)]
pub struct MlpOp {
    dims: Vec<usize>,
    /// `layer_ranges(dims)`, computed once.
    layers: Vec<LayerRange>,
    /// Where the forward leaves its hidden activations for the backward (block-major: each
    /// block's hidden layers together); `None` for queries, which keep none.
    stash: Option<Arc<Mutex<Vec<f32>>>>,
}

/// `c (+)= a · b` on row/column-strided views: `c` is `m × n` (row stride `c_rs`, unit column
/// stride), `a` is `m × k` and `b` is `k × n` with the given (row, column) strides. Every index
/// is checked against the slices before the call.
#[allow(clippy::too_many_arguments)]
fn matmul(
    c: &mut [f32],
    c_rs: usize,
    (m, n, k): (usize, usize, usize),
    a: &[f32],
    (a_rs, a_cs): (usize, usize),
    b: &[f32],
    (b_rs, b_cs): (usize, usize),
    accumulate: bool,
) {
    if m == 0 || n == 0 {
        return;
    }
    let last = |rows: usize, cols: usize, rs: usize, cs: usize| (rows - 1) * rs + (cols - 1) * cs;
    assert!(last(m, n, c_rs, 1) < c.len(), "mlp matmul: c out of range");
    if k == 0 {
        if !accumulate {
            for r in 0..m {
                c[r * c_rs..r * c_rs + n].fill(0.0);
            }
        }
        return;
    }
    assert!(
        last(m, k, a_rs, a_cs) < a.len(),
        "mlp matmul: a out of range"
    );
    assert!(
        last(k, n, b_rs, b_cs) < b.len(),
        "mlp matmul: b out of range"
    );
    // SAFETY: every element the product reads or writes lies within the slices (checked
    // above), `c` is borrowed mutably and does not alias `a` or `b`.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            c.as_mut_ptr(),
            1,
            c_rs as isize,
            accumulate,
            a.as_ptr(),
            a_cs as isize,
            a_rs as isize,
            b.as_ptr(),
            b_cs as isize,
            b_rs as isize,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        )
    }
}

impl MlpOp {
    /// Forward of rows `x` (`[rows, dims[0]]`) into `out`, with each hidden layer's
    /// activations written to `hidden[i]` (`[rows, dims[i + 1]]`).
    fn forward_block(&self, p: &[f32], x: &[f32], hidden: &mut [&mut [f32]], out: &mut [f32]) {
        let layers = &self.layers;
        let rows = x.len() / self.dims[0];
        for (i, l) in layers.iter().enumerate() {
            let (done, rest) = hidden.split_at_mut(i);
            let input: &[f32] = if i == 0 { x } else { &*done[i - 1] };
            let dst: &mut [f32] = if i + 1 == layers.len() {
                out
            } else {
                &mut *rest[0]
            };
            let b = &p[l.bias.clone()];
            for row in dst.chunks_exact_mut(l.output) {
                row.copy_from_slice(b);
            }
            // dst = b + input · Wᵀ (Wᵀ as k × n: row stride 1, column stride `input`).
            matmul(
                dst,
                l.output,
                (rows, l.output, l.input),
                input,
                (l.input, 1),
                &p[l.weight.clone()],
                (1, l.input),
                true,
            );
            if i + 1 < layers.len() {
                dst.iter_mut().for_each(|v| *v = v.max(0.0));
            }
        }
    }

    /// Forward of all rows of `x` into `out`, each block's hidden activations into its slice
    /// of `stash` (`per_row` values per row, block-major).
    fn forward_keeping(
        &self,
        p: &[f32],
        x: &[f32],
        out: &mut [f32],
        stash: &mut [f32],
        per_row: usize,
    ) {
        let (d_in, d_out) = (self.dims[0], *self.dims.last().unwrap());
        out.par_chunks_mut(BLOCK * d_out)
            .zip(stash.par_chunks_mut(BLOCK * per_row))
            .zip(x.par_chunks(BLOCK * d_in))
            .for_each(|((o, st), xb)| {
                let rows = xb.len() / d_in;
                let mut hidden = split_ranges(st, &self.hidden_offsets(rows));
                self.forward_block(p, xb, &mut hidden, o);
            });
    }

    /// Hidden-layer widths and their offsets in a `rows`-row stash.
    fn hidden_offsets(&self, rows: usize) -> Vec<Range<usize>> {
        let mut at = 0;
        self.dims[1..self.dims.len() - 1]
            .iter()
            .map(|&w| {
                let r = at..at + rows * w;
                at = r.end;
                r
            })
            .collect()
    }
}

/// Splits `buf` into the given consecutive ranges.
fn split_ranges<'a>(mut buf: &'a mut [f32], ranges: &[Range<usize>]) -> Vec<&'a mut [f32]> {
    let mut out = Vec::with_capacity(ranges.len());
    let mut at = 0;
    for r in ranges {
        let (_, tail) = std::mem::take(&mut buf).split_at_mut(r.start - at);
        let (a, b) = tail.split_at_mut(r.len());
        out.push(a);
        buf = b;
        at = r.end;
    }
    out
}

impl CustomOp2 for MlpOp {
    fn name(&self) -> &'static str {
        "fused-mlp"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let x = contiguous(s1, l1, "fused-mlp input")?;
        let p = contiguous(s2, l2, "fused-mlp parameters")?;
        let (d_in, d_out) = (self.dims[0], *self.dims.last().unwrap());
        let n_params = self.layers.last().map_or(0, |l| l.bias.end);
        if l1.shape().dims() != [x.len() / d_in.max(1), d_in] || p.len() != n_params {
            candle_core::bail!(
                "mlp: input {:?} and {} parameters for widths {:?}",
                l1.shape(),
                p.len(),
                self.dims
            );
        }
        let n = x.len() / d_in;
        let widths = &self.dims[1..self.dims.len() - 1];
        let mut out = zeros_par(n * d_out);
        // The stash is kept block-major (each block's hidden layers together), so that a block
        // owns one contiguous slice; at least one value per row, so that a network without
        // hidden layers still splits into the same blocks.
        let per_row: usize = widths.iter().sum::<usize>().max(1);
        match &self.stash {
            Some(keep) => {
                let mut stash = zeros_par(n * per_row);
                self.forward_keeping(p, x, &mut out, &mut stash, per_row);
                *keep.lock().unwrap() = stash;
            }
            None => out
                .par_chunks_mut(BLOCK * d_out)
                .zip(x.par_chunks(BLOCK * d_in))
                .for_each(|(o, xb)| {
                    let rows = xb.len() / d_in;
                    let mut st = vec![0f32; rows * per_row];
                    let mut hidden = split_ranges(&mut st, &self.hidden_offsets(rows));
                    self.forward_block(p, xb, &mut hidden, o);
                }),
        }
        Ok((CpuStorage::F32(out), Shape::from((n, d_out))))
    }

    fn bwd(
        &self,
        arg1: &Tensor,
        arg2: &Tensor,
        _res: &Tensor,
        grad_res: &Tensor,
    ) -> candle_core::Result<(Option<Tensor>, Option<Tensor>)> {
        // Read in place: a copy here was a serial pass over the batch's inputs.
        let want_dx = arg1.track_op();
        let names = [
            "fused-mlp input",
            "fused-mlp parameters",
            "fused-mlp gradient",
        ];
        let (dp, dx) = with_cpu_f32([arg1, arg2, grad_res], names, |[x, p, g]| {
            self.grads(x, p, g, want_dx)
        })?;
        let dp = Tensor::from_vec(dp, arg2.shape(), arg2.device())?;
        let dx = if want_dx {
            Some(Tensor::from_vec(dx, arg1.shape(), arg1.device())?)
        } else {
            None
        };
        Ok((dx, Some(dp)))
    }
}

impl MlpOp {
    /// (d loss / d parameters, d loss / d input, empty unless `want_dx`) from the input `x`,
    /// the packed parameters `p` and the output's gradient `g`.
    fn grads(&self, x: &[f32], p: &[f32], g: &[f32], want_dx: bool) -> (Vec<f32>, Vec<f32>) {
        let layers = &self.layers;
        let (d_in, d_out) = (self.dims[0], *self.dims.last().unwrap());
        let n = x.len() / d_in;
        let widths = &self.dims[1..self.dims.len() - 1];
        let per_row: usize = widths.iter().sum::<usize>().max(1);
        let mut stash = match &self.stash {
            Some(keep) => std::mem::take(&mut *keep.lock().unwrap()),
            None => Vec::new(),
        };
        if stash.len() != n * per_row {
            // No forward recorded for this input (the op was not run through `cpu_fwd`):
            // recompute the activations.
            stash = vec![0f32; n * per_row];
            self.forward_keeping(p, x, &mut vec![0f32; n * d_out], &mut stash, per_row);
        }
        // Per block: its share of the parameter gradient, and its rows of dx.
        let partial: Vec<(Vec<f32>, Vec<f32>)> = stash
            .par_chunks(BLOCK * per_row)
            .zip(x.par_chunks(BLOCK * d_in))
            .zip(g.par_chunks(BLOCK * d_out))
            .map(|((st, xb), gb)| {
                let rows = xb.len() / d_in;
                let offs = self.hidden_offsets(rows);
                let mut dp = vec![0f32; p.len()];
                // `cur`: d loss / d (layer i's output); `next`: the same for its input.
                let mut cur = gb.to_vec();
                let mut next = Vec::new();
                for (i, l) in layers.iter().enumerate().rev() {
                    let input: &[f32] = if i == 0 { xb } else { &st[offs[i - 1].clone()] };
                    // dW += Gᵀ · input (Gᵀ: row stride 1, column stride `output`).
                    matmul(
                        &mut dp[l.weight.clone()],
                        l.input,
                        (l.output, l.input, rows),
                        &cur,
                        (1, l.output),
                        input,
                        (l.input, 1),
                        true,
                    );
                    let db = &mut dp[l.bias.clone()];
                    for row in cur.chunks_exact(l.output) {
                        for (d, &v) in db.iter_mut().zip(row) {
                            *d += v;
                        }
                    }
                    if i == 0 && !want_dx {
                        cur.clear();
                        break;
                    }
                    // d input = G · W, then through the ReLU that made the input.
                    next.resize(rows * l.input, 0.0);
                    matmul(
                        &mut next,
                        l.input,
                        (rows, l.input, l.output),
                        &cur,
                        (l.output, 1),
                        &p[l.weight.clone()],
                        (l.input, 1),
                        false,
                    );
                    if i > 0 {
                        // Branch-free (a select): the signs are random, and a branch here
                        // mispredicted half the time (~2 ms a step).
                        for (d, &h) in next.iter_mut().zip(input) {
                            *d = if h > 0.0 { *d } else { 0.0 };
                        }
                    }
                    std::mem::swap(&mut cur, &mut next);
                }
                (dp, cur)
            })
            .collect();
        sum_blocks(&partial, p.len(), if want_dx { n * d_in } else { 0 })
    }
}

/// The blocks' parameter gradients summed in block order (each parameter's sum the same for
/// any thread count; the parameters in parallel chunks), and their rows of dx concatenated
/// (`dx_len` values; 0 when dx is not wanted), block by block in parallel.
fn sum_blocks(
    partial: &[(Vec<f32>, Vec<f32>)],
    p_len: usize,
    dx_len: usize,
) -> (Vec<f32>, Vec<f32>) {
    const CHUNK: usize = 512;
    let mut dp = vec![0f32; p_len];
    dp.par_chunks_mut(CHUNK).enumerate().for_each(|(c, d)| {
        for (part, _) in partial {
            for (d, &v) in d.iter_mut().zip(&part[c * CHUNK..]) {
                *d += v;
            }
        }
    });
    let mut dx = zeros_par(dx_len);
    if dx_len > 0 {
        let mut rest = &mut dx[..];
        let mut parts = Vec::with_capacity(partial.len());
        for (_, rows) in partial {
            let (head, tail) = rest.split_at_mut(rows.len());
            parts.push((head, rows));
            rest = tail;
        }
        parts
            .into_par_iter()
            .for_each(|(d, rows)| d.copy_from_slice(rows));
    }
    (dp, dx)
}
