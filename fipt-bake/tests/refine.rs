//! The path-grown refinement: next-event estimation against an analytic form factor, MIS
//! against plain BRDF sampling, and the closure test: ground-truth materials through the
//! refined shadings reproduce the views better than through the initial bake.
use fipt_bake::bake::{
    diffuse_shading, specular_shading_mixture, BakeConfig, FactorizedBaker, SampleStream,
    SamplerKind,
};
use fipt_bake::refine::{GrownLight, PathGrownRefiner, RefineConfig};
use fipt_bake::slf::{Cube, SlfBuilder};
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::emitter::{EmitSide, Emitter};
use fipt_core::field::{Material, MaterialField};
use fipt_core::image::BadPixelPolicy;
use fipt_core::metrics::srgb_psnr;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{
    PixelDraw, RefineInputs, Scope, ShadingRefiner, Shard, ViewShadings, DEFAULT_LEVELS,
};
use fipt_geom::{Geometry, Mesh};
use fipt_shading::field_surfaces::FieldSurfaces;
use fipt_shading::render::RenderConfig;
use fipt_synth::{build, write_dataset, SynthOptions};
use glam::Vec3;
use std::f32::consts::PI;

mod common;

/// The same material everywhere.
struct Uniform(Material);
impl MaterialField for Uniform {
    fn name(&self) -> &str {
        "uniform"
    }
    fn materials(&self, p: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        Ok(vec![self.0; p.len()])
    }
    fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(vec![0.0; p.len()])
    }
}

/// Form factor from a differential area to a parallel rectangle [0, a]×[0, b] at height h,
/// the rectangle's corner above the area.
fn corner_form_factor(a: f32, b: f32, h: f32) -> f32 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// A floor at z = 0 and a square emitter of half-side `a` at height `h` above the origin.
fn floor_and_lamp(a: f32, h: f32, le: Vec3) -> (Mesh, Emitter) {
    let big = 50.0;
    let p = vec![
        Vec3::new(-big, -big, 0.0),
        Vec3::new(big, -big, 0.0),
        Vec3::new(big, big, 0.0),
        Vec3::new(-big, big, 0.0),
        Vec3::new(-a, -a, h),
        Vec3::new(a, -a, h),
        Vec3::new(a, a, h),
        Vec3::new(-a, a, h),
    ];
    let mesh = Mesh::from_triangles(p, None, vec![[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]]);
    let e = Emitter {
        triangles: vec![2, 3],
        radiance: vec![le.to_array(); 2],
        area: 4.0 * a * a,
        mean_radiance: le.to_array(),
        power: [0.0; 3],
        centroid: [0.0, 0.0, h],
        pixels: 1,
        sides: Vec::new(),
    };
    (mesh, e)
}

/// [`floor_and_lamp`] with a rough grey floor and an empty SLF: all light comes from the lamp.
struct LampScene {
    mesh: Mesh,
    geo: Geometry,
    surfaces: FieldSurfaces,
    slf: fipt_bake::slf::SurfaceLightField,
}

impl LampScene {
    fn new(a: f32, h: f32, le: Vec3) -> Self {
        Self::with_sides(a, h, le, Vec::new())
    }
    /// The lamp emitting from `sides` (its winding faces the floor).
    fn with_sides(a: f32, h: f32, le: Vec3, sides: Vec<EmitSide>) -> Self {
        let (mesh, mut e) = floor_and_lamp(a, h, le);
        e.sides = sides;
        let field = Uniform(Material {
            albedo: Vec3::splat(0.5),
            roughness: 0.9,
            metallic: 0.0,
        });
        let surfaces = FieldSurfaces::build(&field, &mesh, &[e], &[], 0.1).unwrap();
        let slf = SlfBuilder::new(
            Cube {
                min: Vec3::splat(-60.0),
                size: 120.0,
            },
            16,
        )
        .finish();
        LampScene {
            geo: Geometry::new(mesh.clone()),
            mesh,
            surfaces,
            slf,
        }
    }
    fn light(&self) -> GrownLight<'_> {
        GrownLight::new(&self.geo, &self.slf, &self.surfaces, &self.mesh, 0.6, 5)
    }
}

