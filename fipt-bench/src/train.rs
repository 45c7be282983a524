//! `fipt bench --suite train`: training steps/s per preset on synthetic surface samples, split
//! into hash grid / MLP and loss / optimiser, and the same encoding+MLP+Adam step with the hash
//! grid written in plain candle ops (index_select + a dense AdamW over the tables).
use crate::{BenchError, Result};
use candle_core::{DType, Device, Module, Tensor, Var};
use candle_nn::{Optimizer, VarBuilder, VarMap};
use fipt_core::fsutil::write_json_atomic;
use fipt_core::image::Image;
use fipt_core::presets::Presets;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{ViewShadings, DEFAULT_LEVELS, NUM_LEVELS};
use fipt_neural::hashgrid::{AdamConfig, HashGrid, HashGridOp};
use fipt_neural::mlp::Mlp;
use fipt_neural::plain::PlainEncoding;
use fipt_neural::train::TrainTimings;
use fipt_neural::{Bounds, TrainConfig, Trainer, TrainingSet};
use glam::Vec3;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// `n` samples on the faces of a 5 m box and of two inner boxes, random shadings and colours.
fn samples(n: usize) -> (TrainingSet, Bounds) {
    let side = 512;
    let views = n.div_ceil(side * side);
    let mut r = Pcg32::new(11, 0);
    let boxes = [
        (Vec3::ZERO, Vec3::splat(5.0)),
        (Vec3::splat(1.0), Vec3::splat(2.0)),
        (Vec3::new(3.0, 0.0, 3.0), Vec3::new(4.0, 1.0, 4.5)),
    ];
    let (mut pts, mut shs, mut imgs) = (vec![], vec![], vec![]);
    for _ in 0..views {
        let mut sh = ViewShadings::zeros(side, side, DEFAULT_LEVELS);
        let mut img = Image::new(side, side);
        let mut p = vec![];
        for i in 0..side * side {
            let (lo, hi) = boxes[(r.next_u32() % 3) as usize];
            let mut q = lo + (hi - lo) * Vec3::new(r.next_f32(), r.next_f32(), r.next_f32());
            let axis = (r.next_u32() % 3) as usize;
            q[axis] = if r.next_f32() < 0.5 {
                lo[axis]
            } else {
                hi[axis]
            };
            p.push(Some(q));
            sh.valid[i] = true;
            sh.ld[i] = Vec3::splat(r.next_f32() + 0.2);
            sh.ls0[i] = [Vec3::splat(r.next_f32()); NUM_LEVELS];
            sh.ls1[i] = [Vec3::splat(0.02); NUM_LEVELS];
            img.data[i] = Vec3::new(r.next_f32(), r.next_f32(), r.next_f32());
        }
        pts.push(p);
        shs.push(sh);
        imgs.push(img);
    }
    let bounds = Bounds::around(pts.iter().flatten().flatten().copied(), 1.1).unwrap();
    (
        TrainingSet::new(&pts, &shs, &imgs, &bounds).unwrap(),
        bounds,
    )
}

/// The median of timings (the upper one of an even count).
fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn ms(x: f64, n: usize) -> f64 {
    x / n as f64 * 1e3
}

/// Encoding + MLP + MSE + optimiser, with the custom op (`plain = false`) or plain candle ops.
fn encoding_step_ms(cfg: &TrainConfig, unit: &[Vec<[f32; 3]>], plain: bool) -> Result<f64> {
    let dev = Device::Cpu;
    let grid = Arc::new(HashGrid::new(cfg.field.grid.clone(), 1)?);
    let varmap = VarMap::new();
    let vb = VarBuilder::from_varmap(&varmap, DType::F32, &dev);
    let mlp = Mlp::new(
        vb,
        grid.output_dim(),
        cfg.field.mlp_width,
        cfg.field.mlp_hidden,
        5,
    )?;
    let plain_enc = if plain {
        Some(PlainEncoding::from_grid(&grid)?)
    } else {
        None
    };
    let mut vars = varmap.all_vars();
    if let Some(p) = &plain_enc {
        vars.push(p.table.clone());
    }
    let params = candle_nn::ParamsAdamW {
        lr: 1e-3,
        weight_decay: 0.0,
        ..Default::default()
    };
    let mut opt = candle_nn::AdamW::new(vars, params)?;
    let adam = AdamConfig::default();
    let mut times = vec![];
    for (k, batch) in unit.iter().enumerate() {
        let t0 = Instant::now();
        let n = batch.len();
        let pts = Tensor::from_vec(
            batch.iter().flatten().copied().collect::<Vec<_>>(),
            (n, 3),
            &dev,
        )?;
        let enc = match &plain_enc {
            Some(p) => p.forward(&grid, batch)?,
            None => Var::from_tensor(&pts)?
                .as_tensor()
                .apply_op1(HashGridOp::new(grid.clone()))?,
        };
        let h = if plain_enc.is_some() {
            mlp.forward_candle(&enc)?
        } else {
            mlp.forward(&enc)?
        };
        let y = candle_nn::ops::sigmoid(&h)?;
        let loss = y.affine(1.0, -0.3)?.sqr()?.mean_all()?;
        opt.backward_step(&loss)?;
        if plain_enc.is_none() {
            grid.adam_step(&adam);
        }
        if k >= 2 {
            times.push(t0.elapsed().as_secs_f64());
        }
    }
    Ok(median(times) * 1e3)
}

