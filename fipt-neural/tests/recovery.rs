//! Recovery with exact shadings: on `cornell`, the views are re-synthesised from the baked
//! shadings and the ground-truth materials (kd·Ld + ks·Ls0(σ) + Ls1(σ), emission on emitter
//! pixels), so the factorised model can explain them exactly. Training (the `fast` preset as
//! `fipt run` trains after a refinement, without the σ pull, at a constant learning rate;
//! 1500 steps of 4096 pixels, with
//! the part ids of `IndexMA/` for the segment prior) must
//! then recover kd, the roughness of the glossy block (σ = 0.25, a dielectric with 4 %
//! specular) and of the rough surfaces, and the emitter mask.
//!
//! The glossy block's σ is observable but weakly: putting σ = 1 in its place raises the
//! block's sRGB MSE by 2.8e-4 (742 of its 1322 pixels by more than 1e-4). Measured: 33.4 dB
//! with these settings (42.6 dB starting from σ = 0.51 instead of 0.98); 2.5 dB with any σ
//! pull in the prior (even the reference's 5e-4); starting from 0.51, 17 dB without the
//! segment prior and 14 dB with σ's logit gain at 4 instead of 10.
use fipt_bake::bake::{primary_records, BakeConfig, FactorizedBaker};
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::field::MaterialField;
use fipt_core::image::{BadPixelPolicy, Image};
use fipt_core::metrics::psnr;
use fipt_core::shading::{lerp_levels, ViewShadings};
use fipt_geom::{Geometry, Mesh};
use fipt_neural::{Bounds, LrDecay, TrainConfig, Trainer, TrainingSet};
use fipt_shading::render::RenderConfig;
use fipt_synth::{build, write_dataset, SynthOptions};
use glam::Vec3;

#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[test]
fn training_on_exact_shadings_recovers_materials_and_emitters() {
    recover(GtKind::IndexMA, 25.0);
}

/// The same with the semantic classes (`segmentation/`: the three blocks are one class,
/// "furniture") and the semantic prior instead of part ids, as a real scene would have them.
/// Measured (σ from 0.51, see `recover`): kd 41.6 dB, glossy block's σ 43.7 dB. Before
/// 2026-11-27 (from σ 0.98, the light's pixels training the material): 44.3 and 24.6 dB.
#[test]
fn training_with_semantic_classes_recovers_the_glossy_block() {
    recover(GtKind::Segmentation, 23.0);
}

