//! The differentiable path tracer: a path is traced once with the current parameters
//! (next-event estimation to the current emitters, BRDF sampling, MIS with the power
//! heuristic), its vertices are recorded, and the gradient of its contribution is taken with
//! the sampled directions, pdfs and MIS weights held fixed (path replay): E[f(θ)/p] = ∫f(θ),
//! so d/dθ of the estimate with p fixed is an unbiased estimate of the derivative of the image.
//!
//! At vertex k, with throughput T_k (product of the earlier BRDF weights), the radiance it
//! sends back is R_k = E_k + w_k ⊙ R_{k+1}, where E_k is the emission it shows (Le of its
//! triangle, MIS-weighted) plus its next-event term g_k ⊙ Le_l · mis / p_light, and
//! w_k = g_k(ωo, ωi) / p its BRDF weight; g = f·cos θi = kd·d + ks·s0 + s1
//! ([`MicrofacetBrdf::lobes`]). Then, for a loss with ∂ℓ/∂L = δ at the pixel:
//! * ∂ℓ/∂(kd, ks, σ at k) = δ·T_k ⊙ [∂g_nee·Le_l·mis/p_light + ∂g_k/p ⊙ R_{k+1}];
//! * ∂ℓ/∂Le(triangle of k) = δ·T_k·mis_k, ∂ℓ/∂Le(light l) = δ·T_k ⊙ g_nee·mis/p_light.
//!
//! ∂g/∂σ is a central difference of the model's lobes (1 % of σ: the formulas stay in
//! fipt-core's reflectance module); everything else is exact.
use crate::lights::LightSampler;
use crate::params::Params;
use fipt_core::brdf::{Brdf, Frame};
use fipt_core::color::Rgb;
use fipt_core::reflectance::{
    clamp_roughness, metallic_workflow, metallic_workflow_derivatives, ReflectanceModel,
    MIN_ROUGHNESS,
};
use fipt_core::rng::Pcg32;
use fipt_core::shading::RayQuery;
use fipt_shading::brdf::MicrofacetBrdf;
use fipt_shading::incident::power_heuristic;
use glam::Vec3;

/// What the tracer traces.
pub struct TraceScene<'a> {
    pub geometry: &'a dyn RayQuery,
    /// Material group of each triangle.
    pub tri_group: &'a [u32],
    pub model: ReflectanceModel,
    pub lights: &'a LightSampler<'a>,
    /// Reflections along a path (1: direct light only).
    pub max_bounces: u32,
    /// Reflections before Russian roulette.
    pub rr_start: u32,
}

/// A BRDF factor g = kd·d + ks·s0 + s1 at one direction pair, with ∂/∂σ of its lobes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Lobes {
    pub l: [f32; 3],
    pub dl: [f32; 3],
}

/// The next-event term of a vertex: the light's emission slot, direction to it (local),
/// mis / p_light.
#[derive(Clone, Copy, Debug)]
pub struct Nee {
    pub light: u32,
    pub wi: Vec3,
    pub scale: f32,
}

/// One recorded path vertex.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub tri: u32,
    /// The emission slot of the side of `tri` the path sees.
    pub slot: u32,
    /// Weight of the triangle's own emission at this vertex (1 for the camera's hit, the MIS
    /// weight after a BRDF sample).
    pub emission_weight: f32,
    /// The direction to the previous vertex, in the local frame.
    pub wo: Vec3,
    pub nee: Option<Nee>,
    /// The sampled direction to the next vertex (local) and 1 / its pdf.
    pub next: Option<(Vec3, f32)>,
}

/// The material of group `g`: its BRDF (kd, ks of the metallic workflow).
#[inline]
fn brdf_of(model: ReflectanceModel, p: &Params, g: u32) -> MicrofacetBrdf {
    let (kd, ks) = metallic_workflow(p.albedo(g), p.metallic(g));
    MicrofacetBrdf::with_model(model, kd, ks, p.roughness(g))
}

/// The lobes at (ωo, ωi) and, when `derivative`, their central difference in σ.
#[inline]
fn lobes(b: &MicrofacetBrdf, wo: Vec3, wi: Vec3, derivative: bool) -> Lobes {
    let l = b.lobes(wo, wi);
    if !derivative {
        return Lobes { l, dl: [0.0; 3] };
    }
    let s = b.roughness;
    let h = 0.01 * s;
    let (lo, hi) = (clamp_roughness(s - h).max(MIN_ROUGHNESS), (s + h).min(1.0));
    let at = |sigma: f32| {
        MicrofacetBrdf {
            roughness: sigma,
            ..*b
        }
        .lobes(wo, wi)
    };
    let (a, c) = (at(lo), at(hi));
    let d = hi - lo;
    Lobes {
        l,
        dl: std::array::from_fn(|k| (c[k] - a[k]) / d),
    }
}

#[inline]
fn factor(b: &MicrofacetBrdf, l: &[f32; 3]) -> Rgb {
    b.kd * l[0] + b.ks * l[1] + Vec3::splat(l[2])
}

