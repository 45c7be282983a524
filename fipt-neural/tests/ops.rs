//! The element-wise ops: values against fipt-core, gradients against finite differences.
use candle_core::{Device, Tensor, Var};
use fipt_core::color::srgb_oetf as core_oetf;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{lerp_levels, DEFAULT_LEVELS, NUM_LEVELS};
use fipt_neural::ops::{positional_encoding, srgb_oetf, LevelWeights, SrgbOetf};
use glam::Vec3;

/// d/dx Σ w·op(x) by candle's autograd.
fn autograd(
    op: impl Fn(&Tensor) -> Tensor,
    x: &[f32],
    w: &[f32],
    shape: (usize, usize),
) -> Vec<f32> {
    let dev = Device::Cpu;
    let v = Var::from_tensor(&Tensor::from_vec(x.to_vec(), shape, &dev).unwrap()).unwrap();
    let y = op(v.as_tensor());
    let wt = Tensor::from_vec(w.to_vec(), y.shape(), &dev).unwrap();
    let l = (y * wt).unwrap().sum_all().unwrap();
    let g = l.backward().unwrap();
    g.get(v.as_tensor())
        .unwrap()
        .flatten_all()
        .unwrap()
        .to_vec1::<f32>()
        .unwrap()
}

#[test]
fn oetf_matches_core_in_range_and_its_gradient_finite_differences() {
    for x in [0.0f32, 1e-6, 0.003, 0.0031308, 0.01, 0.18, 0.5, 1.0] {
        assert!((srgb_oetf(x) - core_oetf(x)).abs() < 1e-6, "x={x}");
    }
    // HDR values above 1 are not clamped; values span 1e-6 .. 1e5.
    assert!(srgb_oetf(4.0) > 1.5 && srgb_oetf(1e5).is_finite());
    let xs: Vec<f32> = vec![-0.1, 1e-6, 0.002, 0.004, 0.05, 0.5, 1.0, 3.0, 100.0, 1e5];
    let w = vec![1.0; xs.len()];
    let g = autograd(|t| t.apply_op1(SrgbOetf).unwrap(), &xs, &w, (xs.len(), 1));
    for (i, &x) in xs.iter().enumerate() {
        let h = (x.abs() * 1e-3).max(1e-7) as f64;
        let f = |x: f64| srgb_oetf(x as f32) as f64;
        let fd = (f(x as f64 + h) - f(x as f64 - h)) / (2.0 * h);
        assert!(
            (fd - g[i] as f64).abs() < 1e-2 * fd.abs().max(1e-3),
            "x={x}: fd {fd} vs {}",
            g[i]
        );
    }
}

