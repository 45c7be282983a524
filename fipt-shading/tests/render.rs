//! The path tracer on analytic cases: a closed sphere with uniform emission Le and Lambertian
//! albedo ρ has radiance Le/(1−ρ) everywhere inside (Le·Σ_{k≤B} ρ^k with B reflections), and
//! renders are reproducible for a seed.
use fipt_core::camera::Camera;
use fipt_shading::render::{render, render_aovs, RenderConfig};
use fipt_shading::scene::{LambertSurfaces, Scene};
use fipt_shading::synth::icosphere_mesh;
use glam::Vec3;

fn furnace(rho: f32, le: f32) -> Scene<LambertSurfaces> {
    furnace_scaled(rho, le, 1.0)
}

fn furnace_scaled(rho: f32, le: f32, radius: f32) -> Scene<LambertSurfaces> {
    let mesh = icosphere_mesh(Vec3::ZERO, radius, 2);
    let n = mesh.triangles.len();
    let surfaces = LambertSurfaces {
        albedo: vec![Vec3::splat(rho); n],
        emission: vec![Vec3::splat(le); n],
    };
    Scene::new(mesh, surfaces)
}

fn mean(img: &fipt_core::image::Image) -> f64 {
    img.data
        .iter()
        .map(|p| (p.x + p.y + p.z) as f64 / 3.0)
        .sum::<f64>()
        / img.data.len() as f64
}

/// 32×32 pixels × 64 spp = 65,536 paths from inside a 320-triangle icosphere.
/// Tolerance: 1 % of the exact value.
#[test]
fn closed_sphere_converges_to_le_over_one_minus_rho() {
    let cam = Camera::look_at(
        Vec3::new(0.1, -0.2, 0.05),
        Vec3::new(1.0, 0.3, 0.2),
        Vec3::Y,
        1.2,
        32,
        32,
    );
    for (rho, le) in [(0.5f32, 1.0f32), (0.8, 0.25)] {
        let scene = furnace(rho, le);
        // Infinite depth (Russian roulette keeps it unbiased).
        let cfg = RenderConfig {
            spp: 64,
            max_bounces: 200,
            rr_start: 3,
            seed: 1,
            tile: 8,
        };
        let (img, stats) = render(&scene, &cam, &cfg, 0, &|_| {});
        let exact = le as f64 / (1.0 - rho as f64);
        let got = mean(&img);
        assert!(
            (got - exact).abs() < 0.01 * exact,
            "ρ={rho}: {got} vs {exact}"
        );
        assert_eq!(stats.nonfinite, 0);
        // Finite depth: B reflections give Le·(1−ρ^{B+1})/(1−ρ).
        for b in [0u32, 1, 3] {
            let cfg = RenderConfig {
                spp: 64,
                max_bounces: b,
                rr_start: 100,
                seed: 2,
                tile: 8,
            };
            let (img, _) = render(&scene, &cam, &cfg, 0, &|_| {});
            let exact = le as f64 * (1.0 - (rho as f64).powi(b as i32 + 1)) / (1.0 - rho as f64);
            let got = mean(&img);
            assert!(
                (got - exact).abs() < 0.01 * exact,
                "ρ={rho} B={b}: {got} vs {exact}"
            );
        }
    }
}

#[test]
fn renders_are_reproducible_and_views_independent() {
    let scene = furnace(0.5, 1.0);
    let cam = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Y, 1.0, 16, 12);
    let cfg = RenderConfig {
        spp: 4,
        max_bounces: 5,
        rr_start: 1,
        seed: 7,
        tile: 5,
    };
    let (a, _) = render(&scene, &cam, &cfg, 3, &|_| {});
    let (b, _) = render(&scene, &cam, &cfg, 3, &|_| {});
    assert_eq!(
        a, b,
        "same seed, same image (bit for bit, whatever the thread schedule)"
    );
    let (c, _) = render(
        &scene,
        &cam,
        &RenderConfig {
            seed: 8,
            ..cfg.clone()
        },
        3,
        &|_| {},
    );
    assert_ne!(a, c);
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let (d, _) = one_thread.install(|| render(&scene, &cam, &cfg, 3, &|_| {}));
    assert_eq!(a, d);
}

#[test]
fn aovs_report_the_surface_at_pixel_centres() {
    let scene = furnace(0.3, 2.0);
    let cam = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 8, 6);
    let aov = render_aovs(&scene, &cam);
    for i in 0..48 {
        assert_eq!(aov.kd.data[i], Vec3::splat(0.3));
        assert_eq!(aov.emission.data[i], Vec3::splat(2.0));
        let d = aov.depth.data[i].x;
        assert!(d > 0.9 && d <= 1.0 + 1e-5, "inside a unit icosphere: {d}");
        let p = aov.position.data[i];
        assert!((p.length() - d).abs() < 1e-4, "camera at the origin");
        assert!(aov.normal.data[i].dot(p) < 0.0, "normal faces the camera");
        assert!(aov.face[i] < 320);
    }
}

/// Radiance from 1e-6 to 1e5 and enclosures from 1 mm to 1 km: the answer scales exactly,
/// nothing overflows, nothing becomes NaN.
#[test]
fn extremes_of_radiance_and_scale() {
    for (le, radius) in [
        (1e-6f32, 1.0f32),
        (1e5, 1.0),
        (1.0, 1e-3),
        (1.0, 1e3),
        (1e5, 1e-3),
    ] {
        let scene = furnace_scaled(0.5, le, radius);
        let cam = Camera::look_at(
            Vec3::splat(0.1 * radius),
            Vec3::new(1.0, 0.2, 0.1) * radius,
            Vec3::Y,
            1.0,
            16,
            16,
        );
        let cfg = RenderConfig {
            spp: 64,
            max_bounces: 100,
            rr_start: 3,
            seed: 4,
            tile: 8,
        };
        let (img, stats) = render(&scene, &cam, &cfg, 0, &|_| {});
        assert_eq!(stats.nonfinite, 0, "Le={le} r={radius}");
        assert!(img.data.iter().all(|p| p.is_finite()));
        let got = mean(&img);
        let exact = 2.0 * le as f64;
        assert!(
            (got - exact).abs() < 0.02 * exact,
            "Le={le} r={radius}: {got} vs {exact}"
        );
    }
}
