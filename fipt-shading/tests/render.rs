//! The path tracer on analytic cases: a closed sphere with uniform emission Le and Lambertian
//! albedo ρ has radiance Le/(1−ρ) everywhere inside (Le·Σ_{k≤B} ρ^k with B reflections), and
//! renders are reproducible for a seed.
use fipt_core::camera::Camera;
use fipt_shading::render::{render, render_aovs, RenderConfig};
use fipt_shading::scene::{LambertSurfaces, Scene};
use fipt_synth::icosphere_mesh;
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

/// The tracer keeps several pixels' paths in flight on a thread; each pixel still draws its
/// random stream one path after another, so the image and the variance are those traced
/// pixel by pixel with `trace_path` (compared bit for bit), and the ray count the sum of its
/// paths', whatever the tile: a pixel, fewer pixels than paths in flight, more, the whole
/// image. (That `trace_path` itself traces as before its split into `arrive` and `scatter` is
/// shown by whole renders, `docs/scaling.md`, *Paths in flight*.)
#[test]
fn paths_in_flight_give_the_image_of_one_path_at_a_time() {
    use fipt_core::color::luminance;
    use fipt_core::rng::Pcg32;
    use fipt_shading::render::{trace_path, trace_variance};
    let scene = furnace(0.7, 1.0);
    let (w, h) = (40usize, 20usize);
    let cam = Camera::look_at(Vec3::ZERO, Vec3::X, Vec3::Y, 1.0, w, h);
    let (view_key, spp) = (5u64, 3u32);
    let cfg = RenderConfig {
        spp,
        max_bounces: 6,
        rr_start: 0,
        seed: 11,
        tile: 1,
    };
    let (mut want, mut want_var, mut rays) = (Vec::new(), Vec::new(), 0u64);
    for y in 0..h {
        for x in 0..w {
            let mut rng = Pcg32::from_keys(&[cfg.seed, view_key, (y * w + x) as u64]);
            let (mut sum, mut sq) = (Vec3::ZERO, 0.0f64);
            for _ in 0..spp {
                let j = rng.next_2d();
                let (o, d) = cam.ray(x as f32 + j.x, y as f32 + j.y);
                let (l, r) = trace_path(&scene, &cfg, o, d, &mut rng);
                sum += l;
                sq += (luminance(l) as f64).powi(2);
                rays += r as u64;
            }
            let n = spp as f32;
            let mean = sum / n;
            let lm = luminance(mean) as f64;
            want_var.push((((sq / n as f64 - lm * lm).max(0.0)) / n as f64) as f32);
            want.push(mean);
        }
    }
    let bits = |v: &[Vec3]| -> Vec<[u32; 3]> {
        v.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
    };
    let var_bits = |v: &[f32]| -> Vec<u32> { v.iter().map(|x| x.to_bits()).collect() };
    for tile in [1, 3, 16, 64] {
        let cfg = RenderConfig {
            tile,
            ..cfg.clone()
        };
        let (img, var, stats) = trace_variance(&scene, &cam, &cfg, view_key, &|_| {});
        assert_eq!(bits(&img.data), bits(&want), "tile {tile}");
        assert_eq!(var_bits(&var), var_bits(&want_var), "tile {tile}");
        assert_eq!(stats.rays, rays, "tile {tile}");
        assert_eq!(stats.nonfinite, 0);
    }
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

/// A Lambertian floor (albedo ρ) lit by one added light, seen straight down at the point
/// under it; one bounce. Returns the radiance of the floor at the origin.
fn floor_radiance(
    rho: f32,
    add: impl FnOnce(&mut fipt_geom::Mesh, &mut fipt_shading::edit::EditedSurfaces<LambertSurfaces>),
    delta: Vec<fipt_shading::lights::DeltaLight>,
) -> f32 {
    use fipt_core::rng::Pcg32;
    let s = 50.0;
    let mut mesh = fipt_geom::Mesh::from_triangles(
        vec![
            Vec3::new(-s, 0.0, -s),
            Vec3::new(s, 0.0, -s),
            Vec3::new(s, 0.0, s),
            Vec3::new(-s, 0.0, s),
        ],
        None,
        vec![[0, 2, 1], [0, 3, 2]],
    );
    let base = LambertSurfaces {
        albedo: vec![Vec3::splat(rho); 2],
        emission: vec![Vec3::ZERO; 2],
    };
    let mut surfaces = fipt_shading::edit::EditedSurfaces::new(base, &mesh);
    add(&mut mesh, &mut surfaces);
    let mut scene = Scene::new(mesh, surfaces);
    scene.delta_lights = delta;
    let cfg = RenderConfig {
        max_bounces: 1,
        ..Default::default()
    };
    let n = 4000;
    let mut sum = 0.0f64;
    let mut rng = Pcg32::from_keys(&[7]);
    for _ in 0..n {
        let o = Vec3::new(0.0, 0.5, 0.0);
        let (l, _) = fipt_shading::render::trace_path(&scene, &cfg, o, -Vec3::Y, &mut rng);
        sum += l.x as f64;
    }
    (sum / n as f64) as f32
}

#[test]
fn point_and_spot_lights_give_the_inverse_square_law() {
    use fipt_shading::lights::LightSpec;
    let (rho, i, h) = (0.6f32, 5.0f32, 2.0f32);
    let exact = rho / std::f32::consts::PI * i / (h * h);
    let point = LightSpec::Point {
        position: [0.0, h, 0.0],
        intensity: [i; 3],
    };
    let l = floor_radiance(rho, |_, _| {}, vec![point.delta().unwrap()]);
    assert!((l / exact - 1.0).abs() < 1e-4, "point: {l} vs {exact}");
    // A spot aimed at the point gives the same; aimed away, nothing.
    for (dir, want) in [([0.0, -1.0, 0.0], exact), ([1.0, 0.0, 0.0], 0.0)] {
        let spot = LightSpec::Spot {
            position: [0.0, h, 0.0],
            direction: dir,
            intensity: [i; 3],
            cutoff_angle: 30.0,
            beam_width: None,
        };
        let l = floor_radiance(rho, |_, _| {}, vec![spot.delta().unwrap()]);
        assert!(
            (l - want).abs() <= 1e-4 * exact,
            "spot {dir:?}: {l} vs {want}"
        );
    }
}

#[test]
fn a_one_sided_quad_light_lights_only_the_side_it_faces() {
    use fipt_core::materials::SurfacePoint;
    use fipt_shading::edit::AddedSurface;
    use fipt_shading::lights::LightSpec;
    // A small square light at height h: irradiance ≈ Le·A/h² at the point below.
    let (rho, le, h, a) = (0.5f32, 100.0f32, 1.0f32, 0.05f32);
    let quad = |down: bool| {
        let (e1, e2) = if down {
            ([a, 0.0, 0.0], [0.0, 0.0, a])
        } else {
            ([0.0, 0.0, a], [a, 0.0, 0.0])
        };
        LightSpec::Quad {
            corner: [-a / 2.0, h, -a / 2.0],
            edge1: e1,
            edge2: e2,
            radiance: [le; 3],
            two_sided: false,
        }
    };
    let add = |spec: LightSpec| {
        move |mesh: &mut fipt_geom::Mesh,
              s: &mut fipt_shading::edit::EditedSurfaces<LambertSurfaces>| {
            let (m, le, two) = spec.area(std::path::Path::new(".")).unwrap().unwrap();
            let what = AddedSurface {
                surface: SurfacePoint {
                    emission: le,
                    roughness: 1.0,
                    ..Default::default()
                },
                one_sided: !two,
                part: 1,
            };
            s.add(mesh, &m, what);
        }
    };
    let exact = rho / std::f32::consts::PI * le * a * a / (h * h);
    // e1 × e2 of the first quad points down (−y) at the floor; the second's up.
    let facing = floor_radiance(rho, add(quad(true)), vec![]);
    let away = floor_radiance(rho, add(quad(false)), vec![]);
    assert!(
        (facing / exact - 1.0).abs() < 0.01,
        "facing: {facing} vs {exact}"
    );
    assert_eq!(away, 0.0);
}
