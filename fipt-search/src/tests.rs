//! Tests of the material search: the fitted profile, the choice and its rules, outlines,
//! the settings' ranges.
use super::*;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{DEFAULT_LEVELS, NUM_LEVELS};

/// The search's settings with the lifted dielectric rules (`dielectric_rule = "lifted"`), which
/// these tests check.
pub(crate) fn lifted() -> SearchConfig {
    SearchConfig {
        dielectric_rule: crate::DielectricRule::Lifted,
        ..SearchConfig::default()
    }
}

/// Views rendered by the factorised model itself at (σ, m) with a base colour per cell:
/// random shadings per pixel, 8 views × 64 pixels, 16 cells of 32 pixels each.
fn scene(sigma: f32, m: f32) -> (Vec<SearchPixel>, Vec<ViewShadings>, Vec<Image>) {
    let mut rng = Pcg32::new(3, 7);
    let base: Vec<Rgb> = (0..16)
        .map(|_| {
            Vec3::new(
                0.2 + 0.7 * rng.next_f32(),
                0.2 + 0.7 * rng.next_f32(),
                0.2 + 0.7 * rng.next_f32(),
            )
        })
        .collect();
    rendered(&mut rng, m, &|cell| (base[cell as usize], sigma))
}

/// Views rendered by the factorised model at metallic `m`, `material(cell)` giving each
/// cell's base colour and σ: random shadings per pixel (from `rng`), 8 views × 64 pixels, 16
/// cells of 32 pixels each, one region.
pub(crate) fn rendered(
    rng: &mut Pcg32,
    m: f32,
    material: &dyn Fn(u32) -> (Rgb, f32),
) -> (Vec<SearchPixel>, Vec<ViewShadings>, Vec<Image>) {
    let mut u = || rng.next_f32();
    let (mut pixels, mut shadings, mut images) = (vec![], vec![], vec![]);
    for v in 0..8u32 {
        let mut sh = ViewShadings::zeros(8, 8, DEFAULT_LEVELS);
        let mut img = Image::new(8, 8);
        for i in 0..64 {
            sh.valid[i] = true;
            sh.ld[i] = Vec3::splat(0.5 + u());
            for l in 0..NUM_LEVELS {
                // View-dependent specular shadings that differ between levels.
                sh.ls0[i][l] = Vec3::splat(0.2 + 3.0 * u() * (1.0 - l as f32 / 6.0));
                sh.ls1[i][l] = Vec3::splat(0.05 * u());
            }
            let cell = ((v as usize * 64 + i) % 16) as u32;
            let (base, sigma) = material(cell);
            let (b, c) = linear_terms(&sh, i, sigma, m);
            img.data[i] = base * b + c;
            pixels.push(SearchPixel {
                view: v,
                pixel: i as u32,
                region: 0,
                cell,
                clipped: false,
            });
        }
        shadings.push(sh);
        images.push(img);
    }
    (pixels, shadings, images)
}

#[test]
fn the_fitted_profile_is_zero_at_the_truth_and_the_choice_finds_it() {
    let grid: Vec<f32> = DEFAULT_LEVELS.to_vec();
    for (sigma, m) in [(0.412, 1.0), (0.216, 0.0), (1.0, 0.0)] {
        let (px, sh, img) = scene(sigma, m);
        let p = &profile(&px, &sh, &img, 1, &grid, &[0.0, 1.0], Albedo::Fitted)[0];
        let mi = usize::from(m == 1.0);
        let si = grid.iter().position(|&s| s == sigma).unwrap();
        assert!(
            p.cost[mi][si] < 1e-10,
            "({sigma}, {m}): cost at the truth {}",
            p.cost[mi][si]
        );
        for (k, row) in p.cost.iter().enumerate() {
            for (j, &c) in row.iter().enumerate() {
                if (k, j) != (mi, si) {
                    assert!(
                        c > 1e-6,
                        "({sigma}, {m}): candidate ({k}, {j}) also fits: {c}"
                    );
                }
            }
        }
        let cfg = SearchConfig {
            min_pixels: 1,
            ..lifted()
        };
        let c = choose(p, &cfg, false, None);
        assert_eq!(c.metallic, Some(m));
        // Each its own σ; a dielectric at σ = 1 by `rough_band` (without it, none: the
        // training decides).
        assert_eq!(c.roughness, Some(sigma), "({sigma}, {m})");
        let no_band = SearchConfig {
            rough_band: 0.0,
            ..cfg.clone()
        };
        assert_eq!(
            choose(p, &no_band, false, None).roughness,
            (sigma < 1.0).then_some(sigma),
            "({sigma}, {m})"
        );
    }
}