/// Median forward + backward of one MLP on 8192 rows: the fused op or plain candle ops.
fn mlp_step_ms(
    input: usize,
    width: usize,
    hidden: usize,
    output: usize,
    plain: bool,
) -> Result<f64> {
    let dev = Device::Cpu;
    let varmap = VarMap::new();
    let mlp = Mlp::new(
        VarBuilder::from_varmap(&varmap, DType::F32, &dev),
        input,
        width,
        hidden,
        output,
    )?;
    let mut r = Pcg32::new(3, 4);
    let n = mlp.params().elem_count();
    mlp.set_params((0..n).map(|_| r.next_f32() * 0.2 - 0.1).collect())?;
    let x = Var::from_tensor(&Tensor::from_vec(
        (0..8192 * input).map(|_| r.next_f32()).collect::<Vec<_>>(),
        (8192, input),
        &dev,
    )?)?;
    let mut times = vec![];
    for k in 0..23 {
        let t0 = Instant::now();
        let y = if plain {
            mlp.forward_candle(x.as_tensor())?
        } else {
            mlp.forward(x.as_tensor())?
        };
        let grads = y.sqr()?.mean_all()?.backward()?;
        if grads.get(mlp.params().as_tensor()).is_none() {
            return Err(BenchError::Invalid("no MLP gradient".into()));
        }
        if k >= 3 {
            times.push(t0.elapsed().as_secs_f64());
        }
    }
    Ok(median(times) * 1e3)
}

/// Median and mean seconds of `steps` training steps of `cfg` at batch `batch` (3 steps of
/// warm-up first), and the mean split of a step in ms (batch, hash grid forward / backward
/// with its Adam, MLPs and loss, MLP optimiser).
fn step_seconds(
    cfg: &TrainConfig,
    batch: usize,
    steps: usize,
    data: &TrainingSet,
    bounds: Bounds,
) -> Result<(f64, f64, serde_json::Value)> {
    let mut cfg = cfg.clone();
    cfg.batch = batch;
    cfg.steps = steps + 3;
    let mut t = Trainer::new(cfg, bounds, data.levels)?;
    for _ in 0..3 {
        t.step(data)?;
    }
    let warm = t.timings;
    let mut each = Vec::with_capacity(steps);
    for _ in 0..steps {
        let t1 = Instant::now();
        t.step(data)?;
        each.push(t1.elapsed().as_secs_f64());
    }
    let mean = each.iter().sum::<f64>() / steps as f64;
    let split = step_split(&t.timings, &warm, steps);
    Ok((median(each), mean, split))
}

/// The mean split of the steps between two timing snapshots, in ms per step.
fn step_split(tm: &TrainTimings, warm: &TrainTimings, steps: usize) -> serde_json::Value {
    let grid_fwd = tm.grid_forward - warm.grid_forward;
    let grid_bwd =
        (tm.grid_backward - warm.grid_backward) + (tm.grid_optimizer - warm.grid_optimizer);
    let batch = tm.batch - warm.batch;
    let opt = tm.optimizer - warm.optimizer;
    let rest = tm.total() - warm.total() - grid_fwd - grid_bwd - batch - opt;
    serde_json::json!({
        "batch": ms(batch, steps), "grid_forward": ms(grid_fwd, steps),
        "grid_backward_and_adam": ms(grid_bwd, steps), "mlps_and_loss": ms(rest, steps),
        "mlp_optimizer": ms(opt, steps),
    })
}

