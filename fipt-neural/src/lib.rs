//! # fipt-neural
//!
//! The material field of fipt-rs (method §4.3), on candle:
//!
//! * [`hashgrid::HashGrid`]: a multi-resolution hash-grid encoding as a candle custom op with
//!   rayon forward/backward and a lazy Adam over the touched table entries;
//! * [`field::NeuralField`]: hash grid + MLP → sigmoid → albedo, roughness (0.02 + 0.98·s),
//!   metallic; and the emission mask, an MLP on a 10-frequency positional encoding with
//!   α = 1 − exp(−relu(m)). Implements [`fipt_core::field::MaterialField`];
//! * [`train::Trainer`]: batches of training pixels, the loss of the reference (sRGB-OETF MSE,
//!   mask sparsity, roughness/metallic prior), Adam, checkpoints (safetensors) and exact resume;
//! * [`mlp::Mlp`]: the field's MLPs, whose forward and backward are one fused CPU op each
//!   (blocks of rows in parallel, matrix products by `gemm`);
//! * [`plain`]: the same encoding from plain candle ops, the baseline of the benchmark.
//!
//! CPU only: the hash grid, the MLPs and the loss are fused CPU ops with hand-written
//! backward passes; there is no GPU backend (no kernel here has a CUDA version, so a `cuda`
//! feature would change nothing and is not offered).
pub mod adam;
pub mod error;
pub mod field;
pub mod hashgrid;
pub mod head;
pub mod image_loss;
pub mod mlp;
pub mod ops;
pub mod plain;
pub mod train;
pub mod trainer;

pub use error::{NeuralError, Result};
pub use field::{Bounds, FieldConfig, NeuralField};
pub use hashgrid::{AdamConfig, HashGrid, HashGridConfig};
pub use train::{LrDecay, PriorNorm, TrainConfig, Trainer, TrainingSet};
pub use trainer::HashGridTrainer;