pub(crate) fn curve(metal: Vec<f64>, dielectric: Vec<f64>) -> RegionProfile {
    RegionProfile {
        region: 0,
        pixels: 1000,
        cells: 10,
        sigma: vec![0.02, 0.25, 0.5, 0.75, 1.0],
        metallic: vec![0.0, 1.0],
        cost: vec![dielectric, metal],
        gain: vec![],
        one_colour: vec![],
    }
}

#[test]
fn the_choice_needs_its_margins_and_both_halves_of_the_views() {
    let cfg = lifted();
    // A mirror-end dielectric minimum 13 % below σ = 1 (the studio's diffuse box): no σ.
    let p = curve(vec![1.0; 5], vec![0.100, 0.110, 0.120, 0.118, 0.113]);
    assert_eq!(choose(&p, &cfg, false, None).roughness, None);
    // An interior minimum 14 % below σ = 1: σ at the minimum.
    let p = curve(vec![1.0; 5], vec![0.110, 0.100, 0.105, 0.110, 0.114]);
    assert_eq!(
        choose(&p, &cfg, false, Some([&p, &p])).roughness,
        Some(0.25)
    );
    // A shallow interior minimum (a wall, 1 % below σ = 1): the roughest within a quarter
    // of that 1 %, when both halves of the views agree; below 0.1 % (the diffuse box)
    // none.
    let wall = curve(vec![1.0; 5], vec![0.2, 0.1000, 0.1001, 0.1004, 0.1010]);
    let other = curve(vec![1.0; 5], vec![0.2, 0.1003, 0.1000, 0.1004, 0.1010]);
    assert_eq!(
        choose(&wall, &cfg, false, Some([&wall, &other])).roughness,
        Some(0.5)
    );
    // Noise: one half's minimum (σ 0.25) costs more than σ = 1 on the other half. The
    // minimum is disputed: the midpoint of the interior rule's 0.5 and σ = 1
    // (`hedge_disputed`); none without it.
    let noise = curve(vec![1.0; 5], vec![0.2, 0.1020, 0.1000, 0.1004, 0.1010]);
    assert_eq!(
        choose(&wall, &cfg, false, Some([&wall, &noise])).roughness,
        Some(0.75)
    );
    let no_hedge = SearchConfig {
        hedge_disputed: false,
        ..cfg.clone()
    };
    assert_eq!(
        choose(&wall, &no_hedge, false, Some([&wall, &noise])).roughness,
        None
    );
}

