//! fipt's benchmarks, each writing one JSON report (`fipt bench --suite …`): speed is measured
//! here, never in timed tests.
//!
//! | suite | measures |
//! |---|---|
//! | [`Suite::Rays`] | BVH build, closest-hit Mrays/s (coherent and incoherent, our wrapper beside obvhs's bare traversal), path-tracing speed, thread scaling |
//! | [`Suite::Bake`] | the shading bake on a scene: pixels/s, Mrays/s against the raw BVH, time per term, and its ablations with their accuracy |
//! | [`Suite::Render`] | the re-render of a finished run's recovered scene: Mrays/s traced beside the BVH's raw incoherent rate on the same mesh and cameras, interleaved |
//! | [`Suite::Train`] | material-field training steps/s per preset, split into hash grid / MLP / optimiser, and the custom ops against plain candle |
//!
//! Every report holds the process's peak RSS. What a suite has to say while it runs goes to
//! fipt-pipeline's observer (`fipt_pipeline::observe`).
mod bake;
mod rays;
mod render;
mod train;
pub use train::profile_steps;

use std::path::PathBuf;

/// What can stop a benchmark.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Core(#[from] fipt_core::CoreError),
    #[error(transparent)]
    Shading(#[from] fipt_shading::ShadingError),
    #[error(transparent)]
    Neural(#[from] fipt_neural::NeuralError),
    #[error(transparent)]
    Candle(#[from] candle_core::Error),
    #[error(transparent)]
    Pipeline(#[from] fipt_pipeline::RunError),
    /// A request the suite cannot measure; the message says what it needs.
    #[error("{0}")]
    Invalid(String),
}

/// `Result` with [`BenchError`].
pub type Result<T, E = BenchError> = std::result::Result<T, E>;

/// Which benchmark to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    /// The BVH and the path tracer on the generated room and a 1M-triangle mesh.
    Rays,
    /// The shading bake and its ablations on a scene folder.
    Bake,
    /// Training steps per preset, custom ops against plain candle.
    Train,
    /// The re-render of a finished run beside the BVH's raw rate on the same scene.
    Render,
}

/// One benchmark run.
pub struct BenchRequest {
    pub suite: Suite,
    /// Where the JSON report goes.
    pub out: PathBuf,
    /// Smaller workloads (a smoke test).
    pub quick: bool,
    /// Repetitions of each timed measurement of the rays suite (the best is reported).
    pub reps: usize,
    /// The scene of the bake suite; the finished run folder of the render suite.
    pub scene: Option<PathBuf>,
    /// The bake suite's first N training views (default all); the render suite's first N val
    /// views (default 2).
    pub views: Option<usize>,
}

/// Runs the suite and writes its report to `req.out` (temp file, then rename).
pub fn bench(req: &BenchRequest) -> Result<()> {
    match req.suite {
        Suite::Rays => rays::run(req.quick, req.reps, &req.out),
        Suite::Bake => bake::run(req.scene.as_deref(), req.views, &req.out),
        Suite::Train => train::run(req.quick, &req.out),
        Suite::Render => render::run(
            &render::RenderBench {
                run: req.scene.as_deref(),
                views: req.views,
                reps: req.reps,
                quick: req.quick,
            },
            &req.out,
        ),
    }
}
