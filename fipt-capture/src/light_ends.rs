//! What the kd map would be at the ends of a light's range, where the views do not pin the
//! light ([`crate::light_scale`]).
//!
//! Off the lights the views fix I(x) = kd(x) · S(x), S(x) = A(x) + Σ_j L_j · D_j(x): A is the
//! light the surface receives from the rest of the room, read from the photos themselves (it
//! is data and does not move with a light's guess), D_j what light j gives it at unit
//! radiance. With light e at L'_e instead of the chosen L_e the same pixels need
//! kd'(x) = kd(x) · S(x) / S'(x), S' = S + (L'_e − L_e) · D_e. That is the first-order
//! picture the report draws at each end of the range: the run's kd re-weighted by the light
//! the estimate itself measures, not a second run (the specular split and the training's
//! smoothing would shift a little too).
use crate::light_scale::{direct, gather, LightEstimate};
use fipt_bake::slf::SurfaceLightField;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::rng::Pcg32;
use fipt_geom::{offset_ray_origin, Geometry, TriangleSampler};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};

/// The room's light as the estimate measures it: the surface light field of the training
/// views (lights and clipped pixels left out), the lights' triangles, the side each emits on
/// and a sampler per light.
#[derive(Clone, Debug)]
pub struct LightModel {
    pub(crate) slf: SurfaceLightField,
    /// Per triangle, what [`gather`] reads where the light field holds nothing.
    pub(crate) fill: Vec<Vec3>,
    pub(crate) is_light: HashSet<u32>,
    pub(crate) side: HashMap<u32, f32>,
    pub(crate) samplers: Vec<TriangleSampler>,
}

impl LightModel {
    /// A and each light's D (unit radiance) at the surface point `hit` seen from `eye`. The
    /// same random numbers at every point: A and D vary smoothly along a surface (their noise
    /// does not pass for texture), but for shadows.
    pub(crate) fn parts(
        &self,
        geometry: &Geometry,
        eye: Vec3,
        hit: fipt_shading::records::HitPoint,
    ) -> (Vec3, Vec<f32>) {
        let (o, n, mut rng) = Self::frame(geometry, eye, hit);
        let a = gather(
            geometry,
            &self.slf,
            &self.fill,
            &self.is_light,
            o,
            n,
            &mut rng,
        );
        let d = self
            .samplers
            .iter()
            .map(|s| direct(geometry, s, &self.side, o, n, &mut rng))
            .collect();
        (a, d)
    }

    /// The surface points `count` cosine directions from `hit` meet (None: a miss or a
    /// light); [`Self::parts`] reads A from the first 64 of them.
    pub(crate) fn gathered(
        &self,
        geometry: &Geometry,
        eye: Vec3,
        hit: fipt_shading::records::HitPoint,
        count: usize,
    ) -> Vec<Option<Vec3>> {
        let (o, n, mut rng) = Self::frame(geometry, eye, hit);
        crate::light_scale::gather_points(geometry, &self.is_light, o, n, count, &mut rng)
            .into_iter()
            .map(|p| p.map(|(p, _)| p))
            .collect()
    }

    /// The ray origin off the surface at `hit`, its normal facing `eye`, and the random
    /// numbers every point starts from.
    fn frame(
        geometry: &Geometry,
        eye: Vec3,
        hit: fipt_shading::records::HitPoint,
    ) -> (Vec3, Vec3, Pcg32) {
        let mut n = geometry.mesh.face_normal(hit.tri() as usize);
        if n.dot(eye - hit.p) < 0.0 {
            n = -n;
        }
        (offset_ray_origin(hit.p, n), n, Pcg32::from_keys(&[0x11a7]))
    }
}

/// One end of one light's range and the factor that turns the run's kd into kd at that end.
#[derive(Clone, Debug)]
pub struct EndFactor {
    /// The light's index among the estimates.
    pub light: usize,
    /// "lower" or "upper".
    pub end: &'static str,
    /// The end, in clip levels (luminance), and the chosen value.
    pub levels: f32,
    pub chosen: f32,
    /// kd at the end / kd as run, per pixel and channel (1 off the surfaces, on the lights and
    /// where S' vanishes).
    pub factor: Image,
}