#[test]
fn a_capture_half_holds_out_within_the_band_and_near_one_means_one() {
    let cfg = lifted();
    // Pose error and pixel noise (a capture): one half barely sees the gloss, its minimum
    // lies 0.01 % below σ = 1 but where the other half's does (σ 0.5 and 0.6, within
    // `held_out_band`): it holds out. Half a range apart (0.25 and 0.6) it does not, nor
    // with the band off.
    let fine = |c: Vec<f64>| RegionProfile {
        sigma: vec![0.02, 0.25, 0.5, 0.6, 1.0],
        ..curve(vec![1.0; 5], c)
    };
    let whole = fine(vec![0.2, 0.1003, 0.1000, 0.1001, 0.1010]);
    let flat = fine(vec![0.2, 0.10012, 0.10011, 0.10010, 0.10011]);
    let apart = fine(vec![0.2, 0.10010, 0.10011, 0.10012, 0.10013]);
    assert_eq!(
        choose(&whole, &cfg, false, Some([&whole, &flat])).roughness,
        Some(0.6)
    );
    let no_band = SearchConfig {
        held_out_band: 0.0,
        ..cfg.clone()
    };
    // Not held out: the midpoint of the interior rule's 0.6 and σ = 1, or none without
    // `hedge_disputed`.
    let no_hedge = |c: &SearchConfig| SearchConfig {
        hedge_disputed: false,
        ..c.clone()
    };
    for (c, half) in [(&cfg, &apart), (&no_band, &flat)] {
        let disputed = choose(&whole, c, false, Some([&whole, half])).roughness;
        assert!((disputed.unwrap() - 0.8).abs() < 1e-6, "{disputed:?}");
        assert_eq!(
            choose(&whole, &no_hedge(c), false, Some([&whole, half])).roughness,
            None
        );
    }
    // Halves that agree within a band of σ = 1 (a diffuse box, σ 1: 0.95 and 0.9) are σ = 1
    // by the same yardstick: no interior target, but σ = 1 by `rough_band` (none without).
    let near_one = |c: Vec<f64>| RegionProfile {
        sigma: vec![0.02, 0.5, 0.9, 0.95, 1.0],
        ..curve(vec![1.0; 5], c)
    };
    let whole = near_one(vec![0.2, 0.15, 0.1002, 0.1000, 0.1010]);
    let flat = near_one(vec![0.2, 0.15, 0.10010, 0.10011, 0.10011]);
    assert_eq!(
        choose(&whole, &cfg, false, Some([&whole, &flat])).roughness,
        Some(1.0)
    );
    // Without `rough_band` the minimum at 0.95 is a disputed one (midway to σ = 1); without
    // the hedge too, none.
    let no_rough = SearchConfig {
        rough_band: 0.0,
        ..cfg.clone()
    };
    assert_eq!(
        choose(&whole, &no_rough, false, Some([&whole, &flat])).roughness,
        Some(0.975)
    );
    assert_eq!(
        choose(&whole, &no_hedge(&no_rough), false, Some([&whole, &flat])).roughness,
        None
    );
}

#[test]
fn a_lacquer_half_holds_out_and_the_held_out_check_decides() {
    let cfg = lifted();
    let wall = curve(vec![1.0; 5], vec![0.2, 0.1000, 0.1001, 0.1004, 0.1010]);
    // A lacquer (σ 0.12): the whole's minimum is interior, one half's lies below
    // `interior_sigma` (0.08) but above the mirror end: it holds out. A half whose minimum is
    // the mirror end does not.
    let lacquer = |c: Vec<f64>| RegionProfile {
        sigma: vec![0.02, 0.08, 0.12, 0.5, 1.0],
        ..curve(vec![1.0; 5], c)
    };
    // Held out, within 2 % of the minimum (0.12); otherwise within 25 % (0.5).
    let whole = lacquer(vec![0.1003, 0.1001, 0.1000, 0.1150, 0.1420]);
    let low = lacquer(vec![0.1003, 0.1000, 0.1001, 0.1150, 0.1420]);
    let end = lacquer(vec![0.1000, 0.1001, 0.1002, 0.1150, 0.1420]);
    assert_eq!(
        choose(&whole, &cfg, false, Some([&whole, &low])).roughness,
        Some(0.12)
    );
    assert_eq!(
        choose(&whole, &cfg, false, Some([&whole, &end])).roughness,
        Some(0.5)
    );
    // Without halves the held-out check cannot pass (the minimum is disputed: midway to
    // σ = 1); without the check the curve decides.
    assert_eq!(choose(&wall, &cfg, false, None).roughness, Some(0.75));
    let trusting = SearchConfig {
        held_out: false,
        ..lifted()
    };
    assert_eq!(choose(&wall, &trusting, false, None).roughness, Some(0.5));
    let p = curve(vec![1.0; 5], vec![0.2, 0.1, 0.1, 0.1, 0.10003]);
    assert_eq!(choose(&p, &trusting, false, None).roughness, None);
    // The old rule (5 %, the metal tolerance) keeps the wall at σ = 1.
    let old = SearchConfig {
        interior_gain: 0.05,
        interior_tolerance: 1.0,
        ..trusting
    };
    assert_eq!(choose(&wall, &old, false, None).roughness, None);
}

