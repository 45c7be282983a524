//! The fused MLP op against the same network in plain candle ops: outputs, the gradient of
//! the input and of the packed parameters, blocks that do not divide the batch, an input that
//! needs no gradient, and determinism across thread counts.
use candle_core::{DType, Device, Module, Tensor, Var};
use candle_nn::{VarBuilder, VarMap};
use fipt_core::rng::Pcg32;
use fipt_neural::mlp::{layer_ranges, Mlp};

fn random(n: usize, scale: f32, r: &mut Pcg32) -> Vec<f32> {
    (0..n).map(|_| (r.next_f32() * 2.0 - 1.0) * scale).collect()
}

/// A network with random parameters.
fn net(input: usize, width: usize, hidden: usize, output: usize, seed: u64) -> (Mlp, VarMap) {
    let varmap = VarMap::new();
    let vb = VarBuilder::from_varmap(&varmap, DType::F32, &Device::Cpu);
    let mlp = Mlp::new(vb.pp("net"), input, width, hidden, output).unwrap();
    let n = mlp.params().elem_count();
    mlp.set_params(random(n, 0.4, &mut Pcg32::new(seed, 1)))
        .unwrap();
    (mlp, varmap)
}

/// Output, d(Σ w·y)/dx (when `x_var`) and d(Σ w·y)/dparams through `f`.
fn run(
    mlp: &Mlp,
    f: impl Fn(&Tensor) -> Tensor,
    x: &[f32],
    rows: usize,
    w: &[f32],
    x_var: bool,
) -> (Vec<f32>, Option<Vec<f32>>, Vec<f32>) {
    let dev = Device::Cpu;
    let xt = Tensor::from_vec(x.to_vec(), (rows, x.len() / rows), &dev).unwrap();
    let xv = Var::from_tensor(&xt).unwrap();
    let input = if x_var { xv.as_tensor().clone() } else { xt };
    let y = f(&input);
    let wt = Tensor::from_vec(w.to_vec(), y.shape(), &dev).unwrap();
    let loss = (&y * wt).unwrap().sum_all().unwrap();
    let g = loss.backward().unwrap();
    let flat = |t: &Tensor| t.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    let dx = if x_var {
        Some(flat(g.get(xv.as_tensor()).unwrap()))
    } else {
        None
    };
    (flat(&y), dx, flat(g.get(mlp.params().as_tensor()).unwrap()))
}

fn assert_close(a: &[f32], b: &[f32], tol: f32, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    let scale = b.iter().fold(0f32, |m, v| m.max(v.abs())).max(1e-6);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol * scale,
            "{what}[{i}]: fused {x} vs candle {y} (scale {scale})"
        );
    }
}

#[test]
fn layer_ranges_pack_weights_then_biases() {
    let l = layer_ranges(&[3, 4, 2]);
    assert_eq!(l.len(), 2);
    assert_eq!((l[0].weight.clone(), l[0].bias.clone()), (0..12, 12..16));
    assert_eq!((l[1].weight.clone(), l[1].bias.clone()), (16..24, 24..26));
    assert_eq!((l[1].input, l[1].output), (4, 2));
}

#[test]
fn fused_forward_and_backward_match_plain_candle() {
    // 600 rows: two full blocks of 256 and a partial one. Shapes of both field MLPs plus a
    // deeper, odd-width one.
    for (input, width, hidden, output) in
        [(32, 64, 2, 5), (63, 64, 2, 1), (7, 13, 3, 2), (5, 8, 0, 3)]
    {
        let rows = 600;
        let (mlp, _vm) = net(input, width, hidden, output, input as u64);
        let mut r = Pcg32::new(7, input as u64);
        let x = random(rows * input, 1.0, &mut r);
        let w = random(rows * output, 1.0, &mut r);
        for x_var in [true, false] {
            let fused = run(&mlp, |t| mlp.forward(t).unwrap(), &x, rows, &w, x_var);
            let plain = run(
                &mlp,
                |t| mlp.forward_candle(t).unwrap(),
                &x,
                rows,
                &w,
                x_var,
            );
            let tag = format!("{input}-{width}x{hidden}-{output}");
            assert_close(&fused.0, &plain.0, 1e-5, &format!("{tag} output"));
            assert_close(&fused.2, &plain.2, 1e-4, &format!("{tag} d params"));
            match (&fused.1, &plain.1) {
                (Some(a), Some(b)) => assert_close(a, b, 1e-4, &format!("{tag} d input")),
                (None, None) => {}
                _ => panic!("{tag}: input gradient present in one and not the other"),
            }
        }
    }
}