/// Least squares of t = a + c·x over the points (x, t), each weighted by 1/t² (relative
/// errors: the small batches, where the fixed part shows, count as much as the large); (a, c).
fn fit_line(points: &[(f64, f64)]) -> (f64, f64) {
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(x, y) in points {
        let w = 1.0 / (y * y).max(1e-12);
        sw += w;
        sx += w * x;
        sy += w * y;
        sxx += w * x * x;
        sxy += w * x * y;
    }
    let det = sw * sxx - sx * sx;
    if det.abs() < 1e-300 {
        return (sy / sw, 0.0);
    }
    let c = (sw * sxy - sx * sy) / det;
    ((sy - c * sx) / sw, c)
}

/// The batch sweep at the current pool's thread count T: per batch size the median and mean
/// step, and the fit of t = a + c·B/T.
fn sweep_at(
    cfg: &TrainConfig,
    data: &TrainingSet,
    bounds: Bounds,
    quick: bool,
) -> Result<(Vec<serde_json::Value>, f64, f64)> {
    let threads = rayon::current_num_threads() as f64;
    let sizes: &[usize] = if quick {
        &[1024, 8192, 32768]
    } else {
        &[1024, 2048, 4096, 8192, 16384, 32768, 65536]
    };
    let mut rows = vec![];
    let mut points = vec![];
    for &b in sizes {
        // About a second of steps each, at least 10.
        let steps = if quick {
            6
        } else {
            (400_000 / b).clamp(10, 200)
        };
        let (med, mean, split) = step_seconds(cfg, b, steps, data, bounds)?;
        points.push((b as f64 / threads, med * 1e3));
        rows.push(serde_json::json!({
            "threads": threads, "batch": b, "steps": steps, "ms_median": med * 1e3,
            "ms_mean": mean * 1e3, "mean_over_median": mean / med,
            "samples_per_second": b as f64 / med, "ms_split_mean": split,
        }));
    }
    let (a, c) = fit_line(&points);
    Ok((rows, a, c))
}

/// The step time against the batch size B, at 1 thread and at this machine's T, each fitted as
/// t = a + c·B/T (a: what a step costs whatever its batch; c: one sample's cost on one
/// thread). c grows with the threads (memory and hand-offs shared by more of them): taken as
/// c(T) = c₁·(1 + k·(T − 1)), with k from the two sweeps, the fit predicts each preset's step
/// at 16 and 64 threads.
fn batch_sweep(
    preset: &str,
    cfg: &TrainConfig,
    data: &TrainingSet,
    bounds: Bounds,
    quick: bool,
) -> Result<serde_json::Value> {
    let threads = rayon::current_num_threads() as f64;
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| BenchError::Invalid(e.to_string()))?;
    let (mut rows, a1, c1) = one.install(|| sweep_at(cfg, data, bounds, quick))?;
    let (a, k) = if threads > 1.0 {
        let (more, a, c) = sweep_at(cfg, data, bounds, quick)?;
        rows.extend(more);
        (a, ((c / c1 - 1.0) / (threads - 1.0)).max(0.0))
    } else {
        (a1, 0.0)
    };
    let b = cfg.batch as f64;
    let at = |t: f64| {
        if t <= 1.0 {
            a1 + c1 * b
        } else {
            a + c1 * (1.0 + k * (t - 1.0)) * b / t
        }
    };
    // The same without the growth of c: every thread as fast as one alone.
    let ideal = |t: f64| a + c1 * b / t;
    if threads <= 1.0 {
        // One thread cannot show how the per-sample cost grows: no prediction.
        return Ok(serde_json::json!({
            "rows": rows,
            "fit": {"model": "t_ms = a + c1 * batch", "a_ms_1_thread": a1, "c1_ms_per_sample": c1},
            "preset_batch": cfg.batch,
            "predicted_speedup_16_threads": null,
            "note": "measured at 1 thread only: run with 2 or more threads for a prediction",
        }));
    }
    fipt_pipeline::note!(
        "{preset:>8} batch sweep: 1 thread t = {a1:.2} ms + {c1:.5} ms × B; {threads} threads a = {a:.2} ms, per-sample cost ×{:.2}; batch {}: predicted ×{:.1} at 16 threads against 1 (×{:.1} against 2; ×{:.1} were c constant)",
        1.0 + k * (threads - 1.0),
        cfg.batch,
        at(1.0) / at(16.0),
        at(2.0) / at(16.0),
        at(1.0) / ideal(16.0),
    );
    Ok(serde_json::json!({
        "rows": rows,
        "fit": {
            "model": "t_ms = a + c1 * (1 + k * (threads - 1)) * batch / threads",
            "a_ms_1_thread": a1, "c1_ms_per_sample": c1,
            "threads": threads, "a_ms": a, "k": k,
        },
        "preset_batch": cfg.batch,
        "predicted_ms_per_step": {"1": at(1.0), "2": at(2.0), "16": at(16.0), "64": at(64.0)},
        "predicted_speedup_16_threads": at(1.0) / at(16.0),
        "predicted_speedup_64_threads": at(1.0) / at(64.0),
        "predicted_speedup_2_to_16_threads": at(2.0) / at(16.0),
        "predicted_speedup_16_threads_if_c_constant": at(1.0) / ideal(16.0),
    }))
}

