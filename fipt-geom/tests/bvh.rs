//! BVH queries against brute force, robust offsets, and area sampling.
use fipt_core::rng::Pcg32;
use fipt_geom::{hit_point, offset_ray_origin, BuildQuality, Bvh, Mesh, TriangleSampler};
use glam::{Vec2, Vec3};

fn random_soup(n: usize, scale: f32, seed: u64) -> Mesh {
    let mut rng = Pcg32::new(seed, 0);
    let mut p = Vec::new();
    let mut t = Vec::new();
    for i in 0..n {
        let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * scale;
        for _ in 0..3 {
            p.push(
                c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * scale * 0.2,
            );
        }
        t.push([3 * i as u32, 3 * i as u32 + 1, 3 * i as u32 + 2]);
    }
    Mesh::from_triangles(p, None, t)
}

fn brute_force(mesh: &Mesh, o: Vec3, d: Vec3) -> Option<(u32, f32)> {
    let mut best: Option<(u32, f32)> = None;
    for i in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.vertices(i).map(|v| v.as_dvec3());
        let (o, d) = (o.as_dvec3(), d.as_dvec3());
        let e1 = b - a;
        let e2 = c - a;
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det.abs() < 1e-300 {
            continue;
        }
        let s = o - a;
        let u = s.dot(pv) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        if u >= 0.0
            && v >= 0.0
            && u + v <= 1.0
            && t > 0.0
            && best.is_none_or(|(_, bt)| (t as f32) < bt)
        {
            best = Some((i as u32, t as f32));
        }
    }
    best
}