#[test]
fn a_strong_minimum_is_kept_and_a_metal_by_hysteresis() {
    let cfg = lifted();
    // A strong minimum at the mirror end: the roughest within 25 %.
    let p = curve(vec![1.0; 5], vec![0.100, 0.120, 0.200, 0.300, 0.300]);
    assert_eq!(choose(&p, &cfg, false, None).roughness, Some(0.25));
    // A strong interior minimum (a glossy floor, 3× below σ = 1) that holds out: within 2 %
    // of it, where the 25 % rule (`interior_always = false`, or no held-out views) took the
    // next level, 10 % above it.
    let floor = curve(vec![1.0; 5], vec![0.2, 0.100, 0.110, 0.200, 0.300]);
    assert_eq!(
        choose(&floor, &cfg, false, Some([&floor, &floor])).roughness,
        Some(0.25)
    );
    assert_eq!(choose(&floor, &cfg, false, None).roughness, Some(0.5));
    // A lacquer: the next level 1.5 % above the deep minimum. Within `interior_cap` (0.5 %)
    // it stays at the minimum; the old cap of 2 % took it a level rougher.
    let lacquer = curve(vec![1.0; 5], vec![0.3, 0.100, 0.1015, 0.200, 0.300]);
    let held = Some([&lacquer, &lacquer]);
    assert_eq!(choose(&lacquer, &cfg, false, held).roughness, Some(0.25));
    let old_cap = SearchConfig {
        interior_cap: 0.02,
        ..lifted()
    };
    assert_eq!(choose(&lacquer, &old_cap, false, held).roughness, Some(0.5));
    let loose = SearchConfig {
        interior_always: false,
        ..lifted()
    };
    assert_eq!(
        choose(&floor, &loose, false, Some([&floor, &floor])).roughness,
        Some(0.5)
    );
    // Metal by 15 %: not metal, unless it was (then only a 20 % better dielectric turns it).
    let p = curve(vec![0.3, 0.085, 0.3, 0.3, 0.3], vec![0.1; 5]);
    assert_eq!(choose(&p, &cfg, false, None).metallic, Some(0.0));
    let c = choose(&p, &cfg, true, None);
    assert_eq!((c.metallic, c.roughness), (Some(1.0), Some(0.25)));
    let p = curve(vec![0.3, 0.13, 0.3, 0.3, 0.3], vec![0.1; 5]);
    assert_eq!(choose(&p, &cfg, true, None).metallic, Some(0.0));
    // Too few pixels: no target at all.
    let mut p = curve(vec![0.01; 5], vec![0.1; 5]);
    p.pixels = 10;
    let c = choose(&p, &cfg, false, None);
    assert_eq!((c.roughness, c.metallic), (None, None));
}

#[test]
fn region_edges_are_the_pixels_beside_another_region_or_none() {
    // 4×3: region 0 on the left half, 1 on the right, the top-right pixel unlabelled.
    let ids = [
        Some(0),
        Some(0),
        Some(1),
        None, //
        Some(0),
        Some(0),
        Some(1),
        Some(1), //
        Some(0),
        Some(0),
        Some(1),
        Some(1),
    ];
    let edge: Vec<bool> = (0..12)
        .map(|i| on_region_edge(&ids, 4, i, &|_| true))
        .collect();
    #[rustfmt::skip]
    let want = [
        false, true, true, true,
        false, true, true, true,
        false, true, true, false,
    ];
    assert_eq!(edge, want);
    assert!(!on_region_edge(&ids, 0, 0, &|_| true));
    // Only neighbours that count: here the unlabelled pixel alone.
    let by_none: Vec<usize> = (0..12)
        .filter(|&i| on_region_edge(&ids, 4, i, &|j| ids[j].is_none()))
        .collect();
    assert_eq!(by_none, [2, 6, 7]);
}