#[test]
fn level_weights_reproduce_lerp_levels_and_differentiate() {
    let mut r = Pcg32::new(1, 2);
    let values: [Vec3; NUM_LEVELS] =
        std::array::from_fn(|_| Vec3::new(r.next_f32(), r.next_f32(), r.next_f32()));
    let op = LevelWeights(DEFAULT_LEVELS);
    let sig: Vec<f32> = (0..=200)
        .map(|i| i as f32 / 200.0)
        .chain([-1.0, 2.0, f32::NAN])
        .collect();
    let dev = Device::Cpu;
    let w = Tensor::from_vec(sig.clone(), (sig.len(), 1), &dev)
        .unwrap()
        .apply_op1(op)
        .unwrap()
        .to_vec2::<f32>()
        .unwrap();
    for (s, w) in sig.iter().zip(&w) {
        let sum: Vec3 = w.iter().zip(&values).map(|(a, v)| *v * *a).sum();
        let want = lerp_levels(&DEFAULT_LEVELS, &values, *s);
        assert!(
            (sum - want).abs().max_element() < 1e-5,
            "σ={s}: {sum} vs {want}"
        );
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
    // Gradient of Σ_l c_l·w_l(σ) against finite differences, away from the kinks.
    let c: Vec<f32> = (0..NUM_LEVELS).map(|_| r.next_f32() * 4.0 - 2.0).collect();
    let xs: Vec<f32> = vec![0.05, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99];
    let wt: Vec<f32> = xs.iter().flat_map(|_| c.clone()).collect();
    let g = autograd(|t| t.apply_op1(op).unwrap(), &xs, &wt, (xs.len(), 1));
    for (i, &x) in xs.iter().enumerate() {
        let f = |s: f32| {
            let v: [Vec3; NUM_LEVELS] = std::array::from_fn(|l| Vec3::splat(c[l]));
            lerp_levels(&DEFAULT_LEVELS, &v, s).x as f64
        };
        let h = 1e-3;
        let fd = (f(x + h) - f(x - h)) / (2.0 * h as f64);
        assert!(
            (fd - g[i] as f64).abs() < 1e-2 * (1.0 + fd.abs()),
            "σ={x}: fd {fd} vs {}",
            g[i]
        );
    }
}

#[test]
fn positional_encoding_layout() {
    let pe = positional_encoding(&[[0.25, -0.5, 1.0]], 10);
    assert_eq!(pe.len(), 63);
    assert_eq!(&pe[..3], &[0.25, -0.5, 1.0]);
    // k = 1 block: [sin x, sin y, sin z, cos x, cos y, cos z] of 2π·p.
    assert!((pe[3 + 6] - 1.0).abs() < 1e-6); // sin(π/2)
    assert!((pe[3 + 6 + 4] + 1.0).abs() < 1e-6); // cos(−π)
    assert!((pe[3 + 6 + 5] - 1.0).abs() < 1e-6); // cos(2π)
    assert!(pe.iter().all(|v| v.is_finite()));
}

#[test]
fn fused_loss_matches_candle_ops_in_value_and_gradient() {
    use fipt_neural::train::{ImageLoss, PriorNorm};
    let n = 300;
    let (batch, x) = random_loss_batch(n);
    let [unsegmented, segmented, semantic, targeted, poly] = loss_batch_variants(batch);
    let (srgb, slope) = (ImageLoss::Srgb, ImageLoss::SrgbSlope);
    // Last: whether a light's pixels ([`fipt_neural::ops::unreflectable`]) train the material.
    let lights = (0..n)
        .filter(|&j| {
            let b = &unsegmented;
            fipt_neural::ops::unreflectable(b.ld[j], &b.ls0[j], &b.ls1[j], b.gt[j])
        })
        .count();
    assert!(
        lights > 10 && lights < n - 10,
        "{lights} of {n} pixels are a light's: both kinds must be tested"
    );
    for (norm, l1, ml1, batch, rp, image_loss, em) in [
        (PriorNorm::L2Roughness, false, true, &poly, 0.0, srgb, false),
        (PriorNorm::L2Roughness, false, true, &poly, 0.0, slope, true),
        (PriorNorm::L2, false, false, &unsegmented, 1.0, srgb, true),
        (PriorNorm::L2, false, false, &unsegmented, 1.0, srgb, false),
        (PriorNorm::L1, true, true, &unsegmented, 1.0, slope, false),
        (PriorNorm::L1, true, true, &segmented, 0.35, srgb, true),
        (PriorNorm::L2, false, false, &segmented, 0.0, srgb, false),
        (
            PriorNorm::L2Roughness,
            false,
            true,
            &segmented,
            0.7,
            slope,
            true,
        ),
        (
            PriorNorm::L2Roughness,
            false,
            true,
            &semantic,
            0.7,
            srgb,
            false,
        ),
        (
            PriorNorm::L2Roughness,
            false,
            true,
            &targeted,
            0.0,
            srgb,
            true,
        ),
        (PriorNorm::L1, true, true, &targeted, 1.0, slope, false),
    ] {
        fused_matches_candle(&x, batch, (norm, l1, ml1, rp, image_loss, em));
    }
}

/// `n` random pixels for the loss: HDR values from 1e-6 to 1e3, every seventh pixel a light's,
/// σ across all segments and both clamps, α in [0, 1); and the field's outputs, 6 per pixel.
fn random_loss_batch(n: usize) -> (fipt_neural::ops::LossBatch, Vec<f32>) {
    let mut r = Pcg32::new(8, 9);
    let mut u = |lo: f32, hi: f32| lo + (hi - lo) * r.next_f32();
    let mut batch = fipt_neural::ops::LossBatch::default();
    let mut x = vec![];
    for j in 0..n {
        // HDR values from 1e-6 to 1e3, σ across all segments and both clamps, α in [0, 1).
        let scale = 10f32.powf(u(-6.0, 3.0));
        batch.ld.push([
            u(0.0, 1.0) * scale,
            u(0.0, 1.0) * scale,
            u(0.0, 1.0) * scale,
        ]);
        batch.ls0.push(std::array::from_fn(|_| {
            [u(0.0, 1.0) * scale, u(0.0, 1.0), u(0.0, 2.0)]
        }));
        batch.ls1.push(std::array::from_fn(|_| {
            [u(0.0, 0.1), u(0.0, 0.1) * scale, u(0.0, 0.1)]
        }));
        // Every seventh pixel a light's: far brighter than its shadings could reflect.
        let light = if j % 7 == 3 {
            1e3 * scale.max(1.0)
        } else {
            1.0
        };
        batch.gt.push([
            u(0.0, 2.0) * scale * light,
            u(0.0, 1.0) * light,
            u(0.0, 5.0) * light,
        ]);
        let sigma = if j % 10 == 0 {
            0.02
        } else if j % 10 == 1 {
            1.0
        } else {
            u(0.03, 0.99)
        };
        x.extend([
            u(0.0, 1.0),
            u(0.0, 1.0),
            u(0.0, 1.0),
            sigma,
            u(0.0, 1.0),
            u(0.0, 0.99),
        ]);
    }
    (batch, x)
}

/// The batch without segments, with 7 segments, with semantic partners, with search targets,
/// and with the principled model's diffuse σ polynomial (and targets).
fn loss_batch_variants(
    mut batch: fipt_neural::ops::LossBatch,
) -> [std::sync::Arc<fipt_neural::ops::LossBatch>; 5] {
    use fipt_neural::ops::NO_SEGMENT;
    let n = batch.gt.len();
    let unsegmented = std::sync::Arc::new(batch.clone());
    // 7 segments of uneven sizes, and pixels of none.
    batch.segment = (0..n)
        .map(|j| match j % 13 {
            0 => NO_SEGMENT,
            k => ((k * k + j / 50) % 7) as u32,
        })
        .collect();
    batch.segments = 7;
    let segmented = std::sync::Arc::new(batch.clone());
    // Semantic classes: 5 partners per pixel among its class (itself included at times),
    // position weights from 0.05 to 1.
    let mut partners = fipt_neural::ops::SemanticPartners {
        k: 5,
        sigma_albedo: 0.3,
        ..Default::default()
    };
    for (i, &s) in batch.segment.iter().enumerate() {
        let same: Vec<u32> = (0..n as u32)
            .filter(|&j| batch.segment[j as usize] == s)
            .collect();
        for q in 0..5 {
            let j = if s == NO_SEGMENT {
                i as u32
            } else {
                same[(i * 7 + q * 13) % same.len()]
            };
            partners.index.push(j);
            partners
                .pos_w
                .push(0.05 + 0.95 * ((i + 3 * q) % 10) as f32 / 9.0);
        }
    }
    batch.semantic = Some(partners);
    let semantic = std::sync::Arc::new(batch.clone());
    // Search targets on both parts, on one, or none (NaN: the default prior), with segments.
    let mut targeted = batch;
    targeted.semantic = None;
    targeted.target = (0..n)
        .map(|j| match j % 4 {
            0 => [f32::NAN; 2],
            1 => [0.02 + 0.98 * ((j * 7) % 11) as f32 / 10.0, 1.0],
            2 => [f32::NAN, 0.0],
            _ => [0.3, f32::NAN],
        })
        .collect();
    // The principled model's diffuse σ polynomial (Ld1 of either sign: retro-reflection
    // brightens, the grazing Fresnel darkens), with targets and segments.
    let mut poly = targeted.clone();
    poly.ld_poly = poly
        .ld
        .iter()
        .enumerate()
        .map(|(j, ld)| {
            let k = ((j * 5) % 7) as f32 / 6.0 - 0.4;
            [ld.map(|v| v * k), ld.map(|v| v * 0.3 * (1.0 - k))]
        })
        .collect();
    let poly = std::sync::Arc::new(poly);
    let targeted = std::sync::Arc::new(targeted);
    [unsegmented, segmented, semantic, targeted, poly]
}

/// The fused loss against the candle-ops reference on one batch and one set of switches: the
/// five terms and the total's gradient in every input agree to 1e-4.
fn fused_matches_candle(
    x: &[f32],
    batch: &std::sync::Arc<fipt_neural::ops::LossBatch>,
    case: (
        fipt_neural::train::PriorNorm,
        bool,
        bool,
        f32,
        fipt_neural::train::ImageLoss,
        bool,
    ),
) {
    use fipt_neural::field::FieldOutput;
    use fipt_neural::ops::FactorizedLoss;
    use fipt_neural::train::{candle_ops_loss, LossWeights};
    let (norm, l1, ml1, rp, image_loss, em) = case;
    let n = batch.gt.len();
    let dev = Device::Cpu;
    let var = |c: usize, w: usize| {
        let v: Vec<f32> = (0..n)
            .flat_map(|j| x[6 * j + c..6 * j + c + w].to_vec())
            .collect();
        Var::from_tensor(&Tensor::from_vec(v, (n, w), &dev).unwrap()).unwrap()
    };
    let vars = [var(0, 3), var(3, 1), var(4, 1), var(5, 1)];
    let t = |i: usize| vars[i].as_tensor();
    let out = FieldOutput::new(t(0), t(1), t(2), t(3)).unwrap();
    let fused = out
        .packed()
        .unwrap()
        .apply_op1(FactorizedLoss {
            batch: batch.clone(),
            levels: DEFAULT_LEVELS,
            mask_weight: 0.7,
            prior_weight: 0.3,
            prior_l1: l1,
            metallic_l1: ml1,
            segment_weight: 0.4,
            roughness_prior_scale: rp,
            target_weight: 0.25,
            image_loss,
            emitter_material: em,
            cache: Default::default(),
        })
        .unwrap();
    let weights = LossWeights {
        mask: 0.7,
        prior: 0.3,
        prior_norm: norm,
        roughness_prior: rp,
        segment: 0.4,
        target: 0.25,
        image_loss,
        emitter_material: em,
    };
    let plain = candle_ops_loss(&out, batch, DEFAULT_LEVELS, weights).unwrap();
    let (fv, pv) = (
        fused.to_vec1::<f32>().unwrap(),
        plain.to_vec1::<f32>().unwrap(),
    );
    // The segment term is 0 exactly without segments, and counts with them.
    assert_eq!(
        batch.segment.is_empty(),
        fv[4] == 0.0,
        "segment term {}",
        fv[4]
    );
    for k in 0..5 {
        assert!(
            (fv[k] - pv[k]).abs() <= 1e-4 * pv[k].abs().max(1e-3),
            "{norm:?} term {k}: {} vs {}",
            fv[k],
            pv[k]
        );
    }
    assert_same_gradients(&fused, &plain, &vars, &format!("{norm:?}"));
}

/// The total's (term 0's) gradient in every input agrees between the two losses to 1e-4 of
/// the largest.
fn assert_same_gradients(fused: &Tensor, plain: &Tensor, vars: &[Var], what: &str) {
    // Gradients of the total (term 0).
    let grads = |t: &Tensor| {
        t.narrow(0, 0, 1)
            .unwrap()
            .sum_all()
            .unwrap()
            .backward()
            .unwrap()
    };
    let (gf, gp) = (grads(fused), grads(plain));
    let values = |g: &candle_core::backprop::GradStore, v: &Var| {
        let t = g.get(v.as_tensor()).unwrap();
        t.flatten_all().unwrap().to_vec1::<f32>().unwrap()
    };
    for (vi, v) in vars.iter().enumerate() {
        let (a, b) = (values(&gf, v), values(&gp, v));
        let scale = b.iter().fold(0f32, |m, x| m.max(x.abs()));
        for (k, (p, q)) in a.iter().zip(&b).enumerate() {
            assert!(
                (p - q).abs() <= 1e-4 * scale + 1e-9,
                "{what} input {vi} element {k}: fused {p} vs candle {q}"
            );
        }
    }
}

/// The fused loss with its image term alone (no mask, prior, segment or target weight).
fn image_term_only(
    batch: std::sync::Arc<fipt_neural::ops::LossBatch>,
    image_loss: fipt_neural::train::ImageLoss,
    emitter_material: bool,
) -> fipt_neural::ops::FactorizedLoss {
    fipt_neural::ops::FactorizedLoss {
        batch,
        levels: DEFAULT_LEVELS,
        mask_weight: 0.0,
        prior_weight: 0.0,
        prior_l1: false,
        metallic_l1: false,
        segment_weight: 0.0,
        roughness_prior_scale: 0.0,
        target_weight: 0.0,
        image_loss,
        emitter_material,
        cache: Default::default(),
    }
}

/// Pixels of one surface whose views carry zero-mean noise (±25 %, a few-sample render's):
/// at the noise-free albedo the sRGB loss's gradient pushes kd down (the encoded mean of a
/// noisy pixel lies below the encoded noise-free value), while the slope-weighted error's
/// gradient vanishes, and its minimum over kd is the true one. Far from the prediction (beyond
/// the clip) both are the sRGB difference.
#[test]
fn slope_weighted_loss_is_unbiased_under_zero_mean_noise() {
    use fipt_neural::train::ImageLoss;
    let n = 2000;
    let (kd, ld) = (0.5f32, 0.8f32);
    let mut batch = fipt_neural::ops::LossBatch::default();
    for j in 0..n {
        // Symmetric noise: each pair of pixels averages to the noise-free value exactly.
        let k = (j / 2) as f32 / (n / 2) as f32;
        let e = if j % 2 == 0 { 0.25 * k } else { -0.25 * k };
        batch.ld.push([ld; 3]);
        batch.ls0.push([[0.0; 3]; NUM_LEVELS]);
        batch.ls1.push([[0.0; 3]; NUM_LEVELS]);
        batch.gt.push([kd * ld * (1.0 + e); 3]);
    }
    let batch = std::sync::Arc::new(batch);
    // The image term's derivative in kd, at albedo `a` (σ 1, m 0, α 0).
    let slope_at = |loss: ImageLoss, a: f32| -> (f32, f32) {
        let x: Vec<f32> = (0..n).flat_map(|_| [a, a, a, 1.0, 0.0, 0.0]).collect();
        let v = Var::from_tensor(&Tensor::from_vec(x, (n, 6), &Device::Cpu).unwrap()).unwrap();
        let op = image_term_only(batch.clone(), loss, true);
        let out = v.as_tensor().apply_op1(op).unwrap();
        let image = out.narrow(0, 1, 1).unwrap();
        let value = image.to_vec1::<f32>().unwrap()[0];
        let g = image.sum_all().unwrap().backward().unwrap();
        let g = g.get(v.as_tensor()).unwrap().to_vec2::<f32>().unwrap();
        (g.iter().map(|r| r[0]).sum(), value)
    };
    let (srgb, slope) = (
        slope_at(ImageLoss::Srgb, kd).0,
        slope_at(ImageLoss::SrgbSlope, kd).0,
    );
    assert!(
        srgb > 1e-5,
        "sRGB loss at the true kd: gradient {srgb} (expected > 0)"
    );
    assert!(
        slope.abs() < 1e-3 * srgb,
        "slope-weighted loss at the true kd: gradient {slope} (sRGB {srgb})"
    );
    // The sRGB loss's minimum lies over 0.3 % below kd (0.6 % by a series expansion).
    let low = slope_at(ImageLoss::Srgb, kd * 0.997).0;
    assert!(
        low > 0.0,
        "the sRGB loss's minimum lies below kd·0.997 (gradient {low})"
    );
    let (below, above) = (
        slope_at(ImageLoss::SrgbSlope, kd * 0.999).0,
        slope_at(ImageLoss::SrgbSlope, kd * 1.001).0,
    );
    assert!(
        below < 0.0 && above > 0.0,
        "slope-weighted minimum at kd: {below}, {above}"
    );
    // An albedo of 0.01: every pixel 50× brighter than predicted, beyond the clip.
    let (far_srgb, far_slope) = (
        slope_at(ImageLoss::Srgb, 0.01),
        slope_at(ImageLoss::SrgbSlope, 0.01),
    );
    assert_eq!(
        far_srgb, far_slope,
        "far from the prediction both are the sRGB difference"
    );
}

/// A wall pixel (α 0.1) and a light's pixel (α 0.7, 30× brighter): with `emitter_material`
/// off the light's pixel passes no gradient to its albedo, σ or metallic (there the reference's
/// term drives kd up, and the hash cells shared with the wall carry it over), while its mask
/// gradient and everything at the wall pixel are unchanged.
#[test]
fn emitter_pixels_train_the_mask_only_unless_asked() {
    use fipt_neural::train::ImageLoss;
    let mut batch = fipt_neural::ops::LossBatch::default();
    for gt in [0.3f32, 9.0] {
        batch.ld.push([0.6; 3]);
        batch
            .ls0
            .push(std::array::from_fn(|l| [0.1 * (l + 1) as f32; 3]));
        batch
            .ls1
            .push(std::array::from_fn(|l| [0.01 * (l + 1) as f32; 3]));
        batch.gt.push([gt; 3]);
    }
    let batch = std::sync::Arc::new(batch);
    let grads = |emitter_material: bool| -> Vec<Vec<f32>> {
        let x: Vec<f32> = vec![0.4, 0.4, 0.4, 0.8, 0.1, 0.1, 0.4, 0.4, 0.4, 0.8, 0.1, 0.7];
        let v = Var::from_tensor(&Tensor::from_vec(x, (2, 6), &Device::Cpu).unwrap()).unwrap();
        let op = image_term_only(batch.clone(), ImageLoss::Srgb, emitter_material);
        let out = v.as_tensor().apply_op1(op).unwrap();
        let g = out
            .narrow(0, 0, 1)
            .unwrap()
            .sum_all()
            .unwrap()
            .backward()
            .unwrap();
        g.get(v.as_tensor()).unwrap().to_vec2::<f32>().unwrap()
    };
    let (on, off) = (grads(true), grads(false));
    assert_eq!(on[0], off[0], "the wall pixel's gradient must not change");
    assert_eq!(
        on[1][5], off[1][5],
        "the light's mask gradient must not change"
    );
    assert!(
        on[1][..5].iter().all(|g| g.abs() > 1e-6) && on[1][0] < 0.0,
        "the reference's term pushes the light's albedo up: {:?}",
        on[1]
    );
    assert_eq!(off[1][..5], [0.0; 5], "material gradient at the light");
}
