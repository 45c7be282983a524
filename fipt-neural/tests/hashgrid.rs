//! The hash-grid op: forward against a naive encoder and against plain candle ops; backward
//! against finite differences, alone and inside candle's autograd behind an MLP; lazy Adam.
use candle_core::{Device, Module, Tensor, Var};
use fipt_core::rng::Pcg32;
use fipt_neural::hashgrid::{AdamConfig, HashGrid, HashGridConfig, HashGridOp};
use fipt_neural::plain::PlainEncoding;

fn small_config() -> HashGridConfig {
    HashGridConfig {
        levels: 6,
        features: 2,
        log2_table: 10,
        base_resolution: 3,
        per_level_scale: 1.9,
        init_scale: 0.5,
    }
}

fn points(n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut r = Pcg32::new(seed, 1);
    let mut v: Vec<[f32; 3]> = (0..n)
        .map(|_| [r.next_f32(), r.next_f32(), r.next_f32()])
        .collect();
    // The cube's faces, corners and outside points (clamped) are legal inputs.
    v.extend([
        [0.0, 0.0, 0.0],
        [1.0, 1.0, 1.0],
        [1.0, 0.5, 0.0],
        [-0.5, 2.0, 0.3],
    ]);
    v
}

/// Straightforward per-point encoding written independently of the op: integer cell, 8
/// corners by nested loops, the documented hash, trilinear weights.
fn naive(grid: &HashGrid, p: [f32; 3]) -> Vec<f32> {
    let f = grid.config().features;
    let params = grid.params();
    let mut out = vec![];
    for level in grid.levels() {
        let r = level.resolution as f32;
        let q: Vec<f32> = p.iter().map(|&x| x.clamp(0.0, 1.0) * r).collect();
        let base: Vec<u32> = q
            .iter()
            .map(|&x| (x.floor() as u32).min(level.resolution - 1))
            .collect();
        let t: Vec<f32> = q.iter().zip(&base).map(|(&x, &b)| x - b as f32).collect();
        let mut acc = vec![0.0f32; f];
        for dz in 0..2u32 {
            for dy in 0..2u32 {
                for dx in 0..2u32 {
                    let c = [base[0] + dx, base[1] + dy, base[2] + dz];
                    let w = [dx, dy, dz]
                        .iter()
                        .zip(&t)
                        .map(|(&d, &t)| if d == 1 { t } else { 1.0 - t })
                        .product::<f32>();
                    let e = if level.dense {
                        let n = level.resolution as u64 + 1;
                        (c[0] as u64 + n * c[1] as u64 + n * n * c[2] as u64) as usize
                    } else {
                        let h = (c[0] as u64)
                            ^ ((c[1] as u64 * 2_654_435_761) & 0xFFFF_FFFF)
                            ^ ((c[2] as u64 * 805_459_861) & 0xFFFF_FFFF);
                        (h as usize) % level.size
                    };
                    for j in 0..f {
                        acc[j] += w * params[(level.offset + e) * f + j];
                    }
                }
            }
        }
        out.extend(acc);
    }
    out
}

#[test]
fn level_table_mixes_dense_and_hashed_levels() {
    let g = HashGrid::new(small_config(), 1).unwrap();
    let lv = g.levels();
    assert!(lv[0].dense && !lv[lv.len() - 1].dense, "{lv:?}");
    for w in lv.windows(2) {
        assert!(w[1].resolution >= w[0].resolution);
        assert_eq!(w[1].offset, w[0].offset + w[0].size);
    }
    assert_eq!(
        g.num_params(),
        (lv.last().unwrap().offset + lv.last().unwrap().size) * 2
    );
}

#[test]
fn forward_matches_naive_and_plain_candle() {
    let g = HashGrid::new(small_config(), 2).unwrap();
    let pts = points(500, 3);
    let enc = g.encode(&pts);
    let d = g.output_dim();
    for (i, p) in pts.iter().enumerate() {
        let n = naive(&g, *p);
        for j in 0..d {
            assert!(
                (enc[i * d + j] - n[j]).abs() < 1e-5,
                "point {i} {p:?} value {j}: {} vs {}",
                enc[i * d + j],
                n[j]
            );
        }
    }
    let plain = PlainEncoding::from_grid(&g).unwrap();
    let pe = plain
        .forward(&g, &pts)
        .unwrap()
        .flatten_all()
        .unwrap()
        .to_vec1::<f32>()
        .unwrap();
    let max = pe
        .iter()
        .zip(&enc)
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(max < 1e-5, "plain candle differs by {max}");
}

#[test]
fn backward_matches_finite_differences() {
    let g = HashGrid::new(small_config(), 4).unwrap();
    let pts = points(64, 5);
    let d = g.output_dim();
    let mut r = Pcg32::new(6, 0);
    let wts: Vec<f32> = (0..pts.len() * d)
        .map(|_| r.next_f32() * 2.0 - 1.0)
        .collect();
    // L = Σ w · enc, so dL/dθ is what accumulate_grad computes for grad_out = w.
    g.accumulate_grad(&pts, &wts);
    let grad = g.pending_grad();
    let loss = |g: &HashGrid| -> f64 {
        g.encode(&pts)
            .iter()
            .zip(&wts)
            .map(|(a, b)| *a as f64 * *b as f64)
            .sum()
    };
    let params = g.params();
    let nonzero: Vec<usize> = (0..params.len()).filter(|&i| grad[i] != 0.0).collect();
    assert!(nonzero.len() > 50, "only {} entries touched", nonzero.len());
    let mut checked = 0;
    for &i in nonzero
        .iter()
        .step_by(nonzero.len() / 40)
        .chain([0usize, params.len() - 1].iter())
    {
        let h = 1e-2f32;
        g.set_param(i, params[i] + h);
        let lp = loss(&g);
        g.set_param(i, params[i] - h);
        let lm = loss(&g);
        g.set_param(i, params[i]);
        let fd = (lp - lm) / (2.0 * h as f64);
        assert!(
            (fd - grad[i] as f64).abs() < 2e-3 * (1.0 + fd.abs()),
            "entry {i}: fd {fd} vs {}",
            grad[i]
        );
        checked += 1;
    }
    assert!(checked >= 40);
}

