//! Recovery on a tiny generated scene of constant-material parts (`cornell`, rendered by the
//! forward tracer with FIPT's model): base colour per part and the light's radiance, with
//! the light not given, after a stated number of steps; and a killed fit resumes to the same
//! parameters bit for bit.
mod common;
use fipt_core::color::luminance;
use fipt_core::fit::FitInputs;
use fipt_core::reflectance::ReflectanceModel;
use fipt_ipt::{Ipt, IptConfig};
use glam::Vec3;

fn config() -> IptConfig {
    let over: serde_json::Value = std::env::var("IPT_TEST_CONFIG")
        .ok()
        .map(|s| serde_json::from_str(&s).unwrap())
        .unwrap_or(serde_json::json!({}));
    let mut base = serde_json::to_value(IptConfig {
        iterations: 800,
        batch: 4096,
        // cornell's light is one-sided (`fipt synth`'s panels are): one radiance per side.
        two_sided_emission: false,
        ..IptConfig::balanced()
    })
    .unwrap();
    for (k, v) in over.as_object().unwrap() {
        base[k] = v.clone();
    }
    serde_json::from_value(base).unwrap()
}

fn inputs<'a>(fx: &'a common::Fixture, dir: &'a std::path::Path) -> FitInputs<'a> {
    FitInputs {
        geometry: &fx.geometry,
        positions: &fx.synth.mesh.positions,
        triangles: &fx.synth.mesh.triangles,
        views: &fx.views,
        images: &fx.images,
        shadings: None,
        segments: Some(&fx.parts),
        model: ReflectanceModel::Fipt,
        scene: None,
        dir,
        parts: None,
        run: fipt_core::fit::FitRun::new(dir),
    }
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("fipt-ipt-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn recovers_albedo_and_emission_of_a_tiny_scene() {
    let fx = common::cornell(8, 48, 36, 64, ReflectanceModel::Fipt);
    let dir = tmp("recovery");
    let ipt = Ipt { config: config() };
    let inp = inputs(&fx, &dir);
    let prep = ipt.prepare(&inp).unwrap();
    let (state, _) = ipt
        .optimise(&inp, &prep, ipt.config.iterations, &|_, _| {})
        .unwrap();
    // Base colour per part, weighted by the pixels that see it, against the truth.
    let (mut se, mut n) = (0f64, 0f64);
    let mut rows = vec![];
    for t in 0..prep.mesh.triangles.len() {
        let count = prep.seen[2 * t].0 + prep.seen[2 * t + 1].0;
        let truth = fx
            .table
            .materials
            .eval(fx.table.tri_material[t], Vec3::ZERO);
        if count == 0 || fx.emission(t as u32) != Vec3::ZERO {
            continue;
        }
        let g = prep.tri_group[t];
        let got = state.params.albedo(g);
        let want = fipt_core::reflectance::base_color(truth.kd, truth.ks, truth.metallic);
        se += (got - want).length_squared() as f64 / 3.0 * count as f64;
        n += count as f64;
        rows.push((
            g,
            got,
            want,
            state.params.metallic(g),
            state.params.roughness(g),
            truth.roughness,
        ));
    }
    let psnr = -10.0 * (se / n).log10();
    // The light: its triangles are found and their radiance is within 25 %.
    let (emitting, lights) = ipt.emitters(&prep, &state);
    let light_tris: Vec<usize> = (0..emitting.len())
        .filter(|&t| fx.emission(t as u32) != Vec3::ZERO)
        .collect();
    let found = light_tris.iter().filter(|&&t| emitting[t]).count();
    let false_pos = (0..emitting.len())
        .filter(|&t| emitting[t] && fx.emission(t as u32) == Vec3::ZERO)
        .count();
    let le_err: f32 = light_tris
        .iter()
        .map(|&t| {
            let (a, b) = (
                Ipt::triangle_emission(&state, t as u32),
                fx.emission(t as u32),
            );
            eprintln!("  light triangle {t}: {a:.2} vs {b:.2}");
            (luminance(a) / luminance(b) - 1.0).abs()
        })
        .fold(0.0, f32::max);
    eprintln!(
        "albedo PSNR {psnr:.2} dB; light triangles found {found}/{}, false {false_pos}, worst radiance error {le_err:.3}; {} lights",
        light_tris.len(),
        lights.len()
    );
    rows.sort_by_key(|r| r.0);
    rows.dedup_by_key(|r| r.0);
    for (g, got, want, m, r, tr) in rows {
        eprintln!("  group {g}: {got:.3} vs {want:.3}, metallic {m:.2}, σ {r:.2} vs {tr:.2}");
    }
    // Seeds 0–3 give 28.7, 25.7, 26.9 and 21.1 dB, the light 11–20 % dim (the prior on
    // emission pulls it down a little; docs/ipt.md): the bounds hold for all four.
    assert!(psnr > 20.0, "albedo PSNR {psnr:.2} dB");
    assert_eq!(found, light_tris.len(), "every light triangle found");
    assert_eq!(false_pos, 0, "no surface taken for a light");
    assert!(le_err < 0.25, "light radiance within 25 %: {le_err}");
    // A light must outshine the views: at 10× their median it passes (cornell's is ~100×);
    // asked for 1000×, no group of triangles is a light and none is marked emitting.
    let strict = Ipt {
        config: IptConfig {
            emitter_contrast: 1000.0,
            ..ipt.config.clone()
        },
    };
    let (emitting, lights) = strict.emitters(&prep, &state);
    assert!(lights.is_empty() && !emitting.contains(&true));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_killed_fit_resumes_to_the_same_parameters() {
    let fx = common::cornell(3, 24, 18, 16, ReflectanceModel::Fipt);
    let cfg = IptConfig {
        iterations: 40,
        batch: 512,
        checkpoint_every: 10,
        ..config()
    };
    let ipt = Ipt { config: cfg };
    let (a, b) = (tmp("resume-a"), tmp("resume-b"));
    let whole = {
        let inp = inputs(&fx, &a);
        let prep = ipt.prepare(&inp).unwrap();
        ipt.optimise(&inp, &prep, 40, &|_, _| {}).unwrap().0
    };
    let inp = inputs(&fx, &b);
    let prep = ipt.prepare(&inp).unwrap();
    // Killed after step 23: the checkpoint of step 20 is on disk.
    ipt.optimise(&inp, &prep, 23, &|_, _| {}).unwrap();
    let (resumed, start) = ipt.optimise(&inp, &prep, 40, &|_, _| {}).unwrap();
    assert_eq!(start, 20);
    assert_eq!(resumed.params, whole.params);
    assert_eq!(resumed.adam, whole.adam);
    // Other settings do not resume from it.
    let other = Ipt {
        config: IptConfig {
            seed: 1,
            ..ipt.config.clone()
        },
    };
    assert_eq!(other.optimise(&inp, &prep, 1, &|_, _| {}).unwrap().1, 0);
    for d in [a, b] {
        std::fs::remove_dir_all(&d).ok();
    }
}

/// Started at the truth (materials per part, the light's radiance), the optimisation stays
/// near it: the loss and its gradient estimate have no bias that pulls a fit away. (It
/// caught the residual and the gradient paths sharing their point in the pixel, which pulled
/// the light down 25 % in 200 steps, and a tight clamp of the residual, which pushed it up
/// 60 %.)
#[test]
fn the_truth_is_a_fixed_point() {
    use fipt_ipt::optimise::{run, State};
    use fipt_ipt::params::Params;
    use fipt_shading::scene::SurfaceModel;
    let fx = common::cornell(8, 48, 36, 64, ReflectanceModel::Fipt);
    let dir = tmp("fixed");
    let ipt = Ipt {
        config: IptConfig {
            iterations: 200,
            ..config()
        },
    };
    let inp = inputs(&fx, &dir);
    let prep = ipt.prepare(&inp).unwrap();
    let nt = prep.mesh.triangles.len();
    let problem = prep.problem(&inp);
    let mut state = State::initial(&problem, &ipt.config);
    let p = &mut state.params;
    for t in 0..nt as u32 {
        let sp = fx.table.surface(t, Vec3::ZERO);
        let g = prep.tri_group[t as usize];
        let a = fipt_core::reflectance::base_color(sp.kd, sp.ks, sp.metallic);
        let i = Params::albedo_index(g);
        p.x[i..i + 3].copy_from_slice(&a.to_array());
        p.x[Params::roughness_index(g)] = sp.roughness;
        p.x[Params::metallic_index(g)] = sp.metallic;
        // The front's slot holds the truth, the back's (a one-sided panel's) nothing.
        let (front, back) = (p.emission_index(2 * t), p.emission_index(2 * t + 1));
        for c in 0..3 {
            p.x[front + c] = fx.emission(t)[c].max(1e-30).ln();
            p.x[back + c] = 1e-30f32.ln();
        }
    }
    p.project();
    let start = state.params.clone();
    run(
        &problem,
        &ipt.config,
        &mut state,
        200,
        &dir,
        "k",
        &|_, _| {},
    )
    .unwrap();
    let mut worst_albedo = 0f32;
    for g in 0..prep.groups as u32 {
        let d = (state.params.albedo(g) - start.albedo(g))
            .abs()
            .max_element();
        eprintln!(
            "group {g}: albedo {:.3} (from {:.3})",
            state.params.albedo(g),
            start.albedo(g)
        );
        // The light's own group reflects nothing in truth and barely matters; skip it.
        let is_light =
            (0..nt).any(|t| prep.tri_group[t] == g && fx.emission(t as u32) != Vec3::ZERO);
        if !is_light
            && prep
                .seen
                .iter()
                .enumerate()
                .any(|(s, n)| n.0 > 200 && prep.tri_group[s / 2] == g)
        {
            worst_albedo = worst_albedo.max(d);
        }
    }
    let mut worst_light = 0f32;
    for t in (0..nt as u32).filter(|&t| fx.emission(t) != Vec3::ZERO) {
        let (a, b) = (state.params.emission(2 * t), start.emission(2 * t));
        eprintln!("light {t}: {a:.2} (from {b:.2})");
        worst_light = worst_light.max((luminance(a) / luminance(b) - 1.0).abs());
    }
    assert!(
        worst_albedo < 0.15,
        "albedo moved {worst_albedo} from the truth"
    );
    assert!(
        worst_light < 0.15,
        "light moved {worst_light} from the truth"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The metallic prior enters the gradient of metallic alone, with the sign that lowers it,
/// weighted by each group's share of the pixels: one step from m = 0.5 (same seed, same
/// paths) with a prior that outweighs the views lowers every seen group's metallic by Adam's
/// first step (the rate) and leaves every other unknown where the run without it puts it.
#[test]
fn the_metallic_prior_lowers_metallic_alone() {
    use fipt_ipt::optimise::{run, State};
    use fipt_ipt::params::Params;
    let fx = common::cornell(8, 48, 36, 16, ReflectanceModel::Fipt);
    let mut ends = vec![];
    let mut seen_groups = vec![];
    for prior in [1e4, 0.0] {
        let dir = tmp(&format!("metal-prior-{prior}"));
        let ipt = Ipt {
            config: IptConfig {
                iterations: 100,
                batch: 1024,
                metallic_prior: prior,
                ..config()
            },
        };
        let inp = inputs(&fx, &dir);
        let prep = ipt.prepare(&inp).unwrap();
        let problem = prep.problem(&inp);
        let mut state = State::initial(&problem, &ipt.config);
        for g in 0..prep.groups as u32 {
            state.params.x[Params::metallic_index(g)] = 0.5;
        }
        run(&problem, &ipt.config, &mut state, 1, &dir, "k", &|_, _| {}).unwrap();
        seen_groups = (0..prep.groups as u32)
            .filter(|&g| {
                (0..prep.mesh.triangles.len()).any(|t| {
                    prep.tri_group[t] == g && prep.seen[2 * t].0 + prep.seen[2 * t + 1].0 > 0
                })
            })
            .collect();
        ends.push(state.params);
        std::fs::remove_dir_all(&dir).ok();
    }
    let rate = config().learning_rate;
    for &g in &seen_groups {
        let m = ends[0].metallic(g);
        assert!((m - (0.5 - rate)).abs() < 1e-4, "group {g}: metallic {m}");
        assert_eq!(ends[0].albedo(g), ends[1].albedo(g));
        assert_eq!(ends[0].roughness(g), ends[1].roughness(g));
    }
    let emission = ends[0].groups * fipt_ipt::params::PER_GROUP;
    assert_eq!(ends[0].x[emission..], ends[1].x[emission..]);
}