#[test]
fn settings_out_of_range_are_refused_with_their_key() {
    assert_eq!(SearchConfig::default().validate(), Ok(()));
    assert_eq!(SearchConfig::off().validate(), Ok(()));
    let refused = |c: SearchConfig, key: &str| {
        let e = c.validate().unwrap_err();
        assert!(e.starts_with(&format!("search.{key} = ")), "{e}");
    };
    let d = SearchConfig::default;
    refused(
        SearchConfig {
            edge_contrast: -1.0,
            ..d()
        },
        "edge_contrast",
    );
    refused(
        SearchConfig {
            interior_gain: f32::NAN,
            ..d()
        },
        "interior_gain",
    );
    refused(
        SearchConfig {
            split_halves_above: 1.5,
            ..d()
        },
        "split_halves_above",
    );
    refused(
        SearchConfig {
            deep_median_gain: -0.1,
            ..d()
        },
        "deep_median_gain",
    );
    refused(
        SearchConfig {
            interior_tolerance: 2.0,
            ..d()
        },
        "interior_tolerance",
    );
    refused(
        SearchConfig {
            metal_margin: -0.1,
            ..d()
        },
        "metal_margin",
    );
    refused(
        SearchConfig {
            roughness_steps: 1,
            ..d()
        },
        "roughness_steps",
    );
    refused(
        SearchConfig {
            roughness_steps: 1_000_000,
            ..d()
        },
        "roughness_steps",
    );
    refused(
        SearchConfig {
            metallic: vec![],
            ..d()
        },
        "metallic",
    );
    refused(
        SearchConfig {
            metallic: vec![0.0, 1.5],
            ..d()
        },
        "metallic",
    );
    refused(
        SearchConfig {
            cell_footprints: 0.0,
            ..d()
        },
        "cell_footprints",
    );
    refused(
        SearchConfig {
            mesh_angle_deg: 270.0,
            ..d()
        },
        "mesh_angle_deg",
    );
}