/// Ld under a square lamp is Le times the form factor, with emitter samples (MIS with the
/// cosine samples) and without; both within 1 %. The light samples cut the error's spread.
#[test]
fn next_event_estimation_matches_the_form_factor() {
    let (a, h) = (0.3f32, 1.0f32);
    let le = Vec3::new(1e-6, 3.0, 1e5); // extremes of radiance scale exactly
    let scene = LampScene::new(a, h, le);
    let (geo, light) = (&scene.geo, scene.light());
    let exact = le * 4.0 * corner_form_factor(a, a, h);
    let n = Vec3::Z;
    let spread = |n_cos: u32, n_light: u32| -> (f32, f32) {
        // Mean relative error and its spread over 64 independent estimates (green channel).
        let runs: Vec<f32> = (0..64u64)
            .map(|k| {
                let mut st = SampleStream::new(SamplerKind::Independent, &[k]);
                let mut rng = Pcg32::from_keys(&[k, 7]);
                let ld = diffuse_shading(
                    &light,
                    geo,
                    Vec3::new(0.0, 0.0, 0.0),
                    n,
                    n,
                    n_cos,
                    n_light,
                    &mut st,
                    &mut rng,
                );
                assert!(ld.is_finite());
                // All channels scale with Le.
                assert!(((ld.x / le.x) / (ld.y / le.y) - 1.0).abs() < 1e-4, "{ld}");
                assert!(((ld.z / le.z) / (ld.y / le.y) - 1.0).abs() < 1e-4, "{ld}");
                ld.y / exact.y - 1.0
            })
            .collect();
        let mean = runs.iter().sum::<f32>() / runs.len() as f32;
        let var = runs.iter().map(|r| (r - mean).powi(2)).sum::<f32>() / runs.len() as f32;
        (mean, var.sqrt())
    };
    let (m_cos, s_cos) = spread(1024, 0);
    let (m_mis, s_mis) = spread(1024, 64);
    let (m_nee, s_nee) = spread(0, 64);
    eprintln!(
        "relative error: cosine only {m_cos:+.4} ± {s_cos:.4}, cosine + emitters (MIS) {m_mis:+.4} ± {s_mis:.4}, emitters only {m_nee:+.4} ± {s_nee:.4}"
    );
    for (m, s, what) in [
        (m_cos, s_cos, "cosine"),
        (m_mis, s_mis, "MIS"),
        (m_nee, s_nee, "emitters"),
    ] {
        assert!(
            m.abs() < 0.01 + 3.0 * s / 8.0,
            "{what}: mean error {m} (spread {s})"
        );
    }
    assert!(
        s_mis < 0.5 * s_cos,
        "MIS spread {s_mis} should be well below cosine-only {s_cos}"
    );
}

/// A lamp emitting only on its side facing the floor lights it as a two-sided one does; one
/// emitting only on its other side leaves it dark, by cosine and by emitter samples alike.
#[test]
fn a_one_sided_lamp_lights_only_the_side_it_faces() {
    let (a, h, le) = (0.3f32, 1.0f32, Vec3::splat(2.0));
    let exact = le.y * 4.0 * corner_form_factor(a, a, h);
    for (sides, want) in [
        (vec![], exact),
        (vec![EmitSide::Front; 2], exact),
        (vec![EmitSide::Back; 2], 0.0),
    ] {
        let scene = LampScene::with_sides(a, h, le, sides.clone());
        let light = scene.light();
        for (n_cos, n_light) in [(4096, 0), (0, 256), (1024, 64)] {
            let mut st = SampleStream::new(SamplerKind::Independent, &[3]);
            let mut rng = Pcg32::from_keys(&[3, 7]);
            let ld = diffuse_shading(
                &light,
                &scene.geo,
                Vec3::ZERO,
                Vec3::Z,
                Vec3::Z,
                n_cos,
                n_light,
                &mut st,
                &mut rng,
            );
            assert!(
                (ld.y - want).abs() <= 0.03 * exact,
                "sides {sides:?}, {n_cos} cosine + {n_light} emitter samples: Ld {} against {want}",
                ld.y
            );
        }
    }
}

