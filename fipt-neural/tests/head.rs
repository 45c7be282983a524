//! The field head as one op against the same head in candle's element-wise ops: the same
//! values forward and backward (to the bit, up to the sign of zero), for every setting.
use candle_core::{Device, Tensor, Var};
use fipt_core::rng::Pcg32;
use fipt_neural::head::{alphas, head_candle, materials, FieldHead, HeadConfig, PACKED};
use std::sync::Arc;

/// Raw outputs spanning the sigmoid's and the softplus's extremes (saturated at ±30, exactly
/// 0, tiny) and a loss gradient per packed value.
fn inputs(n: usize, seed: u64) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut rng = Pcg32::new(seed, 7);
    let mut raw = |i: usize| match i % 9 {
        0 => 0.0,
        1 => 30.0,
        2 => -30.0,
        3 => 1e-7,
        _ => (rng.next_f32() - 0.5) * 12.0,
    };
    let h: Vec<f32> = (0..n * 5).map(&mut raw).collect();
    let m: Vec<f32> = (0..n).map(|i| raw(i + 3)).collect();
    let mut rng = Pcg32::new(seed, 9);
    let g: Vec<f32> = (0..n * PACKED).map(|_| rng.next_f32() - 0.5).collect();
    (h, m, g)
}

/// (packed output, d/dh, d/dm) of `sum(head(h, m) · g)`, by the op or by candle's ops.
fn run(cfg: &HeadConfig, fused: bool, (h, m, g): &(Vec<f32>, Vec<f32>, Vec<f32>)) -> [Vec<f32>; 3] {
    let dev = Device::Cpu;
    let n = m.len();
    let hv = Var::from_tensor(&Tensor::from_vec(h.clone(), (n, 5), &dev).unwrap()).unwrap();
    let mv = Var::from_tensor(&Tensor::from_vec(m.clone(), (n, 1), &dev).unwrap()).unwrap();
    let out = if fused {
        hv.as_tensor()
            .apply_op2(mv.as_tensor(), FieldHead(cfg.clone()))
    } else {
        head_candle(hv.as_tensor(), mv.as_tensor(), cfg)
    }
    .unwrap();
    let gt = Tensor::from_vec(g.clone(), (n, PACKED), &dev).unwrap();
    let grads = (&out * &gt).unwrap().sum_all().unwrap().backward().unwrap();
    let flat = |t: &Tensor| t.flatten_all().unwrap().to_vec1::<f32>().unwrap();
    [
        flat(&out),
        flat(grads.get(hv.as_tensor()).unwrap()),
        flat(grads.get(mv.as_tensor()).unwrap()),
    ]
}

fn configs(n: usize) -> Vec<HeadConfig> {
    let leak: Arc<Vec<f32>> = Arc::new(
        (0..n)
            .map(|i| if i % 3 == 0 { 0.02 } else { 0.0 })
            .collect(),
    );
    let mut out = vec![];
    for gain in [1.0, 10.0] {
        for leak in [None, Some(leak.clone())] {
            for softplus in [false, true] {
                out.push(HeadConfig {
                    gain,
                    leak: leak.clone(),
                    softplus,
                });
            }
        }
    }
    out
}

#[test]
fn fused_head_equals_candle_ops_forward_and_backward() {
    let n = 3000; // three tasks of 1024 rows, the last one partial
    let data = inputs(n, 11);
    for cfg in configs(n) {
        let a = run(&cfg, true, &data);
        let b = run(&cfg, false, &data);
        for (what, (x, y)) in ["output", "d/dh", "d/dm"].iter().zip(a.iter().zip(&b)) {
            assert_eq!(x.len(), y.len());
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                assert!(u.is_finite(), "{what}[{i}] = {u} with {cfg:?}");
                assert!(u == v, "{what}[{i}]: op {u:e} vs candle {v:e} with {cfg:?}");
            }
        }
    }
}

#[test]
fn query_head_equals_the_training_op() {
    let n = 2000;
    let (h, m, g) = inputs(n, 5);
    for cfg in configs(n).into_iter().filter(|c| c.leak.is_none()) {
        let [out, _, _] = run(&cfg, true, &(h.clone(), m.clone(), g.clone()));
        let mats = materials(&h, cfg.gain);
        let al = alphas(&m, cfg.softplus);
        for j in 0..n {
            assert_eq!(&out[j * PACKED..j * PACKED + 5], &mats[j * 5..j * 5 + 5]);
            assert_eq!(out[j * PACKED + 5], al[j]);
        }
    }
}

#[test]
fn head_ranges_and_slopes() {
    // σ spans [MIN_ROUGHNESS, 1], α [0, 1); α's slope is positive for softplus at any m and
    // zero for relu below 0; the leak keeps σ's logit slope ≥ gain·leak where σ saturates.
    let cfg = HeadConfig {
        gain: 10.0,
        leak: Some(Arc::new(vec![0.02; 4])),
        softplus: true,
    };
    let h = vec![
        -30.0, 0.0, 30.0, 30.0, 0.0, 30.0, 0.0, -30.0, -30.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        1.0, 1.0, 0.1, 1.0,
    ];
    let m = vec![-40.0, -1.0, 0.0, 40.0];
    let mut g = vec![0.0; 4 * PACKED];
    for j in 0..4 {
        g[j * PACKED + 3] = 1.0;
        g[j * PACKED + 5] = 1.0;
    }
    let [out, dh, dm] = run(&cfg, true, &(h, m.clone(), g.clone()));
    for j in 0..4 {
        let sigma = out[j * PACKED + 3];
        assert!(
            (fipt_core::materials::MIN_ROUGHNESS..=1.0).contains(&sigma),
            "σ {sigma}"
        );
        let alpha = out[j * PACKED + 5];
        assert!(
            (0.0..1.0).contains(&alpha) || (alpha == 1.0 && m[j] >= 40.0),
            "α {alpha}"
        );
        assert!(
            dh[j * 5 + 3] >= 10.0 * 0.02 * 0.98 * 0.999,
            "σ slope {} at row {j}",
            dh[j * 5 + 3]
        );
        assert!(dm[j] >= 0.0, "α slope {} at m = {}", dm[j], m[j]);
    }
    assert!(dm[0] > 0.0, "softplus keeps a gradient at m = −40");
    let relu = HeadConfig {
        softplus: false,
        leak: None,
        ..cfg
    };
    let [_, _, dm] = run(&relu, true, &(vec![0.0; 20], m, g));
    assert_eq!(dm[0], 0.0);
    assert_eq!(dm[1], 0.0);
}
