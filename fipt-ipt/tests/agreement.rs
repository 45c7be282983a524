//! The differentiable tracer, given the true materials and lights, renders what the forward
//! tracer renders (the images the fit is compared with): the same light transport, so a
//! fit can reach the truth.
mod common;
use fipt_core::color::luminance;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_ipt::lights::LightSampler;
use fipt_ipt::params::Params;
use fipt_ipt::tracer::{trace, TraceScene};
use fipt_shading::scene::SurfaceModel;
use glam::Vec3;

fn check(model: ReflectanceModel) {
    let fx = common::cornell(2, 32, 24, 256, model);
    let mesh = &fx.synth.mesh;
    let nt = mesh.triangles.len();
    // One group per triangle, at the truth.
    let mut params = Params::new(nt, nt, 0.5, 0.5, 1.0, false);
    for t in 0..nt as u32 {
        let sp = fx.table.surface(t, Vec3::ZERO);
        let a = fipt_core::reflectance::base_color(sp.kd, sp.ks, sp.metallic);
        let i = Params::albedo_index(t);
        params.x[i..i + 3].copy_from_slice(&a.to_array());
        params.x[Params::roughness_index(t)] = sp.roughness;
        params.x[Params::metallic_index(t)] = sp.metallic;
        // Each side's slot: the truth's emission where that side emits (the panel's front).
        let side = fx.table.emit_side(t);
        let n = mesh.face_normal(t as usize);
        for (slot, towards) in [(2 * t, n), (2 * t + 1, -n)] {
            let le = if side.emits_towards(n, towards) {
                fx.emission(t)
            } else {
                Vec3::ZERO
            };
            let e = params.emission_index(slot);
            for c in 0..3 {
                params.x[e + c] = le[c].max(1e-30).ln();
            }
        }
    }
    params.project();
    let tri_group: Vec<u32> = (0..nt as u32).collect();
    let lights = LightSampler::new(mesh, &params);
    let scene = TraceScene {
        geometry: &fx.geometry,
        tri_group: &tri_group,
        model,
        lights: &lights,
        max_bounces: 7,
        rr_start: 3,
    };
    let mut path = vec![];
    for (k, v) in fx.views.iter().enumerate() {
        let cam = &v.camera;
        let (mut ours, mut theirs) = (Vec3::ZERO, Vec3::ZERO);
        for i in 0..cam.width * cam.height {
            let mut rng = Pcg32::from_keys(&[k as u64, i as u64]);
            let mut l = Vec3::ZERO;
            let spp = 256;
            for _ in 0..spp {
                let j = rng.next_2d();
                let (o, d) = cam.ray((i % cam.width) as f32 + j.x, (i / cam.width) as f32 + j.y);
                l += trace(&scene, &params, o, d, &mut rng, &mut path);
            }
            ours += l / spp as f32;
            theirs += fx.images[k].data[i];
        }
        let ratio = luminance(ours) / luminance(theirs);
        eprintln!("{model:?} view {k}: ours {ours:.1} forward {theirs:.1} ratio {ratio:.4}");
        assert!(
            (ratio - 1.0).abs() < 0.02,
            "{model:?} view {k}: ratio {ratio}"
        );
    }
}

#[test]
fn agrees_with_the_forward_tracer_fipt_model() {
    check(ReflectanceModel::Fipt);
}

#[test]
fn agrees_with_the_forward_tracer_principled_model() {
    check(ReflectanceModel::Principled);
}