/// The GGX-mixture estimate of Ls0/Ls1 at every level, with and without emitter samples,
/// agrees (MIS is unbiased), for a glossy and a grazing view.
#[test]
fn emitter_samples_leave_the_specular_shadings_unbiased() {
    let (a, h) = (0.3f32, 1.0f32);
    let le = Vec3::splat(4.0);
    let scene = LampScene::new(a, h, le);
    let (geo, light) = (&scene.geo, scene.light());
    let n = Vec3::Z;
    // Points beside the lamp, seen so that the mirror direction passes near it.
    for (p, wo) in [
        (
            Vec3::new(-0.4, 0.0, 0.0),
            Vec3::new(-0.3, 0.0, 1.0).normalize(),
        ),
        (
            Vec3::new(-1.5, 0.0, 0.0),
            Vec3::new(-0.95, 0.0, 0.3).normalize(),
        ),
    ] {
        let est = |n_light: u32, counts: [u32; 6], key: u64| {
            let mut st: [SampleStream; 6] = std::array::from_fn(|l| {
                SampleStream::new(SamplerKind::Stratified, &[key, l as u64])
            });
            let mut rng = Pcg32::from_keys(&[key, 99]);
            specular_shading_mixture(
                &light,
                geo,
                p,
                n,
                n,
                wo,
                &DEFAULT_LEVELS,
                &counts,
                n_light,
                &mut st,
                &mut rng,
                fipt_core::reflectance::ReflectanceModel::Fipt,
            )
        };
        let (b0, b1) = est(0, [40_000; 6], 1);
        let (m0, m1) = est(8192, [2048; 6], 2);
        eprintln!(
            "p {p}: BRDF-only {:?}\n  MIS {:?}",
            (0..6).map(|l| b0[l].x + b1[l].x).collect::<Vec<_>>(),
            (0..6).map(|l| m0[l].x + m1[l].x).collect::<Vec<_>>()
        );
        for l in 0..6 {
            let (x, y) = (b0[l].x + b1[l].x, m0[l].x + m1[l].x);
            assert!(x.is_finite() && y.is_finite());
            assert!(
                (x - y).abs() <= 0.015 * x.abs().max(0.05),
                "p {p}, level {l}: BRDF-only {x} vs MIS {y}"
            );
        }
    }
}

/// Ground-truth materials of a generated scene as a field: the material of the nearest
/// triangle (brute force; test scenes are small).
struct TableField {
    mesh: Mesh,
    tri_material: Vec<u32>,
    materials: fipt_core::materials::SceneMaterials,
}

impl MaterialField for TableField {
    fn name(&self) -> &str {
        "ground truth"
    }
    fn materials(&self, pts: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        Ok(pts
            .iter()
            .map(|&p| {
                let best = (0..self.mesh.triangles.len())
                    .min_by(|&i, &j| {
                        let d = |t: usize| {
                            fipt_geom::nearest::closest_point(p, &self.mesh.vertices(t))
                                .distance_squared(p)
                        };
                        d(i).total_cmp(&d(j))
                    })
                    .unwrap();
                Material::of_surface(&self.materials.eval(self.tri_material[best], p))
            })
            .collect())
    }
    fn emission_mask(&self, p: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(vec![0.0; p.len()])
    }
}

