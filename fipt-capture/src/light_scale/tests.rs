//! The estimate's unit ladder: bounds, the albedo prior, the flatness search, the filter.
use super::*;

/// Samples of two patches (albedo 0.8 and 0.3) lit by one light of radiance `l` through
/// D falling from 0.05 to 0.005 along them, plus light from the room A = `ambient`; all
/// radiances times `scale`.
fn room(l: f32, ambient: f32, scale: f32) -> Vec<Sample> {
    let mut out = vec![];
    for (patch, kd) in [(0u32, 0.8f32), (1, 0.3)] {
        for k in 0..200 {
            let d = 0.05 * 10f32.powf(-(k as f32) / 200.0);
            let shade = ambient + l * d;
            out.push(Sample {
                at: (0, k, patch as usize),
                patch,
                i: Vec3::splat(kd * shade * scale),
                a: Vec3::splat(ambient * scale),
                d: vec![d],
            });
        }
    }
    out
}

fn unpinned() -> Vec<LightEstimate> {
    vec![LightEstimate {
        triangles: 2,
        radiance: [0.0; 3],
        levels: 0.0,
        contrast: 0.0,
        pinned: false,
        range: [0.0, f32::INFINITY],
        chosen_by: String::new(),
    }]
}

#[test]
fn an_unpinned_light_is_bounded_and_set_by_the_brightest_surface() {
    let samples = room(10.0, 0.02, 1.0);
    let mut out = unpinned();
    bound_and_choose(&samples, &mut out, &[1.0], 1.0);
    let x = &out[0];
    // kd ≤ 0.95 on the 0.8 patch: L ≥ 10 · 0.8 / 0.95 (less the room's share).
    assert!(x.range[0] <= 10.0 && x.range[0] > 7.0, "{:?}", x.range);
    // kd ≥ 0.02 on the 0.3 patch: L ≤ 10 · 0.3 / 0.02.
    assert!(x.range[1] >= 10.0 && x.range[1] < 200.0, "{:?}", x.range);
    // The 0.8 patch read at KD_BRIGHT = 0.8: the true 10 (less the room's share).
    assert!((x.levels - 10.0).abs() < 0.5, "{}", x.levels);
    assert_eq!(x.chosen_by, "albedo");
}

#[test]
fn the_choice_scales_with_the_radiance_from_1e_minus_6_to_1e5() {
    for scale in [1e-6f32, 1e5] {
        let mut out = unpinned();
        bound_and_choose(&room(10.0, 0.02, scale), &mut out, &[scale], scale);
        assert!(
            (out[0].levels - 10.0).abs() < 0.5,
            "{scale}: {}",
            out[0].levels
        );
    }
}

/// Two lights of radiance 10 and 3 over two patches: a wall each light lights from one
/// end (their shares cross along it), a floor under the first with a two-tone texture,
/// and the room's light A everywhere; 3 % pixel noise. The flatness finds both radiances
/// within a step of its grid (×1.12) and says they are pinned.
#[test]
fn the_flatness_pins_two_lights_under_noise_and_texture() {
    let mut rng = Pcg32::new(5, 9);
    let (l, ambient) = ([10.0f32, 3.0], 0.05f32);
    let mut samples = vec![];
    for (patch, n) in [(0u32, 300usize), (1, 300)] {
        for k in 0..n {
            let t = k as f32 / n as f32;
            let (d, kd) = if patch == 0 {
                let d = [0.03 * (1.0 - t) + 0.001, 0.03 * t + 0.001];
                (d, 0.6)
            } else {
                let d = [0.05 * 10f32.powf(-2.0 * t), 0.0];
                (d, if (k / 20) % 2 == 0 { 0.2 } else { 0.5 })
            };
            let shade = ambient + l[0] * d[0] + l[1] * d[1];
            let noise = 1.0 + 0.03 * (2.0 * rng.next_f32() - 1.0) * 3f32.sqrt();
            samples.push(Sample {
                at: (0, k, patch as usize),
                patch,
                i: Vec3::splat(kd * shade * noise),
                a: Vec3::splat(ambient),
                d: d.to_vec(),
            });
        }
    }
    // The two-tone floor (quartiles ×2.5 apart) is one colour to the filter too.
    let (samples, _) = one_colour(samples, 1.0);
    assert_eq!(samples.len(), 600);
    let out = search(&samples, &[vec![0], vec![1]], 1.0, &[]);
    for (e, truth) in l.iter().enumerate() {
        let got = out[e].radiance[1];
        assert!(
            (got / truth).ln().abs() < 1.13f32.ln(),
            "light {e}: {got} for {truth}"
        );
        assert!(out[e].pinned, "light {e}: contrast {}", out[e].contrast);
    }
}