/// One preset's steps/s and their split (and, sized on data, its batch sweep).
fn preset_row(
    name: &str,
    sizing: &str,
    fp: Option<f32>,
    steps: usize,
    data: &TrainingSet,
    bounds: Bounds,
    quick: bool,
) -> Result<serde_json::Value> {
    let mut cfg = TrainConfig::preset(name)
        .unwrap()
        .sized_for(data.len(), fp, &bounds);
    cfg.steps = steps + 3;
    let mut t = Trainer::new(cfg.clone(), bounds, data.levels)?;
    for _ in 0..3 {
        t.step(data)?;
    }
    let warm = t.timings;
    let t0 = Instant::now();
    let mut each = Vec::with_capacity(steps);
    for _ in 0..steps {
        let t1 = Instant::now();
        t.step(data)?;
        each.push(t1.elapsed().as_secs_f64());
    }
    let secs = t0.elapsed().as_secs_f64();
    // The median step is robust to the other work of a shared machine.
    let median = median(each);
    let tm = t.timings;
    let grid = (tm.grid_forward - warm.grid_forward)
        + (tm.grid_backward - warm.grid_backward)
        + (tm.grid_optimizer - warm.grid_optimizer);
    let opt = tm.optimizer - warm.optimizer;
    let total = tm.total() - warm.total();
    let row = serde_json::json!({
        "preset": name,
        "sizing": sizing,
        "footprint_m": fp,
        "levels": cfg.field.grid.levels,
        "per_level_scale": cfg.field.grid.per_level_scale,
        "log2_table": cfg.field.grid.log2_table,
        "params": t.field.num_params(),
        "steps_per_second": steps as f64 / secs,
        "steps_per_second_median": 1.0 / median,
        "ms_per_step": ms(secs, steps),
        "ms_hash_grid": ms(grid, steps),
        "ms_hash_grid_forward": ms(tm.grid_forward - warm.grid_forward, steps),
        "ms_hash_grid_backward": ms(tm.grid_backward - warm.grid_backward, steps),
        "ms_hash_grid_optimizer": ms(tm.grid_optimizer - warm.grid_optimizer, steps),
        // The tables' Adam step runs inside the backward (booked under the grid), so
        // the trainer's optimiser time is the MLPs' alone.
        "ms_mlp_and_loss": ms(total - grid - opt - (tm.batch - warm.batch), steps),
        "ms_mlp_optimizer": ms(opt, steps),
        "ms_batch_gather": ms(tm.batch - warm.batch, steps),
    });
    fipt_pipeline::note!(
        "{name:>8} sized {sizing:<12} finest {:>5} cells, 2^{} tables: {:.1} steps/s (median step {:.1}); ms per step: hash grid {:.1}, MLPs and loss {:.1}, batch {:.1}",
        t.field.grid().levels().last().map_or(0, |l| l.resolution),
        cfg.field.grid.log2_table,
        steps as f64 / secs,
        1.0 / median,
        row["ms_hash_grid"].as_f64().unwrap_or(0.0),
        row["ms_mlp_and_loss"].as_f64().unwrap_or(0.0),
        row["ms_batch_gather"].as_f64().unwrap_or(0.0),
    );
    let mut row = row;
    if sizing == "data" {
        row["batch_sweep"] = batch_sweep(name, &cfg, data, bounds, quick)?;
    }
    Ok(row)
}