/// The ends worth drawing: per light the views do not pin, each finite end of its range that
/// lies more than 1 % from the chosen value.
pub fn ends(estimates: &[LightEstimate]) -> Vec<(usize, &'static str, f32)> {
    let mut out = vec![];
    for (e, x) in estimates.iter().enumerate().filter(|(_, x)| !x.pinned) {
        for (end, levels) in [("lower", x.range[0]), ("upper", x.range[1])] {
            let off = (levels / x.levels.max(1e-30) - 1.0).abs();
            if levels.is_finite() && levels > 0.0 && off > 0.01 {
                out.push((e, end, levels));
            }
        }
    }
    out
}

/// The factors of [`ends`] for `view`, computed every `stride`-th pixel in each direction
/// (each fills its stride × stride block). `estimates` are at the scale the model was
/// measured at; the factors are ratios and carry no scale.
pub fn end_factors(
    model: &LightModel,
    geometry: &Geometry,
    view: &View,
    estimates: &[LightEstimate],
    stride: usize,
) -> Vec<EndFactor> {
    let todo = ends(estimates);
    if todo.is_empty() {
        return vec![];
    }
    let (w, h) = (view.camera.width, view.camera.height);
    let stride = stride.max(1);
    let hits = fipt_shading::records::hit_points(geometry, view);
    let l: Vec<Vec3> = estimates
        .iter()
        .map(|x| Vec3::from_array(x.radiance))
        .collect();
    // Per computed pixel, per end: the factor.
    let rows: Vec<Vec<Vec<Vec3>>> = (0..h.div_ceil(stride))
        .into_par_iter()
        .map(|by| {
            (0..w.div_ceil(stride))
                .map(|bx| {
                    let (x, y) = (
                        (bx * stride + stride / 2).min(w - 1),
                        (by * stride + stride / 2).min(h - 1),
                    );
                    let hit = hits[y * w + x].filter(|h| !model.is_light.contains(&h.tri()));
                    let Some(hit) = hit else {
                        return vec![Vec3::ONE; todo.len()];
                    };
                    let (a, d) = model.parts(geometry, view.camera.origin, hit);
                    factors(a, &d, &l, estimates, &todo)
                })
                .collect()
        })
        .collect();
    todo.iter()
        .enumerate()
        .map(|(k, &(light, end, levels))| {
            let mut factor = Image::new(w, h);
            for (i, p) in factor.data.iter_mut().enumerate() {
                *p = rows[(i / w) / stride][(i % w) / stride][k];
            }
            EndFactor {
                light,
                end,
                levels,
                chosen: estimates[light].levels,
                factor,
            }
        })
        .collect()
}