#[test]
fn faint_gloss_reads_no_glossier_than_one_colour_and_always_gets_a_target() {
    let cfg = SearchConfig {
        one_colour_below: 0.02,
        ..lifted()
    };
    let with_one = |p: RegionProfile, one: Vec<f64>| RegionProfile {
        one_colour: one,
        ..p
    };
    // A rough wall: per cell its minimum is at 0.5, 0.2 % below σ = 1 (faint); with one
    // colour the minimum is at 0.75, 1 % below σ = 1.
    let wall = with_one(
        curve(vec![1.0; 5], vec![0.2, 0.1001, 0.1000, 0.1001, 0.1002]),
        vec![0.3, 0.1008, 0.1004, 0.1000, 0.1010],
    );
    // Halves that agree: the per-cell rule says 0.5, which the one-colour curve rejects (0.4 %
    // above its minimum, more than `interior_gain`): 0.75, the glossiest σ it admits. Halves that disagree, or none: the per-cell rules leave no target (the training
    // took such walls to σ ≈ 1 or below); the one-colour curve's rule gives one, the
    // roughest within a quarter of its 1 %: 0.75 again.
    let apart = curve(vec![1.0; 5], vec![0.2, 0.1000, 0.1003, 0.1004, 0.1002]);
    for halves in [Some([&wall, &wall]), Some([&wall, &apart]), None] {
        assert_eq!(choose(&wall, &cfg, false, halves).roughness, Some(0.75));
    }
    let off = SearchConfig {
        hedge_disputed: false,
        ..lifted()
    };
    assert_eq!(
        choose(&wall, &off, false, Some([&wall, &apart])).roughness,
        None
    );
    // By default the disputed minimum (0.5) takes the midpoint to σ = 1 instead.
    assert_eq!(
        choose(&wall, &lifted(), false, Some([&wall, &apart])).roughness,
        Some(0.75)
    );
    assert_eq!(
        choose(&wall, &off, false, Some([&wall, &wall])).roughness,
        Some(0.5)
    );
    // A per-cell answer the one-colour curve admits (0.5, within 0.1 % of its minimum at
    // 0.75) is kept.
    let admits = with_one(wall.clone(), vec![0.3, 0.1008, 0.10005, 0.1000, 0.1010]);
    assert_eq!(
        choose(&admits, &cfg, false, Some([&admits, &admits])).roughness,
        Some(0.5)
    );
    // Never glossier than the per-cell rule: a one-colour minimum at 0.25 leaves its 0.5.
    let low = with_one(wall.clone(), vec![0.3, 0.1000, 0.1004, 0.1006, 0.1010]);
    assert_eq!(
        choose(&low, &cfg, false, Some([&low, &low])).roughness,
        Some(0.5)
    );
    // A flat one-colour curve whose minimum is σ = 1: σ = 1.
    let plaster = with_one(wall.clone(), vec![0.3, 0.1003, 0.1002, 0.1001, 0.1000]);
    assert_eq!(choose(&plaster, &cfg, false, None).roughness, Some(1.0));
    // The one-colour curve is not read when its minimum is at the mirror end (a diffuse lobe
    // that is not the data's) or when it is deep (two colours in one patch, not a lobe):
    // here the disagreeing halves leave the disputed minimum's midpoint, as without it.
    for one in [
        vec![0.1000, 0.1004, 0.1006, 0.1008, 0.1010],
        vec![0.3, 0.1000, 0.1100, 0.1200, 0.1300],
    ] {
        let p = with_one(wall.clone(), one);
        assert_eq!(
            choose(&p, &cfg, false, Some([&p, &apart])).roughness,
            Some(0.75)
        );
    }
    // Gloss a colour per cell sees (3 % below σ = 1) is decided as before: the one-colour
    // curve is not read.
    let glossy = with_one(
        curve(vec![1.0; 5], vec![0.2, 0.1000, 0.1010, 0.1020, 0.1030]),
        vec![0.3, 0.1008, 0.1004, 0.1000, 0.1010],
    );
    assert_eq!(
        choose(&glossy, &cfg, false, Some([&glossy, &glossy])).roughness,
        Some(0.25)
    );
}

#[test]
fn small_outlines_are_those_under_the_share() {
    // An 8×8 view: region 0 a 6×6 square (20 of its 36 pixels on its outline), region 1 the
    // ring around it, region 2 absent, a pixel of no region (u32::MAX) in the ring.
    let (w, none) = (8, u32::MAX);
    let mut ids: Vec<u32> = (0..64)
        .map(|i| u32::from(!(1..7).contains(&(i % w)) || !(1..7).contains(&(i / w))))
        .collect();
    ids[0] = none;
    let views = vec![ids.clone(), ids];
    let widths = [w, w];
    let shares = outline_shares(&views, &widths, 3, none);
    assert_eq!(shares[0], Some(20.0 / 36.0));
    assert_eq!(shares[1], Some(1.0));
    assert_eq!(shares[2], None);
    // Region 0: every pixel of the 6×6 square's border (20 of 36) touches the ring.
    assert_eq!(small_outlines(&shares, 0.56), vec![true, false, false]);
    assert_eq!(small_outlines(&shares, 0.55), vec![false, false, false]);
    // The ring: all 27 of its pixels... those next to the square or to the pixel of none.
    assert_eq!(small_outlines(&shares, 1.0), vec![true, true, false]);
    assert_eq!(small_outlines(&shares, 0.0), vec![false; 3]);
}