#[test]
fn fused_parameter_gradient_matches_finite_differences() {
    // Independent of candle's ops: central differences in f64 of Σ w·y on a tiny network.
    let (rows, input, width, output) = (37, 4, 6, 2);
    let (mlp, _vm) = net(input, width, 1, output, 3);
    let mut r = Pcg32::new(9, 9);
    let x = random(rows * input, 1.0, &mut r);
    let w = random(rows * output, 1.0, &mut r);
    let (_, _, g) = run(&mlp, |t| mlp.forward(t).unwrap(), &x, rows, &w, false);
    let p0 = mlp.params().as_tensor().to_vec1::<f32>().unwrap();
    let eval = |p: &[f64]| -> f64 {
        let l = layer_ranges(&[input, width, output]);
        let mut total = 0.0f64;
        for i in 0..rows {
            let h: Vec<f64> = (0..width)
                .map(|o| {
                    let mut z = p[l[0].bias.start + o];
                    for j in 0..input {
                        z += p[l[0].weight.start + o * input + j] * x[i * input + j] as f64;
                    }
                    z.max(0.0)
                })
                .collect();
            for o in 0..output {
                let mut z = p[l[1].bias.start + o];
                for j in 0..width {
                    z += p[l[1].weight.start + o * width + j] * h[j];
                }
                total += w[i * output + o] as f64 * z;
            }
        }
        total
    };
    // In f64 with a small step, so that no ReLU kink falls inside the difference.
    let p0: Vec<f64> = p0.iter().map(|&v| v as f64).collect();
    let eps = 1e-7;
    for k in 0..p0.len() {
        let mut p = p0.clone();
        p[k] = p0[k] + eps;
        let up = eval(&p);
        p[k] = p0[k] - eps;
        let down = eval(&p);
        let fd = (up - down) / (2.0 * eps);
        assert!(
            (fd - g[k] as f64).abs() < 1e-4 * fd.abs().max(1.0),
            "param {k}: fd {fd} vs fused {}",
            g[k]
        );
    }
}

#[test]
fn fused_gradient_is_identical_across_thread_counts() {
    let (mlp, _vm) = net(32, 64, 2, 5, 11);
    let mut r = Pcg32::new(1, 1);
    let rows = 2000;
    let x = random(rows * 32, 1.0, &mut r);
    let w = random(rows * 5, 1.0, &mut r);
    let go = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&mlp, |t| mlp.forward(t).unwrap(), &x, rows, &w, true))
    };
    let (a, b) = (go(1), go(3));
    assert_eq!(a.0, b.0);
    assert_eq!(a.1, b.1);
    assert_eq!(a.2, b.2);
}

#[test]
fn inference_forward_matches_and_records_no_gradient() {
    let (mlp, _vm) = net(63, 64, 2, 1, 5);
    let mut r = Pcg32::new(2, 2);
    let rows = 700;
    let x = Tensor::from_vec(random(rows * 63, 1.0, &mut r), (rows, 63), &Device::Cpu).unwrap();
    let a = mlp.forward(&x).unwrap();
    let b = mlp.forward_inference(&x).unwrap();
    assert!(a.track_op(), "the training forward records the op");
    assert!(!b.track_op(), "a query records nothing");
    let flat = |t: &Tensor| t.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    assert_eq!(flat(&a), flat(&b));
}