/// Trains on exact shadings with part ids `ids`; the glossy block's σ must reach
/// `glossy_min` dB.
fn recover(ids: GtKind, glossy_min: f64) {
    let dir = std::env::temp_dir().join(format!(
        "fipt-neural-recovery-{}-{}",
        ids.folder(),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let opts = SynthOptions {
        train_views: 16,
        val_views: 1,
        width: 64,
        height: 48,
        render: RenderConfig::ground_truth(32),
        model: Default::default(),
        lens: Default::default(),
    };
    let scene = build("cornell").unwrap();
    write_dataset(scene, &dir, &opts, &|_, _| {}).unwrap();
    let ds = Dataset::open(&dir).unwrap();
    let geo = Geometry::new(Mesh::load(&ds.mesh).unwrap());
    let split = ds.train();
    let rendered: Vec<Image> = split
        .views
        .iter()
        .map(|v| ds.load_image(v, BadPixelPolicy::Reject).unwrap().0)
        .collect();
    let (shadings, _, _) = FactorizedBaker::new(BakeConfig::fast()).bake_detailed(
        &geo,
        &split.views,
        &rendered,
        &|_, _| {},
    );
    let ExactViews {
        images,
        points,
        truth,
        dbg_px,
    } = exact_views(&ds, &geo, &shadings);
    let bounds = Bounds::around(points.iter().flatten().flatten().copied(), 1.1).unwrap();
    let parts: Vec<Vec<i64>> = (0..split.views.len())
        .map(|k| ds.load_ids(split, ids, k).unwrap().unwrap())
        .collect();
    let data = TrainingSet::new(&points, &shadings, &images, &bounds).unwrap();
    let data = if ids == GtKind::Segmentation {
        data.with_classes(&parts)
    } else {
        data.with_segments(&parts)
    }
    .unwrap();
    let cfg = exact_shadings_config();
    let mut trainer = Trainer::new(cfg, bounds, data.levels).unwrap();
    let t0 = std::time::Instant::now();
    trainer.run(&data, None, &mut |_| {}).unwrap();
    let secs = t0.elapsed().as_secs_f64();

    let pts: Vec<Vec3> = truth.iter().map(|t| t.0).collect();
    let mats = trainer.field.materials(&pts).unwrap();
    let alpha = trainer.field.emission_mask(&pts).unwrap();
    let non_emit: Vec<bool> = truth.iter().map(|t| !t.3).collect();
    let kd_gt: Vec<Vec3> = truth.iter().map(|t| t.1).collect();
    let kd: Vec<Vec3> = mats.iter().map(|m| m.kd()).collect();
    let kd_psnr = psnr(&kd, &kd_gt, Some(&non_emit), 1.0).unwrap();
    let glossy: Vec<bool> = truth.iter().map(|t| t.4 && !t.3).collect();
    let r_gt: Vec<Vec3> = truth.iter().map(|t| Vec3::splat(t.2)).collect();
    let r: Vec<Vec3> = mats.iter().map(|m| Vec3::splat(m.roughness)).collect();
    let r_psnr = psnr(&r, &r_gt, Some(&glossy), 1.0).unwrap();
    let iou = mask_iou(&truth, &alpha);
    eprintln!(
        "recovery on cornell with {} ({} pixels, {} glossy, {} emitter; 1500 steps of 4096 in {secs:.1} s): kd {kd_psnr:.2} dB, glossy roughness {r_psnr:.2} dB, mask IoU {iou:.3}, final loss {:?}",
        ids.folder(),
        truth.len(),
        glossy.iter().filter(|&&g| g).count(),
        truth.iter().filter(|t| t.3).count(),
        trainer.last
    );
    report_closure_mse(&dbg_px, &shadings, &mats);
    // Roughness of the rough surfaces, clamped to [0.2, 1] as in the evaluation protocol.
    let rough: Vec<bool> = truth.iter().map(|t| !t.3 && !t.4).collect();
    let clamp = |v: &Vec<Vec3>| {
        v.iter()
            .map(|x| x.clamp(Vec3::splat(0.2), Vec3::ONE))
            .collect::<Vec<_>>()
    };
    let rr_psnr = psnr(&clamp(&r), &clamp(&r_gt), Some(&rough), 1.0).unwrap();
    eprintln!("roughness of the rough surfaces {rr_psnr:.2} dB");
    assert!(
        glossy.iter().filter(|&&g| g).count() > 100,
        "test scene lacks glossy pixels"
    );
    assert!(kd_psnr >= 33.0, "kd PSNR {kd_psnr:.2} dB < 33");
    assert!(
        r_psnr >= glossy_min,
        "glossy-block roughness PSNR {r_psnr:.2} dB < {glossy_min}"
    );
    assert!(
        rr_psnr >= 17.0,
        "rough-surface roughness PSNR {rr_psnr:.2} dB < 17"
    );
    assert!(iou >= 0.95, "emission mask IoU {iou:.3} < 0.95");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Pixel (view, index, image, the model with the true materials, emitter?).
type DebugPixel = (usize, usize, Vec3, Vec3, bool);

/// The training views re-synthesised from the true materials under the bake's shadings (the
/// lights as seen), their hit points, and per valid pixel the truth: (point, kd, σ, emitter,
/// glossy).
struct ExactViews {
    images: Vec<Image>,
    points: Vec<Vec<Option<Vec3>>>,
    truth: Vec<(Vec3, Vec3, f32, bool, bool)>,
    dbg_px: Vec<DebugPixel>,
}

fn exact_views(ds: &Dataset, geo: &Geometry, shadings: &[ViewShadings]) -> ExactViews {
    let split = ds.train();
    let gt = |kind: GtKind, k: usize| ds.load_gt(split, kind, k).unwrap().unwrap();
    let mut images = Vec::new();
    let mut points = Vec::new();
    let mut truth = Vec::new(); // (point, kd, σ, emitter, glossy)
    let mut dbg_px = Vec::new();
    for (k, (view, sh)) in split.views.iter().zip(shadings).enumerate() {
        let (kd, ks, rough, emit) = (
            gt(GtKind::DiffCol, k),
            gt(GtKind::Specular, k),
            gt(GtKind::Roughness, k),
            gt(GtKind::Emit, k),
        );
        let recs = primary_records(geo, view);
        let mut img = Image::new(sh.width, sh.height);
        for i in 0..sh.width * sh.height {
            let e = emit.data[i];
            img.data[i] = if e.max_element() > 0.0 {
                e
            } else {
                kd.data[i] * sh.ld[i]
                    + ks.data[i] * lerp_levels(&sh.levels, &sh.ls0[i], rough.data[i].x)
                    + lerp_levels(&sh.levels, &sh.ls1[i], rough.data[i].x)
            };
            if let (Some(r), true) = (recs[i], sh.valid[i]) {
                dbg_px.push((
                    k,
                    i,
                    img.data[i],
                    kd.data[i] * sh.ld[i]
                        + ks.data[i] * lerp_levels(&sh.levels, &sh.ls0[i], rough.data[i].x)
                        + lerp_levels(&sh.levels, &sh.ls1[i], rough.data[i].x),
                    e.max_element() > 0.0,
                ));
                truth.push((
                    r.hit.p,
                    kd.data[i],
                    rough.data[i].x,
                    e.max_element() > 0.0,
                    rough.data[i].x < 0.5,
                ));
            }
        }
        points.push(recs.iter().map(|r| r.map(|r| r.hit.p)).collect::<Vec<_>>());
        images.push(img);
    }
    ExactViews {
        images,
        points,
        truth,
        dbg_px,
    }
}

/// Prints the sRGB MSE of the non-emitter pixels under the true and the trained materials.
fn report_closure_mse(
    dbg_px: &[DebugPixel],
    shadings: &[ViewShadings],
    mats: &[fipt_core::field::Material],
) {
    // With the input views themselves instead of the re-synthesised ones, GT materials fit
    // at 0.013 and trained ones at 0.0037 with kd at 10 dB: the one-bounce bake, not the
    // optimiser, limits cornell at 64×48.
    use fipt_core::color::srgb_oetf as o;
    let (mut eg, mut ep, mut n) = (0f64, 0f64, 0usize);
    for (j, &(k, i, im, model_gt, em)) in dbg_px.iter().enumerate() {
        if em {
            continue;
        }
        let sh = &shadings[k];
        let m = &mats[j];
        let pr = m.kd() * sh.ld[i]
            + m.ks() * lerp_levels(&sh.levels, &sh.ls0[i], m.roughness)
            + lerp_levels(&sh.levels, &sh.ls1[i], m.roughness);
        for c in 0..3 {
            eg += ((o(model_gt[c]) - o(im[c])) as f64).powi(2);
            ep += ((o(pr[c]) - o(im[c])) as f64).powi(2);
        }
        n += 3;
    }
    eprintln!(
        "non-emitter sRGB MSE: GT materials {:.5}, trained {:.5}",
        eg / n as f64,
        ep / n as f64
    );
}

/// `TrainConfig::fast` as a round after a refinement trains on exact shadings.
fn exact_shadings_config() -> TrainConfig {
    let mut cfg = TrainConfig::fast();
    // Exact shadings: as in a round after a refinement, no σ pull (`rounds.roughness_prior`).
    cfg.roughness_prior = 0.0;
    cfg.steps = 1500;
    cfg.batch = 4096;
    // σ starts mid-range (the reference's 0.51), not at the presets' 0.98. From 0.98 the
    // glossy block stays at σ = 1.0 (2.5 dB): the gradient of its highlights alone does not
    // bring σ off 1, which is why `fipt run` searches σ first and pulls towards the search's
    // choice. It passed from 0.98 until 2026-11-27 only because the light's pixels trained the
    // material: their pull towards a brighter Ls0 dragged σ down across the shared network in
    // the first 100 steps (`train.emitter_material`, `docs/gallery-mitsuba.md`). From 0.51:
    // kd 42.1 dB, glossy σ 46.0 dB, rough surfaces 18.8 dB; from 0.7 the block's σ reaches
    // 15.2 dB only.
    cfg.field.roughness_init = 0.51;
    // A constant rate: on exact shadings 1500 steps are limited by convergence, not noise, and
    // the presets' decay (for noisy shadings) slows it. Measured with classes only: kd 41.3 /
    // 35.7 / 38.4 dB and glossy σ 27.2 / 20.1 / 24.6 dB with none / (0.5, 0.1) / (0.7, 0.3).
    cfg.lr_decay = LrDecay::default();
    cfg
}

/// IoU of the emission mask (α > 0.5) with the true emitters.
fn mask_iou(truth: &[(Vec3, Vec3, f32, bool, bool)], alpha: &[f32]) -> f64 {
    let (mut inter, mut uni) = (0usize, 0usize);
    for (t, a) in truth.iter().zip(alpha) {
        let pred = *a > 0.5;
        inter += (pred && t.3) as usize;
        uni += (pred || t.3) as usize;
    }
    let iou = inter as f64 / uni.max(1) as f64;
    iou
}
