//! The gradient of the path contribution against central finite differences of the same
//! paths (directions, pdfs and MIS weights held fixed), for base colour, roughness, metallic
//! and emission, under both reflectance models.
mod common;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_ipt::lights::LightSampler;
use fipt_ipt::params::Params;
use fipt_ipt::tracer::{accumulate_gradient, replay, trace, TraceScene, Vertex};
use glam::Vec3;

fn check(model: ReflectanceModel) {
    let fx = common::cornell(2, 16, 12, 1, model);
    let mesh = &fx.synth.mesh;
    let tri_group = fx.table.tri_material.clone();
    let groups = *tri_group.iter().max().unwrap() as usize + 1;
    let nt = mesh.triangles.len();
    let params = random_params(groups, nt, &|t| fx.emission(t) != Vec3::ZERO);
    let lights = LightSampler::new(mesh, &params);
    let scene = TraceScene {
        geometry: &fx.geometry,
        tri_group: &tri_group,
        model,
        lights: &lights,
        max_bounces: 4,
        rr_start: 1,
    };
    // Paths through the pixels of both views, their gradient for δ = (0.3, 1, 0.6).
    let delta = Vec3::new(0.3, 1.0, 0.6);
    let mut paths: Vec<Vec<Vertex>> = vec![];
    let mut pairs = vec![];
    for (k, v) in fx.views.iter().enumerate() {
        let cam = &v.camera;
        for i in (0..cam.width * cam.height).step_by(3) {
            let (o, d) = cam.pixel_center_ray(i % cam.width, i / cam.width);
            let mut r = Pcg32::from_keys(&[k as u64, i as u64]);
            let mut path = vec![];
            let l = trace(&scene, &params, o, d, &mut r, &mut path);
            let again = replay(&scene, &params, &path);
            assert!(
                (l - again).abs().max_element() <= 1e-4 * l.max_element().max(1e-3),
                "{l} {again}"
            );
            accumulate_gradient(&scene, &params, &path, delta, &mut pairs);
            paths.push(path);
        }
    }
    let mut grad = vec![0f64; params.len()];
    for (i, v) in pairs {
        grad[i as usize] += v as f64;
    }
    let loss = |p: &Params| -> f64 {
        paths
            .iter()
            .map(|path| replay(&scene, p, path).dot(delta) as f64)
            .sum()
    };
    // Every group's five parameters and the emission of a few triangles (the light's and
    // others'), each against a central difference.
    let mut idx: Vec<(usize, &str)> = vec![];
    for g in 0..groups as u32 {
        let a = Params::albedo_index(g);
        idx.extend([(a, "albedo r"), (a + 1, "albedo g"), (a + 2, "albedo b")]);
        idx.push((Params::roughness_index(g), "roughness"));
        idx.push((Params::metallic_index(g), "metallic"));
    }
    for slot in (0..2 * nt as u32).step_by(5).chain(
        fx.synth_lights()
            .into_iter()
            .flat_map(|t| [2 * t, 2 * t + 1]),
    ) {
        idx.push((params.emission_index(slot) + 1, "emission g"));
    }
    let (mut checked, mut worst) = (std::collections::BTreeMap::new(), 0f64);
    for (i, what) in idx {
        let h = 1e-3f32 * params.x[i].abs().max(0.1);
        let (mut p, mut q) = (params.clone(), params.clone());
        p.x[i] += h;
        q.x[i] -= h;
        let fd = (loss(&p) - loss(&q)) / (2.0 * h as f64);
        let g = grad[i];
        if fd.abs() < 1e-3 && g.abs() < 1e-3 {
            continue;
        }
        let err = (g - fd).abs() / fd.abs().max(g.abs());
        worst = f64::max(worst, err);
        assert!(
            err < 0.03,
            "{model:?} {what} (param {i}): analytic {g} vs finite difference {fd}"
        );
        *checked.entry(what).or_insert(0) += 1;
    }
    for what in ["albedo g", "roughness", "metallic", "emission g"] {
        assert!(
            checked.get(what).copied().unwrap_or(0) >= 2,
            "{model:?}: too few {what} checked: {checked:?}"
        );
    }
    eprintln!("{model:?}: worst relative error {worst:.2e} over {checked:?}");
}

/// Random parameters: albedo, roughness and metallic per group, and per triangle side an
/// emission (bright on triangles `emits` accepts, faint elsewhere).
fn random_params(groups: usize, nt: usize, emits: &dyn Fn(u32) -> bool) -> Params {
    let mut params = Params::new(groups, nt, 0.5, 0.5, 0.05, false);
    let mut rng = Pcg32::new(11, 0);
    for g in 0..groups as u32 {
        let i = Params::albedo_index(g);
        for c in 0..3 {
            params.x[i + c] = 0.2 + 0.6 * rng.next_f32();
        }
        params.x[Params::roughness_index(g)] = 0.15 + 0.7 * rng.next_f32();
        params.x[Params::metallic_index(g)] = 0.2 + 0.5 * rng.next_f32();
    }
    for slot in 0..2 * nt as u32 {
        let i = params.emission_index(slot);
        let bright = emits(slot / 2);
        for c in 0..3 {
            let le = if bright {
                5.0 + 5.0 * rng.next_f32()
            } else {
                0.01 + 0.1 * rng.next_f32()
            };
            params.x[i + c] = le.ln();
        }
    }
    params
}

trait Lights {
    fn synth_lights(&self) -> Vec<u32>;
}

impl Lights for common::Fixture {
    fn synth_lights(&self) -> Vec<u32> {
        (0..self.synth.mesh.triangles.len() as u32)
            .filter(|&t| self.emission(t) != Vec3::ZERO)
            .collect()
    }
}

#[test]
fn gradient_matches_finite_differences_fipt_model() {
    check(ReflectanceModel::Fipt);
}

#[test]
fn gradient_matches_finite_differences_principled_model() {
    check(ReflectanceModel::Principled);
}