pub fn run(quick: bool, out: &Path) -> Result<()> {
    let steps = if quick { 6 } else { 50 };
    let (data, bounds) = samples(if quick { 300_000 } else { 1_000_000 });
    fipt_pipeline::note!(
        "{} synthetic surface samples; batch 8192; {steps} timed steps per preset",
        data.len()
    );
    // The samples' spacing stands for the median pixel footprint a real run measures:
    // √(surface area / samples) (the three boxes have 150 + 6 + 9.5 m² of faces).
    let footprint = (165.5 / data.len() as f32).sqrt();
    let mut presets = vec![];
    // Each preset as a run sizes it on data with that footprint, then without a footprint
    // (the finest level stays at the preset's fixed scale: for balanced, 2000 cells across).
    let sizings = [("data", Some(footprint)), ("no_footprint", None)];
    for (name, (sizing, fp)) in ["fast", "balanced", "paper"]
        .into_iter()
        .flat_map(|n| sizings.iter().map(move |s| (n, *s)))
    {
        presets.push(preset_row(name, sizing, fp, steps, &data, bounds, quick)?);
    }
    // Custom op vs plain candle ops, same sizes (balanced), same MLP, same loss.
    let cfg = TrainConfig::default().sized_for(data.len(), None, &bounds);
    let mut r = Pcg32::new(5, 5);
    let batches: Vec<Vec<[f32; 3]>> = (0..steps.min(12))
        .map(|_| {
            (0..8192)
                .map(|_| data.unit[(r.next_u32() as usize) % data.len()])
                .collect()
        })
        .collect();
    let custom = encoding_step_ms(&cfg, &batches, false)?;
    let plain = encoding_step_ms(&cfg, &batches, true)?;
    fipt_pipeline::note!("encoding + MLP + Adam step, balanced sizes: custom ops {custom:.1} ms, plain candle {plain:.1} ms (×{:.2})", plain / custom);
    let mut mlps = vec![];
    let f = &cfg.field;
    for (name, input, width, hidden, output) in [
        (
            "material",
            f.grid.output_dim(),
            f.mlp_width,
            f.mlp_hidden,
            5,
        ),
        (
            "mask",
            3 + 6 * f.mask_frequencies,
            f.mask_width,
            f.mask_hidden,
            1,
        ),
    ] {
        let fused = mlp_step_ms(input, width, hidden, output, false)?;
        let plain = mlp_step_ms(input, width, hidden, output, true)?;
        fipt_pipeline::note!("{name} MLP forward + backward, 8192 rows: fused op {fused:.2} ms, plain candle {plain:.2} ms (×{:.2})", plain / fused);
        mlps.push(serde_json::json!({
            "mlp": name, "input": input, "width": width, "hidden": hidden, "output": output,
            "fused_ms": fused, "plain_candle_ms": plain, "speedup": plain / fused,
        }));
    }
    let report = serde_json::json!({
        "suite": "train",
        "threads": rayon::current_num_threads(),
        "samples": data.len(),
        "batch": 8192,
        "presets": presets,
        "encoding_step_ms": {"custom_op": custom, "plain_candle": plain, "speedup": plain / custom},
        "mlp_step_ms": mlps,
        "peak_rss_mib": fipt_core::memory::peak_rss_mib(),
    });
    write_json_atomic(out, &report)?;
    Ok(())
}

/// `steps` training steps of `preset` (sized on the benchmark's samples) at batch `batch` in
/// the current thread pool, nothing else: a target for a profiler
/// (`cargo run --release -p fipt-bench --example train_steps -- balanced 65536 40`). Returns
/// the median step in ms and its split (as in the batch sweep's rows).
pub fn profile_steps(preset: &str, batch: usize, steps: usize) -> Result<(f64, serde_json::Value)> {
    let (data, bounds) = samples(1_000_000);
    let footprint = (165.5 / data.len() as f32).sqrt();
    let cfg = TrainConfig::preset(preset)
        .ok_or_else(|| BenchError::Invalid(format!("no preset {preset}")))?
        .sized_for(data.len(), Some(footprint), &bounds);
    let (median, _, split) = step_seconds(&cfg, batch, steps, &data, bounds)?;
    Ok((median * 1e3, split))
}
