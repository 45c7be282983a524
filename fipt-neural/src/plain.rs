//! The hash-grid encoding written with plain candle ops (`index_select` of a `Var` table,
//! weighted sums), trained with candle-nn's dense `AdamW`: the baseline the custom op is
//! measured against, and an independent check of its forward pass.
use crate::error::{CandleContext, Result};
use crate::hashgrid::HashGrid;
use candle_core::{Tensor, Var};

/// A copy of a [`HashGrid`]'s tables as one candle `Var` (`[entries, features]`), encoded
/// with `index_select` per level and corner; corners and weights come from the grid's level
/// table, so both encodings address the same entries.
pub struct PlainEncoding {
    pub table: Var,
    features: usize,
}

impl PlainEncoding {
    /// A `Var` copy of `grid`'s tables, `[entries, features]`.
    pub fn from_grid(grid: &HashGrid) -> Result<Self> {
        let f = grid.config().features;
        let p = grid.params();
        let n = p.len() / f;
        let t = Tensor::from_vec(p, (n, f), &candle_core::Device::Cpu).ctx("plain table")?;
        Ok(PlainEncoding {
            table: Var::from_tensor(&t).ctx("plain table")?,
            features: f,
        })
    }

    /// Encodes `unit` points: `[n, levels·features]`, differentiable in the table.
    pub fn forward(&self, grid: &HashGrid, unit: &[[f32; 3]]) -> Result<Tensor> {
        let n = unit.len();
        let dev = candle_core::Device::Cpu;
        let mut per_level = Vec::with_capacity(grid.levels().len());
        let r: candle_core::Result<Tensor> = (|| {
            for (l, _) in grid.levels().iter().enumerate() {
                let mut acc: Option<Tensor> = None;
                let cw: Vec<([usize; 8], [f32; 8])> =
                    unit.iter().map(|p| grid.corners_at(l, *p)).collect();
                for k in 0..8 {
                    let idx: Vec<u32> = cw.iter().map(|c| c.0[k] as u32).collect();
                    let w: Vec<f32> = cw.iter().map(|c| c.1[k]).collect();
                    let idx = Tensor::from_vec(idx, n, &dev)?;
                    let w = Tensor::from_vec(w, (n, 1), &dev)?;
                    let e = self
                        .table
                        .as_tensor()
                        .index_select(&idx, 0)?
                        .broadcast_mul(&w)?;
                    acc = Some(match acc {
                        None => e,
                        Some(a) => (a + e)?,
                    });
                }
                per_level.push(acc.expect("8 corners"));
            }
            let out = Tensor::cat(&per_level, 1)?;
            debug_assert_eq!(out.dims(), &[n, per_level.len() * self.features]);
            Ok(out)
        })();
        r.ctx("plain hash grid")
    }
}
