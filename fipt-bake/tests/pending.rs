//! The lights' two halves (`begin`, then `finish`): the SLF light reads the voxel at the hit,
//! and the estimators that keep one sample in flight give bit for bit what they give fed one
//! sample at a time, for the bake's light and for the refinement's (whose paths draw from the
//! random stream in `finish`).
use fipt_bake::bake::{
    diffuse_moments, specular_shading_mixture, SampleStream, SamplerKind, SlfLight,
};
use fipt_bake::refine::GrownLight;
use fipt_bake::slf::{Cube, SlfBuilder, SurfaceLightField};
use fipt_core::emitter::Emitter;
use fipt_core::field::{Material, MaterialField};
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{RayQuery, DEFAULT_LEVELS};
use fipt_geom::{Geometry, TriangleSampler};
use fipt_shading::field_surfaces::FieldSurfaces;
use fipt_shading::incident::{IncidentLight, Incoming};
use fipt_synth::icosphere_mesh;
use glam::Vec3;

/// A light with only `incoming`: the trait's default halves, one sample at a time.
struct Eager<L>(L);

impl<L: IncidentLight> IncidentLight for Eager<L> {
    fn incoming(&self, origin: Vec3, dir: Vec3, rng: &mut Pcg32) -> Incoming {
        self.0.incoming(origin, dir, rng)
    }
    fn has_emitters(&self) -> bool {
        self.0.has_emitters()
    }
    fn sample_emitter(
        &self,
        origin: Vec3,
        rng: &mut Pcg32,
    ) -> Option<fipt_shading::incident::LightSample> {
        self.0.sample_emitter(origin, rng)
    }
}

/// The same glossy material everywhere (paths grow through it).
struct Glossy;
impl MaterialField for Glossy {
    fn name(&self) -> &str {
        "glossy"
    }
    fn materials(&self, p: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        let m = Material {
            albedo: Vec3::new(0.6, 0.5, 0.4),
            roughness: 0.3,
            metallic: 0.2,
        };
        Ok(vec![m; p.len()])
    }
    fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(vec![0.0; p.len()])
    }
}

/// A unit sphere whose SLF radiance varies over it (every voxel a different value) and leaves
/// holes (a quarter of the surface unobserved), so that lookups differ from sample to sample.
fn scene() -> (Geometry, SurfaceLightField) {
    let mesh = icosphere_mesh(Vec3::ZERO, 1.0, 3);
    let all: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
    let sampler = TriangleSampler::uniform_area(&mesh, &all).unwrap();
    let cube = Cube::around(mesh.positions.iter().copied(), 1.1).unwrap();
    let mut b = SlfBuilder::with_fallback(cube, 64, 2);
    let mut rng = Pcg32::new(7, 1);
    for _ in 0..200_000 {
        let p = sampler.sample(&mesh, rng.next_f32(), rng.next_2d()).p;
        if p.x > 0.5 && p.y > 0.0 {
            continue;
        }
        let l = Vec3::new(1.0 + p.x, 2.0 + p.y * p.z, 0.5 + p.z * p.z) * rng.next_f32();
        b.add(p, l);
    }
    (Geometry::new(mesh), b.finish())
}

#[test]
fn the_slf_light_reads_the_voxel_at_the_hit() {
    let (geo, slf) = scene();
    let light = SlfLight {
        geometry: &geo,
        slf: &slf,
    };
    let mut rng = Pcg32::new(3, 3);
    let (mut hits, mut misses) = (0, 0);
    for i in 0..20_000 {
        // Inside, every ray hits; from outside, most leave.
        let origin = if i % 2 == 0 {
            Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.5 - 0.25
        } else {
            Vec3::new(0.0, 0.0, 3.0)
        };
        let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let Some(dir) = d.try_normalize() else {
            continue;
        };
        let want = match geo.intersect(origin, dir) {
            Some(h) => Incoming::Radiance(slf.lookup(h.p)),
            None => Incoming::Miss,
        };
        assert_eq!(light.incoming(origin, dir, &mut rng), want, "ray {i}");
        let pending = light.begin(origin, dir, &mut rng);
        assert_eq!(light.finish(pending, &mut rng), want, "ray {i}, in halves");
        match want {
            Incoming::Miss => misses += 1,
            _ => hits += 1,
        }
    }
    assert!(
        hits > 5_000 && misses > 1_000,
        "{hits} hits, {misses} misses"
    );
}