/// Traces one camera ray with the current parameters; returns the radiance estimate and
/// records the vertices into `path` (cleared first).
pub fn trace(
    scene: &TraceScene,
    params: &Params,
    mut origin: Vec3,
    mut dir: Vec3,
    rng: &mut Pcg32,
    path: &mut Vec<Vertex>,
) -> Rgb {
    path.clear();
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut prev_pdf = 0.0f32;
    for bounce in 0..=scene.max_bounces {
        let Some(hit) = scene.geometry.intersect(origin, dir) else {
            break;
        };
        let wo_w = -dir;
        let cos_ng = hit.ng.dot(wo_w);
        let slot = params.slot(hit.tri, cos_ng > 0.0);
        let emission_weight = if prev_pdf == 0.0 {
            1.0
        } else {
            let light_pdf = scene.lights.pdf_area(slot) * hit.t * hit.t / cos_ng.abs().max(1e-12);
            power_heuristic(prev_pdf, light_pdf)
        };
        l += beta * params.emission(slot) * emission_weight;
        let mut v = Vertex {
            tri: hit.tri,
            slot,
            emission_weight,
            wo: Vec3::Z,
            nee: None,
            next: None,
        };
        if bounce == scene.max_bounces {
            path.push(v);
            break;
        }
        let b = brdf_of(scene.model, params, scene.tri_group[hit.tri as usize]);
        let ng = if cos_ng < 0.0 { -hit.ng } else { hit.ng };
        let ns = if hit.ns.dot(ng) < 0.0 {
            -hit.ns
        } else {
            hit.ns
        };
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(wo_w);
        v.wo = wo;
        if wo.z <= 0.0 {
            path.push(v);
            break;
        }
        let p_out = scene.geometry.offset(hit.p, ng);
        // Next-event estimation.
        let at = Shading {
            brdf: &b,
            frame: &frame,
            tri: hit.tri,
            p_out,
            ng,
            wo,
        };
        v.nee = next_event(scene, params, &at, beta, rng, &mut l);
        // Continue by sampling the BRDF.
        let Some(s) = b.sample(wo, rng.next_f32(), rng.next_2d()) else {
            path.push(v);
            break;
        };
        let wi_w = frame.to_world(s.wi);
        if wi_w.dot(ng) <= 0.0 {
            path.push(v);
            break;
        }
        let mut inv_pdf = 1.0 / s.pdf;
        let w = factor(&b, &b.lobes(wo, s.wi)) * inv_pdf;
        // Russian roulette after `rr_start` reflections; the survival probability joins the
        // (fixed) pdf of the path.
        if bounce + 1 > scene.rr_start {
            let q = (beta * w).max_element().min(0.95);
            if !(rng.next_f32() < q) {
                path.push(v);
                break;
            }
            inv_pdf /= q;
        }
        v.next = Some((s.wi, inv_pdf));
        path.push(v);
        beta *= factor(&b, &b.lobes(wo, s.wi)) * inv_pdf;
        prev_pdf = s.pdf;
        origin = p_out;
        dir = wi_w;
    }
    l
}

/// A path vertex as next-event estimation sees it.
struct Shading<'a> {
    brdf: &'a MicrofacetBrdf,
    frame: &'a Frame,
    /// The triangle hit (a light sample on it is refused).
    tri: u32,
    /// The point, offset off the surface.
    p_out: Vec3,
    /// The geometric normal towards the viewer.
    ng: Vec3,
    /// The direction to the viewer, local frame.
    wo: Vec3,
}

/// Adds to `l` one emitter sample's light at `at`, times `beta`, weighted by the power
/// heuristic against the BRDF; returns what the gradient needs of it (None: nothing arrived).
#[inline]
fn next_event(
    scene: &TraceScene,
    params: &Params,
    at: &Shading,
    beta: Rgb,
    rng: &mut Pcg32,
    l: &mut Rgb,
) -> Option<Nee> {
    let Shading {
        brdf: b,
        frame,
        tri,
        p_out,
        ng,
        wo,
    } = *at;
    let ls = scene.lights.sample(rng.next_f32(), rng.next_2d())?;
    let d = ls.p - p_out;
    let dist2 = d.length_squared();
    let dist = dist2.sqrt();
    let wi_w = d / dist.max(1e-20);
    let cos_l = ls.n.dot(wi_w).abs();
    let wi = frame.to_local(wi_w);
    // The sampled side must face the point.
    let facing = params.slot(ls.tri, ls.n.dot(wi_w) < 0.0) == ls.slot;
    if !(dist > 0.0 && cos_l > 0.0 && facing && wi.z > 0.0 && wi_w.dot(ng) > 0.0 && ls.tri != tri) {
        return None;
    }
    let lb = b.lobes(wo, wi);
    if !(lb.iter().any(|&x| x != 0.0) && !scene.geometry.occluded(p_out, wi_w, dist * (1.0 - 1e-4)))
    {
        return None;
    }
    let light_pdf = ls.pdf_area * dist2 / cos_l;
    let scale = power_heuristic(light_pdf, b.pdf(wo, wi)) / light_pdf;
    *l += beta * factor(b, &lb) * params.emission(ls.slot) * scale;
    Some(Nee {
        light: ls.slot,
        wi,
        scale,
    })
}