#[test]
fn closest_hit_matches_brute_force_for_every_preset_and_scale() {
    for (scale, seed) in [(1.0f32, 1u64), (1e-4, 2), (1e4, 3)] {
        let mesh = random_soup(300, scale, seed);
        for q in [BuildQuality::Fast, BuildQuality::Medium, BuildQuality::Slow] {
            let bvh = Bvh::build(&mesh, q);
            let mut rng = Pcg32::new(seed, 7);
            let mut agree = 0;
            let n = 400;
            for _ in 0..n {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * scale * 1.4
                    - 0.2 * scale;
                let d =
                    (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize();
                let ours = bvh.closest_hit(o, d, 0.0, f32::INFINITY);
                let bf = brute_force(&mesh, o, d);
                match (ours, bf) {
                    (None, None) => agree += 1,
                    (Some(h), Some((tri, t))) => {
                        assert!(
                            (h.t - t).abs() <= 1e-4 * t.max(scale),
                            "{q:?} t {} vs {t} (scale {scale}) tri {} vs {tri}",
                            h.t,
                            h.tri
                        );
                        if h.tri == tri {
                            agree += 1;
                            let p = hit_point(&mesh, &h);
                            assert!((p - (o + d * h.t)).length() <= 1e-4 * scale, "barycentrics");
                            assert!((h.ng - mesh.face_normal(tri as usize)).length() < 1e-4);
                        }
                    }
                    _ => {}
                }
            }
            // Ties on shared edges aside, all rays must agree.
            assert!(agree >= n - 2, "{q:?} scale {scale}: {agree}/{n} agree");
        }
    }
}

#[test]
fn batched_queries_equal_single_queries() {
    let mesh = random_soup(500, 1.0, 9);
    let bvh = Bvh::build(&mesh, BuildQuality::Medium);
    let mut rng = Pcg32::new(4, 4);
    let rays: Vec<(Vec3, Vec3)> = (0..3000)
        .map(|_| {
            (
                Vec3::splat(0.5),
                (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize(),
            )
        })
        .collect();
    let batch = bvh.closest_hits(&rays);
    for (r, h) in rays.iter().zip(&batch) {
        assert_eq!(*h, bvh.closest_hit(r.0, r.1, 0.0, f32::INFINITY));
        assert_eq!(h.is_some(), bvh.occluded(r.0, r.1, f32::INFINITY));
        if let Some(h) = h {
            assert!(!bvh.occluded(r.0, r.1, h.t * 0.999));
        }
    }
}

/// Two parallel walls `gap` apart. Rays leaving wall A at grazing angles must neither hit A
/// again (acne) nor pass through wall B (leak), for walls near and far from the origin.
#[test]
fn offsets_prevent_acne_and_leaks_at_grazing_angles() {
    for (centre, size, gap) in [
        (0.0f32, 1.0f32, 1e-3f32),
        (0.0, 1.0, 2e-5),
        (100.0, 10.0, 1e-2),
        (-3.0, 0.5, 1e-3),
        (1e-4, 1e-4, 1e-8),
    ] {
        let c = Vec3::splat(centre);
        let quad = |z: f32| {
            vec![
                c + Vec3::new(-size, -size, z),
                c + Vec3::new(size, -size, z),
                c + Vec3::new(size, size, z),
                c + Vec3::new(-size, size, z),
            ]
        };
        let mut p = quad(0.0);
        p.extend(quad(gap));
        let mesh = Mesh::from_triangles(p, None, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]);
        let bvh = Bvh::build(&mesh, BuildQuality::Medium);
        let mut rng = Pcg32::new(11, 0);
        let (mut acne, mut leaks, mut n) = (0, 0, 0);
        for _ in 0..20_000 {
            // A point on wall A, found by a ray from below (as a renderer would).
            let xy = (Vec2::new(rng.next_f32(), rng.next_f32()) - 0.5) * size;
            let o = c + Vec3::new(xy.x, xy.y, -size);
            let Some(h) = bvh.closest_hit(o, Vec3::Z, 0.0, f32::INFINITY) else {
                continue;
            };
            assert!(h.tri < 2);
            let x = hit_point(&mesh, &h);
            let n_out = Vec3::Z; // leaving towards wall B
                                 // Grazing: elevation between 0.01° and 5°.
            let elev = (0.01 + 4.99 * rng.next_f32()).to_radians();
            let az = rng.next_f32() * std::f32::consts::TAU;
            let d = Vec3::new(elev.cos() * az.cos(), elev.cos() * az.sin(), elev.sin());
            let org = bvh.offset(x, n_out);
            if centre.abs() >= 1.0 {
                // At unit scale the scaled offset is the plain one.
                assert!((org - offset_ray_origin(x, n_out)).length() <= 8.0 * (org - x).length());
            }
            n += 1;
            match bvh.closest_hit(org, d, 0.0, f32::INFINITY) {
                Some(h2) if h2.tri < 2 => acne += 1,
                Some(_) => {}
                None => {
                    // Missed B: only allowed if it left through the side of the slab.
                    let t_b = (centre + gap - org.z) / d.z;
                    let pb = org + d * t_b;
                    if (pb.x - centre).abs() < size * 0.999 && (pb.y - centre).abs() < size * 0.999
                    {
                        leaks += 1;
                    }
                }
            }
        }
        assert!(n > 15_000);
        assert_eq!(acne, 0, "self-intersections at centre {centre}");
        assert_eq!(leaks, 0, "leaks through a {gap} m gap at centre {centre}");
    }
}

#[test]
fn uniform_area_sampling_follows_areas_and_stays_inside() {
    // Tiny, unit and huge triangles together.
    let p = vec![
        Vec3::ZERO,
        Vec3::new(1e-3, 0.0, 0.0),
        Vec3::new(0.0, 1e-3, 0.0),
        Vec3::ZERO,
        Vec3::X,
        Vec3::Y,
        Vec3::ZERO,
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 3.0),
    ];
    let mesh = Mesh::from_triangles(p, None, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
    let s = TriangleSampler::uniform_area(&mesh, &[0, 1, 2]).unwrap();
    let areas = [0.5e-6, 0.5, 4.5];
    let total: f64 = areas.iter().sum();
    let mut counts = [0usize; 3];
    let mut rng = Pcg32::new(5, 5);
    let n = 200_000;
    for _ in 0..n {
        let smp = s.sample(&mesh, rng.next_f32(), rng.next_2d());
        counts[smp.tri as usize] += 1;
        let [a, b, c] = mesh.vertices(smp.tri as usize);
        // Inside: barycentric areas add up.
        let area = |x: Vec3, y: Vec3, z: Vec3| 0.5 * (y - x).cross(z - x).length();
        let sum = area(smp.p, b, c) + area(a, smp.p, c) + area(a, b, smp.p);
        assert!((sum - area(a, b, c)).abs() <= 1e-4 * area(a, b, c) + 1e-12);
        assert!((smp.pdf_area - 1.0 / total as f32).abs() < 1e-5 * smp.pdf_area);
    }
    for k in 1..3 {
        let expected = areas[k] / total * n as f64;
        let sigma = (expected * (1.0 - areas[k] / total)).sqrt();
        assert!(
            (counts[k] as f64 - expected).abs() < 5.0 * sigma,
            "tri {k}: {} vs {expected}",
            counts[k]
        );
    }
    // The whole set sampled uniformly: the mean of x over the unit triangle is 1/3.
    let unit = TriangleSampler::uniform_area(&mesh, &[1]).unwrap();
    let mean: f32 = (0..n)
        .map(|_| unit.sample(&mesh, rng.next_f32(), rng.next_2d()).p.x)
        .sum::<f32>()
        / n as f32;
    assert!((mean - 1.0 / 3.0).abs() < 3e-3, "{mean}");
    assert!(TriangleSampler::weighted(&mesh, &[0], &[0.0]).is_none());
}

/// Axis-aligned rays, including directions with negative-zero components, hit flat and tilted
/// triangles from both sides (obvhs alone misses them).
#[test]
fn axis_aligned_rays_with_negative_zero_hit_from_both_sides() {
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 0.0, 0.5)];
    let flat = Mesh::from_triangles(p.clone(), None, vec![[0, 1, 2]]);
    let bvh = Bvh::build(&flat, BuildQuality::Medium);
    for (o, d) in [
        (Vec3::new(0.2, 0.2, 1.0), -Vec3::Z),
        (Vec3::new(0.2, 0.2, -1.0), Vec3::Z),
    ] {
        let h = bvh.closest_hit(o, d, 0.0, f32::INFINITY).expect("hit");
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!(bvh.occluded(o, d, 2.0));
        assert!((bvh.bare_traverse(o, d) - 1.0).abs() < 1e-6);
    }
    let upright = Mesh::from_triangles(p, None, vec![[0, 1, 3]]);
    let bvh = Bvh::build(&upright, BuildQuality::Medium);
    for (o, d) in [
        (Vec3::new(0.2, 1.0, 0.1), -Vec3::Y),
        (Vec3::new(0.2, -1.0, 0.1), Vec3::Y),
    ] {
        assert!(bvh.closest_hit(o, d, 0.0, f32::INFINITY).is_some(), "{d}");
    }
}