/// Ls0/Ls1 at every level and the diffuse moments at the point `i` of the sphere, with
/// `n_light` emitter samples each, as text.
fn shadings<L: IncidentLight>(
    light: &L,
    geo: &Geometry,
    i: u64,
    model: ReflectanceModel,
    n_light: u32,
) -> String {
    let mut rng = Pcg32::new(5, i);
    let d = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
    let hit = geo.intersect(Vec3::ZERO, d.normalize()).unwrap();
    let n = -hit.ng;
    let wo = (n + Vec3::new(0.3, -0.2, 0.1) * (i % 4) as f32).normalize();
    let mut st =
        std::array::from_fn(|k| SampleStream::new(SamplerKind::Stratified, &[i, k as u64]));
    let (l0, l1) = specular_shading_mixture(
        light,
        geo,
        hit.p,
        n,
        n,
        wo,
        &DEFAULT_LEVELS,
        &[16; 6],
        n_light,
        &mut st,
        &mut rng,
        model,
    );
    assert!(
        l0.iter().chain(&l1).any(|v| *v != Vec3::ZERO),
        "point {i}: all black"
    );
    let mut st = SampleStream::new(SamplerKind::Stratified, &[i]);
    let m = diffuse_moments(
        light, geo, hit.p, n, n, 64, n_light, &mut st, &mut rng, true,
    );
    format!("{l0:?} {l1:?} {m:?}")
}

#[test]
fn estimators_with_a_sample_in_flight_equal_one_at_a_time() {
    let (geo, slf) = scene();
    let light = SlfLight {
        geometry: &geo,
        slf: &slf,
    };
    let eager = Eager(light);
    for i in 0..40 {
        for model in ReflectanceModel::ALL {
            assert_eq!(
                shadings(&light, &geo, i, model, 0),
                shadings(&eager, &geo, i, model, 0),
                "point {i}, {model}"
            );
        }
    }
}

/// The refinement's light on the same sphere, glossy (paths grow, drawing from the stream in
/// `finish`) with a lamp of a few triangles (emitter hits answer in `begin`).
#[test]
fn grown_paths_with_a_sample_in_flight_equal_one_at_a_time() {
    let (geo, slf) = scene();
    let mesh = icosphere_mesh(Vec3::ZERO, 1.0, 3);
    let area = |t: usize| {
        let [a, b, c] = mesh.vertices(t);
        0.5 * (b - a).cross(c - a).length()
    };
    let lamp = Emitter {
        triangles: vec![0, 1, 2, 3],
        radiance: vec![[20.0, 18.0, 15.0]; 4],
        area: (0..4).map(area).sum(),
        mean_radiance: [20.0, 18.0, 15.0],
        power: [0.0; 3],
        centroid: mesh.vertices(0)[0].to_array(),
        pixels: 1,
        sides: Vec::new(),
    };
    let surfaces = FieldSurfaces::build(&Glossy, &mesh, &[lamp], &[], 0.05).unwrap();
    let grown = || GrownLight::new(&geo, &slf, &surfaces, &mesh, 0.6, 4);
    let (light, eager) = (grown(), Eager(grown()));
    assert!(light.has_emitters());
    for i in 0..40 {
        let model = ReflectanceModel::ALL[i as usize % ReflectanceModel::ALL.len()];
        // With and without emitter samples (drawn after the GGX and cosine samples).
        for n_light in [0, 8] {
            assert_eq!(
                shadings(&light, &geo, i, model, n_light),
                shadings(&eager, &geo, i, model, n_light),
                "point {i}, {model}, {n_light} light samples"
            );
        }
    }
}