/// S / S' per end at a point with room light `a` and unit-radiance lights `d`, the lights at
/// `l`.
fn factors(
    a: Vec3,
    d: &[f32],
    l: &[Vec3],
    estimates: &[LightEstimate],
    todo: &[(usize, &'static str, f32)],
) -> Vec<Vec3> {
    let s = a + d.iter().zip(l).map(|(d, l)| *l * *d).sum::<Vec3>();
    todo.iter()
        .map(|&(e, _, levels)| {
            let scale = levels / estimates[e].levels.max(1e-30);
            let s_end = s + l[e] * ((scale - 1.0) * d[e]);
            Vec3::select(
                s_end.cmpgt(Vec3::ZERO) & s.cmpgt(Vec3::ZERO),
                s / s_end,
                Vec3::ONE,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimate(levels: f32, range: [f32; 2], pinned: bool) -> LightEstimate {
        LightEstimate {
            triangles: 2,
            radiance: [levels; 3],
            levels,
            contrast: 0.0,
            pinned,
            range,
            chosen_by: if pinned { "flatness" } else { "albedo" }.into(),
        }
    }

    #[test]
    fn only_unpinned_lights_and_finite_ends_away_from_the_choice_are_drawn() {
        let est = [
            estimate(10.0, [5.0, 40.0], true),
            estimate(10.0, [5.0, f32::INFINITY], false),
            estimate(10.0, [10.0, 30.0], false),
        ];
        assert_eq!(ends(&est), vec![(1, "lower", 5.0), (2, "upper", 30.0)]);
    }

    #[test]
    fn a_surface_lit_only_by_the_light_scales_inversely_and_the_rest_stays() {
        let est = [
            estimate(10.0, [2.0, 50.0], false),
            estimate(4.0, [4.0, 4.0], true),
        ];
        let todo = ends(&est);
        let l = [Vec3::splat(10.0), Vec3::splat(4.0)];
        // Lit by light 0 alone: kd' = kd · L / L'.
        let f = factors(Vec3::ZERO, &[0.1, 0.0], &l, &est, &todo);
        assert!(
            (f[0] - Vec3::splat(5.0)).abs().max_element() < 1e-5,
            "{f:?}"
        );
        assert!(
            (f[1] - Vec3::splat(0.2)).abs().max_element() < 1e-5,
            "{f:?}"
        );
        // Lit by the room and light 1 only: unchanged.
        let f = factors(Vec3::splat(0.3), &[0.0, 0.2], &l, &est, &todo);
        assert!(f
            .iter()
            .all(|f| (*f - Vec3::ONE).abs().max_element() < 1e-6));
        // Half the light from light 0 at the chosen value: S' = 0.5 + 0.5 · 5 at the upper end.
        let f = factors(Vec3::splat(0.5), &[0.05, 0.0], &l, &est, &todo);
        assert!(
            (f[1] - Vec3::splat(1.0 / 3.0)).abs().max_element() < 1e-5,
            "{f:?}"
        );
        // Nothing lit: no factor.
        let f = factors(Vec3::ZERO, &[0.0, 0.0], &l, &est, &todo);
        assert!(f.iter().all(|f| *f == Vec3::ONE));
    }

    /// A floor lit by one square light above it and nothing else (A = 0): kd at an end is kd ×
    /// chosen / end on every floor pixel, exactly, and off the floor nothing changes.
    #[test]
    fn on_a_floor_lit_by_the_light_alone_the_factor_is_the_ratio_of_the_radiances() {
        let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let positions = vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.4, 0.4, 1.0),
            p(0.6, 0.4, 1.0),
            p(0.6, 0.6, 1.0),
            p(0.4, 0.6, 1.0),
        ];
        let tris = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let geometry = Geometry::new(fipt_geom::Mesh::from_triangles(positions, None, tris));
        let lights = [2u32, 3];
        let cube = fipt_core::cube::Cube::around([Vec3::ZERO, Vec3::ONE], 1.1).unwrap();
        let model = LightModel {
            slf: fipt_bake::slf::SlfBuilder::with_fallback(cube, 8, 1).finish(),
            fill: vec![],
            is_light: lights.into_iter().collect(),
            side: HashMap::new(),
            samplers: vec![TriangleSampler::uniform_area(&geometry.mesh, &lights).unwrap()],
        };
        let camera = fipt_core::camera::Camera::look_at(
            p(0.5, 0.5, 0.6),
            p(0.5, 0.5, 0.0),
            Vec3::Y,
            2.0,
            16,
            12,
        );
        let view = View {
            index: 0,
            camera,
            image: "x".into(),
            mask: None,
        };
        let est = [estimate(10.0, [2.0, 40.0], false)];
        let ends = end_factors(&model, &geometry, &view, &est, 2);
        assert_eq!(ends.len(), 2);
        let hits = fipt_shading::records::hit_points(&geometry, &view);
        let floor = hits.iter().filter(|h| h.is_some()).count();
        assert!(floor > 40 && floor < 16 * 12, "{floor} floor pixels");
        for (e, want) in ends.iter().zip([5.0f32, 0.25]) {
            for (i, f) in e.factor.data.iter().enumerate() {
                // Each factor is its 2 × 2 block's centre pixel's.
                let (x, y) = ((i % 16) / 2 * 2 + 1, (i / 16) / 2 * 2 + 1);
                let want = if hits[y * 16 + x].is_some() {
                    want
                } else {
                    1.0
                };
                assert!(
                    (*f - Vec3::splat(want)).abs().max_element() < 1e-4,
                    "{} {i}: {f}",
                    e.end
                );
            }
        }
        // A pinned light draws nothing.
        let pinned = [estimate(10.0, [2.0, 40.0], true)];
        assert!(end_factors(&model, &geometry, &view, &pinned, 2).is_empty());
    }
}