/// A mirror-like patch, whose pixels show a dark wall or a lamp whatever the light's
/// radiance, reads kd up to 8 at the true radiance: kept, its median asks the light to
/// be several times brighter than it is; left out as not one colour, the two diffuse
/// patches (kd 0.8 and 0.3 under a tenfold fall of the light's share) are kept and give
/// the light back.
#[test]
fn a_mirror_patch_neither_bounds_the_light_nor_is_kept() {
    let mut samples = room(10.0, 0.02, 1.0);
    let mut rng = Pcg32::new(3, 1);
    for k in 0..40 {
        let seen = if k % 2 == 0 { 0.03 } else { 4.0 };
        samples.push(Sample {
            at: (1, k, 9),
            patch: 9,
            i: Vec3::splat(seen * (1.0 + 0.5 * rng.next_f32())),
            a: Vec3::splat(0.02),
            d: vec![0.05],
        });
    }
    let mut kept_all = unpinned();
    bound_and_choose(&samples, &mut kept_all, &[1.0], 1.0);
    assert!(kept_all[0].range[0] > 30.0, "{:?}", kept_all[0].range);
    let (kept, mixed) = one_colour(samples, 1.0);
    assert_eq!(mixed, 1);
    assert_eq!(kept.len(), 400);
    assert!(kept.iter().all(|s| s.patch != 9));
    let mut out = unpinned();
    bound_and_choose(&kept, &mut out, &[1.0], 1.0);
    assert!((out[0].levels - 10.0).abs() < 0.5, "{}", out[0].levels);
    // Scaled from 1e-6 to 1e5, the same patches are kept.
    for scale in [1e-6f32, 1e5] {
        assert_eq!(one_colour(room(10.0, 0.02, scale), scale).0.len(), 400);
    }
}

#[test]
fn the_clip_level_bounds_from_below() {
    // Views that see the light clipped at 40 (after their gains) say it is brighter.
    let mut out = unpinned();
    bound_and_choose(&room(10.0, 0.02, 1.0), &mut out, &[40.0], 1.0);
    assert!(out[0].levels >= 40.0 - 1e-3 && out[0].range[0] >= 40.0 - 1e-3);
}

/// A floor under a wide ceiling no view saw: with the light field empty, the room's light A
/// at the floor reads the ceiling patch's mean (the fill); without a fill it read nothing (the
/// bias that left A at 0.59–0.82 of the truth on the kitchen's walls). Where the light field
/// holds radiance, it is read instead.
#[test]
fn the_room_light_reads_the_patch_mean_where_the_light_field_is_empty() {
    let p = Vec3::new;
    let positions = vec![
        p(-1.0, 0.0, -1.0),
        p(1.0, 0.0, -1.0),
        p(1.0, 0.0, 1.0),
        p(-1.0, 0.0, 1.0),
        p(-50.0, 1.0, -50.0),
        p(50.0, 1.0, -50.0),
        p(50.0, 1.0, 50.0),
        p(-50.0, 1.0, 50.0),
    ];
    let cube = Cube::around(positions.iter().copied(), 1.1).unwrap();
    let tris = vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]];
    let geometry = Geometry::new(fipt_geom::Mesh::from_triangles(positions, None, tris));
    let no_lights = std::collections::HashSet::new();
    let (o, n) = (p(0.0, 1e-3, 0.0), Vec3::Y);
    let a = |slf: &fipt_bake::slf::SurfaceLightField, fill: &[Vec3]| {
        gather(
            &geometry,
            slf,
            fill,
            &no_lights,
            o,
            n,
            &mut Pcg32::new(1, 2),
        )
    };
    let empty = SlfBuilder::with_fallback(cube, 8, 1).finish();
    let fill = [Vec3::ZERO, Vec3::ZERO, Vec3::splat(0.3), Vec3::splat(0.3)];
    // Nearly every cosine direction meets the ceiling (it spans ±50 at height 1).
    let filled = a(&empty, &fill);
    assert!(
        (filled - Vec3::splat(0.3)).abs().max_element() < 0.01,
        "{filled}"
    );
    assert_eq!(a(&empty, &[]), Vec3::ZERO);
    let mut seen = SlfBuilder::with_fallback(cube, 8, 1);
    for i in -10..=10 {
        for k in -10..=10 {
            seen.add(p(5.0 * i as f32, 1.0, 5.0 * k as f32), Vec3::splat(0.7));
        }
    }
    let read = a(&seen.finish(), &fill);
    assert!(
        (read - Vec3::splat(0.7)).abs().max_element() < 0.02,
        "{read}"
    );
}