/// Mean over views of the sRGB PSNR of Le + kd·Ld + ks·Ls0(σ) + Ls1(σ) (ground-truth
/// materials) against the input views, off the emitters.
fn closure(ds: &Dataset, shadings: &[ViewShadings], images: &[fipt_core::image::Image]) -> f64 {
    let split = ds.train();
    let mut sum = 0.0;
    for (v, s) in split.views.iter().zip(shadings) {
        let g = |k| ds.load_gt(split, k, v.index).unwrap().unwrap();
        let (kd, ks, ro, le) = (
            g(GtKind::DiffCol),
            g(GtKind::Specular),
            g(GtKind::Roughness),
            g(GtKind::Emit),
        );
        let pred: Vec<Vec3> = (0..kd.data.len())
            .map(|i| s.reflected(i, kd.data[i], ks.data[i], ro.data[i].x))
            .collect();
        assert!(pred.iter().all(|p| p.is_finite()));
        let mask: Vec<bool> = (0..kd.data.len())
            .map(|i| s.valid[i] && le.data[i].max_element() <= 0.0)
            .collect();
        sum += srgb_psnr(&pred, &images[v.index].data, Some(&mask)).unwrap();
    }
    sum / split.views.len() as f64
}

/// Closure on `cornell` (24 views of 64×48): the refined shadings, with ground-truth materials
/// and emitters, reproduce the views better than the initial bake at comparable cost, and
/// the refinement is deterministic.
#[test]
fn refined_shadings_raise_the_closure_psnr() {
    let dir = std::env::temp_dir().join(format!("fipt-refine-closure-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (ds, mesh, geo, images) = cornell_views(&dir);
    let scene = build("cornell").unwrap();
    let split = ds.train();
    let table = fipt_shading::scene::TableSurfaces::new(
        scene.materials.clone(),
        &mesh,
        std::path::Path::new("scene_gt.json"),
    )
    .unwrap();
    let field = TableField {
        mesh: mesh.clone(),
        tri_material: table.tri_material.clone(),
        materials: scene.materials.clone(),
    };
    let emitter = table_emitter(&table, &mesh);
    assert_eq!(emitter.triangles.len(), 2, "cornell has one quad light");
    let (bake, _, _) = FactorizedBaker::new(BakeConfig::default()).bake_detailed(
        &geo,
        &split.views,
        &images,
        &|_, _| {},
    );
    let inputs = RefineInputs {
        geometry: &geo,
        positions: &mesh.positions,
        triangles: &mesh.triangles,
        views: &split.views,
        images: &images,
        field: &field,
        emitters: std::slice::from_ref(&emitter),
    };
    let refiner = PathGrownRefiner::new(RefineConfig::default());
    let (refined, stats) = refiner.refine_detailed(&inputs, &|_, _| {}).unwrap();
    let again = refiner.refine(&inputs, &|_, _| {}).unwrap();
    assert_eq!(refined, again.output, "refinement must be deterministic");
    // A drawn share: its pixels exactly as a whole refinement with the diffuse cache's cells
    // grown by √(1 / 0.25) = 2 gives them, the others misses; with no growth, as `refined`.
    let draw = PixelDraw::new(3, Some(0.25));
    assert_eq!(RefineConfig::default().cache_cell_for(&draw), 2.0);
    assert_eq!(RefineConfig::default().cache_cell_for(&PixelDraw::ALL), 1.0);
    let grown = PathGrownRefiner::new(RefineConfig {
        cache_cell_scale: 2.0,
        ..Default::default()
    })
    .refine(&inputs, &|_, _| {})
    .unwrap()
    .output;
    assert_ne!(grown, refined, "cells twice as wide give another Ld");
    let fixed = RefineConfig {
        cache_cell_growth: 1.0,
        ..Default::default()
    };
    for (cfg, whole) in [(RefineConfig::default(), &grown), (fixed, &refined)] {
        let mut kept = 0;
        PathGrownRefiner::new(cfg)
            .refine_into(
                &inputs,
                Scope {
                    shard: Shard::ALL,
                    pixels: draw,
                },
                &|_, _| {},
                &mut |k, s| {
                    kept += common::check_drawn(k, &s, &whole[k], draw).0;
                    Ok(())
                },
            )
            .unwrap();
        assert!(kept > 0);
    }
    // The contract carries the same statistics as the detailed call.
    assert_eq!(again.report["rays"], serde_json::json!(stats.rays));
    let no_light = PathGrownRefiner::new(RefineConfig {
        light_samples: 0,
        ..Default::default()
    })
    .refine(&inputs, &|_, _| {})
    .unwrap()
    .output;
    // The reference's refinement: Ld per pixel (128 samples, no emitter samples) instead of
    // per cache cell with emitter samples.
    let per_pixel = PathGrownRefiner::new(RefineConfig::reference())
        .refine(&inputs, &|_, _| {})
        .unwrap()
        .output;
    // The SLF with the pixels beside the light (its anti-aliased outline), which the default
    // leaves out.
    let (with_outline, outline_stats) = PathGrownRefiner::new(RefineConfig {
        slf_light_margin: 0,
        ..Default::default()
    })
    .refine_detailed(&inputs, &|_, _| {})
    .unwrap();
    let (c_bake, c_ref, c_nolight, c_pixel, c_outline) = (
        closure(&ds, &bake, &images),
        closure(&ds, &refined, &images),
        closure(&ds, &no_light, &images),
        closure(&ds, &per_pixel, &images),
        closure(&ds, &with_outline, &images),
    );
    eprintln!(
        "closure: initial bake {c_bake:.2} dB, refined {c_ref:.2} dB, refined without emitter samples {c_nolight:.2} dB, per-pixel Ld (reference) {c_pixel:.2} dB, the light's outline in the SLF {c_outline:.2} dB; {stats:?}"
    );
    // Measured: 31.52 dB against 31.29 with the outline.
    assert!(stats.slf_margin_pixels > 0 && outline_stats.slf_margin_pixels == 0);
    assert!(
        c_ref >= c_outline,
        "leaving the light's outline out of the SLF should not lower the closure: {c_outline:.2} → {c_ref:.2} dB"
    );
    // Measured: 22.7 dB against 31.3 with the cache and emitter samples (the reference's
    // estimator is noisy where small lights are found only by BRDF samples).
    assert!(
        c_pixel.is_finite() && c_ref >= c_pixel + 3.0,
        "the cached refinement should beat the per-pixel reference's: {c_pixel:.2} vs {c_ref:.2} dB"
    );
    assert!(stats.secondary_emitter > 0 && stats.secondary_slf > 0 && stats.secondary_grown > 0);
    assert!(
        c_ref >= c_bake + 1.0,
        "refinement should raise the closure: {c_bake:.2} → {c_ref:.2} dB"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The cornell scene rendered into `dir` (24 views of 64×48 at 256 spp), opened: the dataset,
/// its mesh and geometry, the training images.
fn cornell_views(dir: &std::path::Path) -> (Dataset, Mesh, Geometry, Vec<fipt_core::image::Image>) {
    let opts = SynthOptions {
        train_views: 24,
        val_views: 1,
        width: 64,
        height: 48,
        render: RenderConfig {
            spp: 256,
            ..Default::default()
        },
        model: Default::default(),
        lens: Default::default(),
    };
    let scene = build("cornell").unwrap();
    write_dataset(scene, dir, &opts, &|_, _| {}).unwrap();
    let ds = Dataset::open(&dir).unwrap();
    let mesh = Mesh::load(&ds.mesh).unwrap();
    let geo = Geometry::new(mesh.clone());
    let split = ds.train().clone();
    let images: Vec<_> = split
        .views
        .iter()
        .map(|v| ds.load_image(v, BadPixelPolicy::Reject).unwrap().0)
        .collect();
    (ds, mesh, geo, images)
}

/// The emitter of a material table's emitting triangles.
fn table_emitter(table: &fipt_shading::scene::TableSurfaces, mesh: &Mesh) -> Emitter {
    let mut emitter = Emitter {
        triangles: vec![],
        radiance: vec![],
        area: 0.0,
        mean_radiance: [0.0; 3],
        power: [0.0; 3],
        centroid: [0.0; 3],
        pixels: 0,
        sides: Vec::new(),
    };
    for t in 0..mesh.triangles.len() as u32 {
        use fipt_shading::scene::SurfaceModel;
        let le = table.emission(t);
        if le != Vec3::ZERO {
            emitter.triangles.push(t);
            emitter.radiance.push(le.to_array());
        }
    }
    emitter
}