#[test]
fn gradient_flows_through_candle_autograd() {
    // enc → linear(·) → squared sum: the op's backward is called by candle with the MLP's
    // upstream gradient; compare with finite differences of the whole loss.
    let g = std::sync::Arc::new(HashGrid::new(small_config(), 7).unwrap());
    let pts = points(32, 8);
    let dev = Device::Cpu;
    let d = g.output_dim();
    let mut r = Pcg32::new(9, 0);
    let wv: Vec<f32> = (0..3 * d).map(|_| r.next_f32() - 0.5).collect();
    let lin = candle_nn::Linear::new(Tensor::from_vec(wv, (3, d), &dev).unwrap(), None);
    let loss_of = |train: bool| -> (Tensor, f64) {
        let flat: Vec<f32> = pts.iter().flatten().copied().collect();
        let t = Tensor::from_vec(flat, (pts.len(), 3), &dev).unwrap();
        let enc = if train {
            Var::from_tensor(&t)
                .unwrap()
                .as_tensor()
                .apply_op1(HashGridOp::new(g.clone()))
                .unwrap()
        } else {
            Tensor::from_vec(g.encode(&pts), (pts.len(), d), &dev).unwrap()
        };
        let l = lin.forward(&enc).unwrap().sqr().unwrap().sum_all().unwrap();
        let v = l.to_scalar::<f32>().unwrap() as f64;
        (l, v)
    };
    let (l, _) = loss_of(true);
    l.backward().unwrap();
    let grad = g.pending_grad();
    let params = g.params();
    let idx: Vec<usize> = (0..params.len())
        .filter(|&i| grad[i].abs() > 1e-4)
        .collect();
    assert!(idx.len() > 20);
    for &i in idx.iter().step_by(idx.len() / 20) {
        let h = 1e-2;
        g.set_param(i, params[i] + h);
        let lp = loss_of(false).1;
        g.set_param(i, params[i] - h);
        let lm = loss_of(false).1;
        g.set_param(i, params[i]);
        let fd = (lp - lm) / (2.0 * h as f64);
        assert!(
            (fd - grad[i] as f64).abs() < 1e-2 * (1.0 + fd.abs()),
            "entry {i}: fd {fd} vs autograd {}",
            grad[i]
        );
    }
}

#[test]
fn lazy_adam_moves_only_touched_entries_and_clears_the_gradient() {
    let g = HashGrid::new(small_config(), 10).unwrap();
    let before = g.params();
    let pts = vec![[0.3f32, 0.6, 0.2]];
    let go = vec![1.0f32; g.output_dim()];
    g.accumulate_grad(&pts, &go);
    let touched: Vec<usize> = g
        .pending_grad()
        .iter()
        .enumerate()
        .filter(|(_, &x)| x != 0.0)
        .map(|(i, _)| i)
        .collect();
    assert!(!touched.is_empty() && touched.len() <= 8 * g.output_dim());
    let cfg = AdamConfig::default();
    g.adam_step(&cfg);
    let after = g.params();
    for i in 0..before.len() {
        if touched.contains(&i) {
            // First Adam step moves by lr·sign(g) (up to eps); the gradient is positive.
            assert!((before[i] - after[i] - cfg.lr).abs() < 1e-6, "entry {i}");
        } else {
            assert_eq!(before[i], after[i], "untouched entry {i} moved");
        }
    }
    assert!(g.pending_grad().iter().all(|&x| x == 0.0));
    // A second step with no gradient moves nothing.
    g.adam_step(&cfg);
    assert_eq!(g.params(), after);
}

#[test]
fn update_in_backward_equals_accumulate_then_step_bit_for_bit() {
    // Two grids from the same seed; five steps of 300 points with random gradients (some rows
    // zero), one grid stepping inside the backward, the other with the two separate calls.
    let (a, b) = (
        HashGrid::new(small_config(), 4).unwrap(),
        HashGrid::new(small_config(), 4).unwrap(),
    );
    let cfg = AdamConfig {
        lr: 1e-2,
        ..AdamConfig::default()
    };
    let mut r = Pcg32::new(3, 3);
    for step in 0..5 {
        let pts = points(300, 20 + step);
        let go: Vec<f32> = (0..pts.len() * a.output_dim())
            .map(|i| {
                if (i / a.output_dim()) % 7 == 0 {
                    0.0
                } else {
                    r.next_f32() - 0.5
                }
            })
            .collect();
        a.accumulate_and_step(&pts, &go, &cfg);
        b.accumulate_grad(&pts, &go);
        b.adam_step(&cfg);
        assert_eq!(a.state(), b.state(), "step {step}");
        assert!(a.pending_grad().iter().all(|&x| x == 0.0));
    }
    assert_eq!(a.steps(), 5);
    assert_ne!(
        a.params(),
        HashGrid::new(small_config(), 4).unwrap().params()
    );
}