#[test]
fn a_clipped_pixel_is_a_lower_bound_and_left_out_of_the_fit() {
    let clip = Vec3::splat(1.0);
    let img = Image {
        width: 1,
        height: 1,
        data: vec![clip],
    };
    let p = SearchPixel {
        view: 0,
        pixel: 0,
        region: 0,
        cell: 0,
        clipped: true,
    };
    let o = Observed::of_pixel(&p, std::slice::from_ref(&img));
    // Above the clip level: no cost; below: the squared sRGB error, as unclipped.
    assert_eq!(o.sq_err(Vec3::splat(5.0)), 0.0);
    let below = Vec3::new(0.25, 2.0, 1.0);
    let exact = Observed::of(clip);
    let d = fipt_core::color::srgb_oetf(0.25) - fipt_core::color::srgb_oetf(1.0);
    assert!((o.sq_err(below) - (d * d) as f64).abs() < 1e-9);
    assert!(exact.sq_err(below) > o.sq_err(below));
    // The base colour's fit does not see it.
    let mut fit = crate::AlbedoFit::default();
    fit.add_terms(&o, Vec3::ONE, Vec3::ZERO);
    assert_eq!(fit.albedo(), Vec3::ZERO);
    fit.add_terms(&Observed::of(Vec3::splat(0.5)), Vec3::ONE, Vec3::ZERO);
    assert!((fit.albedo() - Vec3::splat(0.5)).abs().max_element() < 1e-6);
}

#[test]
fn silhouettes_are_occlusions_not_creases() {
    use fipt_shading::records::HitPoint;
    // A 6×6 view from the origin looking down +z: region 1 a 2×2 square at depth 1 in front of
    // region 0 at depth 2 (left half) and region 2 at depth 2 (right half: a crease with 0).
    let (w, eye) = (6, Vec3::ZERO);
    let square = |x: usize, y: usize| (2..4).contains(&x) && (2..4).contains(&y);
    let ids: Vec<u32> = (0..36)
        .map(|i| match (i % w, i / w) {
            (x, y) if square(x, y) => 1,
            (x, _) if x < 3 => 0,
            _ => 2,
        })
        .collect();
    let hits: Vec<Option<HitPoint>> = (0..36)
        .map(|i| {
            let (x, y) = ((i % w) as f32 * 0.01, (i / w) as f32 * 0.01);
            let z = if ids[i] == 1 { 1.0 } else { 2.0 };
            Some(HitPoint::new(Vec3::new(x, y, z), 0))
        })
        .collect();
    let sil = |i: usize, gap: f32| on_silhouette(&ids, &hits, w, i, eye, gap, &|_| true);
    // The square's pixels and the ring around it lie across the occlusion.
    for i in [14, 15, 20, 21, 7, 28, 13, 22] {
        assert!(sil(i, 0.05), "pixel {i}");
    }
    // Along the crease between regions 0 and 2 (x = 2 | 3, rows 0 and 5), at one depth: not.
    for i in [2, 3, 32, 33] {
        assert!(!sil(i, 0.05), "pixel {i}");
    }
    // A gap wider than the depth step sees no occlusion; a pixel without a neighbour in
    // another region is never one; a neighbour of another region without a hit makes one (a
    // neighbour of its own region does not), and a pixel without a hit is none.
    assert!(!sil(14, 1.5));
    assert!(!sil(0, 0.05));
    let mut holed = hits.clone();
    holed[2] = None;
    let holed_sil = |i: usize| on_silhouette(&ids, &holed, w, i, eye, 0.05, &|_| true);
    assert!(holed_sil(3));
    assert!(!holed_sil(1));
    assert!(!holed_sil(2));
    // Only neighbours that `counts` (e.g. of another brightness) make one.
    assert!(!on_silhouette(&ids, &hits, w, 14, eye, 0.05, &|_| false));
    assert!(on_silhouette(&ids, &hits, w, 14, eye, 0.05, &|j| j == 8));
    assert!(!on_silhouette(&ids, &hits, w, 14, eye, 0.05, &|j| j == 15));
}