/// What vertex `v` shows by itself (its emission and its next-event term) and its BRDF
/// weight towards the next vertex, with parameters `params`.
#[inline]
fn vertex_terms(params: &Params, b: &MicrofacetBrdf, v: &Vertex) -> (Rgb, Rgb) {
    let mut e = params.emission(v.slot) * v.emission_weight;
    if let Some(n) = v.nee {
        e += factor(b, &b.lobes(v.wo, n.wi)) * params.emission(n.light) * n.scale;
    }
    let w = v.next.map_or(Vec3::ZERO, |(wi, inv_pdf)| {
        factor(b, &b.lobes(v.wo, wi)) * inv_pdf
    });
    (e, w)
}

/// The radiance the recorded `path` carries with parameters `params` (its directions, pdfs
/// and MIS weights fixed): what [`accumulate_gradient`] differentiates.
pub fn replay(scene: &TraceScene, params: &Params, path: &[Vertex]) -> Rgb {
    let mut r = Vec3::ZERO;
    for v in path.iter().rev() {
        let b = brdf_of(scene.model, params, scene.tri_group[v.tri as usize]);
        let (e, w) = vertex_terms(params, &b, v);
        r = e + w * r;
    }
    r
}

/// Adds ∂ℓ/∂θ of the recorded `path` for ∂ℓ/∂L = `delta` to `grad` as (parameter index,
/// value) pairs; emission gradients are taken in the log parameters u = ln Le.
pub fn accumulate_gradient(
    scene: &TraceScene,
    params: &Params,
    path: &[Vertex],
    delta: Rgb,
    grad: &mut Vec<(u32, f32)>,
) {
    let n = path.len();
    let brdfs: Vec<MicrofacetBrdf> = path
        .iter()
        .map(|v| brdf_of(scene.model, params, scene.tri_group[v.tri as usize]))
        .collect();
    // R_{k+1} of every vertex, from the back, and the BRDF weights w_k.
    let mut next_r = vec![Vec3::ZERO; n];
    let mut weight = vec![Vec3::ZERO; n];
    let mut r = Vec3::ZERO;
    for k in (0..n).rev() {
        next_r[k] = r;
        let (e, w) = vertex_terms(params, &brdfs[k], &path[k]);
        weight[k] = w;
        r = e + w * r;
    }
    let mut t = Vec3::ONE;
    for k in 0..n {
        let (v, b) = (&path[k], &brdfs[k]);
        let dt = delta * t;
        let le = params.emission(v.slot);
        push_emission(params, v.slot, dt * le * v.emission_weight, grad);
        // The material of vertex k, through its next-event term and its BRDF weight.
        let mut terms: [(Lobes, Rgb); 2] = [(Lobes::default(), Vec3::ZERO); 2];
        if let Some(nee) = v.nee {
            let lel = params.emission(nee.light);
            let lb = lobes(b, v.wo, nee.wi, true);
            terms[0] = (lb, dt * lel * nee.scale);
            push_emission(
                params,
                nee.light,
                dt * factor(b, &lb.l) * lel * nee.scale,
                grad,
            );
        }
        if let Some((wi, inv_pdf)) = v.next {
            terms[1] = (lobes(b, v.wo, wi, true), dt * next_r[k] * inv_pdf);
        }
        push_material(params, scene.tri_group[v.tri as usize], b, &terms, grad);
        t *= weight[k];
    }
}

#[inline]
fn push_emission(params: &Params, slot: u32, q: Rgb, grad: &mut Vec<(u32, f32)>) {
    if q == Vec3::ZERO {
        return;
    }
    let i = params.emission_index(slot) as u32;
    grad.extend([(i, q.x), (i + 1, q.y), (i + 2, q.z)]);
}

/// ∂/∂(a, σ, m) of Σ q ⊙ g(lobes) for the (lobes, q) `terms` of one vertex of group `g`.
fn push_material(
    params: &Params,
    g: u32,
    b: &MicrofacetBrdf,
    terms: &[(Lobes, Rgb); 2],
    grad: &mut Vec<(u32, f32)>,
) {
    let (a, m) = (params.albedo(g), params.metallic(g));
    let ((kd_a, ks_a), (kd_m, ks_m)) = metallic_workflow_derivatives(a, m);
    let (mut ga, mut gs, mut gm) = (Vec3::ZERO, 0.0f32, 0.0f32);
    for (lb, q) in terms {
        if *q == Vec3::ZERO {
            continue;
        }
        let [d, s0, _] = lb.l;
        ga += *q * (kd_a * d + ks_a * s0);
        gm += q.dot(kd_m * d + ks_m * s0);
        gs += q.dot(b.kd * lb.dl[0] + b.ks * lb.dl[1] + Vec3::splat(lb.dl[2]));
    }
    if ga == Vec3::ZERO && gs == 0.0 && gm == 0.0 {
        return;
    }
    let i = Params::albedo_index(g) as u32;
    grad.extend([
        (i, ga.x),
        (i + 1, ga.y),
        (i + 2, ga.z),
        (Params::roughness_index(g) as u32, gs),
        (Params::metallic_index(g) as u32, gm),
    ]);
}
