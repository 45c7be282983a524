//! Tests of the `dielectric_rule = "minimum"` choice: a minimum the halves bear out, the
//! midpoint where they split, the median of three on a deep curve and at the mirror end.
use super::*;
use crate::tests::{curve, lifted};

/// A half's profile whose dielectric minimum lies at candidate `k` of `curve`'s σ grid.
fn minimum_at(k: usize) -> RegionProfile {
    let mut row = vec![0.2, 0.15, 0.14, 0.13, 0.16];
    row[k] = 0.1;
    curve(vec![1.0; 5], row)
}

#[test]
fn the_minimum_rule_takes_a_dielectric_minimum_however_shallow_where_the_halves_agree() {
    let cfg = SearchConfig::default();
    assert_eq!(cfg.dielectric_rule, crate::DielectricRule::Minimum);
    // A wall's minimum 0.05 % below σ = 1 whose halves agree (0.5 and 0.4, the band): the
    // minimum, where the lifted rules lift it.
    let wall = curve(vec![1.0; 5], vec![0.2, 0.1003, 0.10000, 0.10002, 0.10005]);
    let near = RegionProfile {
        sigma: vec![0.02, 0.25, 0.4, 0.75, 1.0],
        ..curve(vec![1.0; 5], vec![0.2, 0.1003, 0.10000, 0.10002, 0.10005])
    };
    assert_eq!(
        choose(&wall, &cfg, false, Some([&wall, &near])).roughness,
        Some(0.5)
    );
    assert_eq!(choose(&wall, &cfg, false, None).roughness, Some(0.5));
    assert_ne!(
        choose(&wall, &lifted(), false, Some([&wall, &near])).roughness,
        Some(0.5)
    );
    // One half at σ = 1 (those views caught no highlight): still the minimum, which lies
    // below `split_halves_above`.
    let rough_half = curve(vec![1.0; 5], vec![0.2, 0.15, 0.12, 0.11, 0.10]);
    assert_eq!(
        choose(&wall, &cfg, false, Some([&rough_half, &wall])).roughness,
        Some(0.5)
    );
    // Both halves at σ = 1: neither reproduces the whole's minimum; the lifted rules decide.
    assert_eq!(
        choose(&wall, &cfg, false, Some([&rough_half, &rough_half])).roughness,
        choose(&wall, &lifted(), false, Some([&rough_half, &rough_half])).roughness
    );
    assert_ne!(
        choose(&wall, &cfg, false, Some([&rough_half, &rough_half])).roughness,
        Some(0.5)
    );
    // One half's minimum glossier by more than the band (0.25): noise placed it, and the
    // lifted rules decide (here no target: the curve is below `interior_gain`), as with
    // `lifted`; the choice records where each half put its minimum.
    let noise = curve(vec![1.0; 5], vec![0.2, 0.1000, 0.1020, 0.1004, 0.1010]);
    let c = choose(&wall, &cfg, false, Some([&wall, &noise]));
    assert_eq!(c.halves_sigma, Some([0.5, 0.25]));
    let disputed = c.roughness;
    assert_eq!(disputed, None);
    assert_eq!(
        disputed,
        choose(&wall, &lifted(), false, Some([&wall, &noise])).roughness
    );
    // σ = 1 at the minimum: σ = 1.
    assert_eq!(choose(&rough_half, &cfg, false, None).roughness, Some(1.0));
    // A mirror-end minimum (below `interior_sigma`: a diffuse lobe that is not the data's)
    // is left to the lifted rules: no σ.
    let mirror = curve(vec![1.0; 5], vec![0.100, 0.110, 0.120, 0.118, 0.113]);
    assert_eq!(choose(&mirror, &cfg, false, None).roughness, None);
    // Metals keep their tolerance rule.
    let metal = curve(vec![0.05, 0.0500, 0.0501, 0.06, 0.07], vec![1.0; 5]);
    let m = choose(&metal, &cfg, false, None);
    assert_eq!((m.metallic, m.roughness), (Some(1.0), Some(0.5)));
    // Too few pixels: no decision.
    let small = RegionProfile {
        pixels: 10,
        ..wall.clone()
    };
    assert_eq!(choose(&small, &cfg, false, None).roughness, None);
}

#[test]
fn a_rough_minimum_that_one_half_of_the_views_misses_takes_the_midpoint() {
    let cfg = SearchConfig::default();
    // A ceiling's minimum at σ 0.75, 0.5 % below σ = 1; one half of the views finds it,
    // the other finds σ = 1 (the halves 0.25 apart, more than the band).
    let ceiling = curve(vec![1.0; 5], vec![0.2, 0.15, 0.102, 0.1000, 0.1005]);
    let rough_half = curve(vec![1.0; 5], vec![0.2, 0.15, 0.12, 0.11, 0.10]);
    let c = choose(&ceiling, &cfg, false, Some([&ceiling, &rough_half]));
    assert_eq!(c.halves_sigma, Some([0.75, 1.0]));
    assert_eq!(c.roughness, Some(0.875));
    assert_eq!(c.metallic, Some(0.0));
    // Halves that agree, or none: the minimum.
    for halves in [Some([&ceiling, &ceiling]), None] {
        assert_eq!(choose(&ceiling, &cfg, false, halves).roughness, Some(0.75));
    }
    // Off: the minimum.
    let off = SearchConfig {
        split_halves_above: 0.0,
        ..SearchConfig::default()
    };
    assert_eq!(
        choose(&ceiling, &off, false, Some([&ceiling, &rough_half])).roughness,
        Some(0.75)
    );
    // At or above the threshold only: with it at 0.8 the minimum stays.
    let high = SearchConfig {
        split_halves_above: 0.8,
        ..SearchConfig::default()
    };
    assert_eq!(
        choose(&ceiling, &high, false, Some([&ceiling, &rough_half])).roughness,
        Some(0.75)
    );
}

#[test]
fn a_deep_minimum_the_halves_dispute_takes_the_median_of_the_three() {
    let cfg = SearchConfig::default();
    // A glossy box: its minimum at 0.25, σ = 1 60 % above it; one half agrees, the other
    // puts its minimum at the mirror end (more than the band glossier).
    let boxed = RegionProfile {
        pixels: 5000,
        ..curve(vec![1.0; 5], vec![0.2, 0.1, 0.12, 0.14, 0.16])
    };
    let mirror_half = curve(vec![1.0; 5], vec![0.09, 0.1, 0.12, 0.14, 0.16]);
    let c = choose(&boxed, &cfg, false, Some([&boxed, &mirror_half]));
    assert_eq!(c.halves_sigma, Some([0.25, 0.02]));
    assert_eq!((c.roughness, c.metallic), (Some(0.25), Some(0.0)));
    // Without the rule the lifted rules lift it (here to the roughest σ within 25 %).
    let off = SearchConfig {
        deep_median_gain: 0.0,
        ..SearchConfig::default()
    };
    assert_eq!(
        choose(&boxed, &off, false, Some([&boxed, &mirror_half])).roughness,
        Some(0.5)
    );
    // A small region (under 2,000 pixels): its halves are too noisy; the lifted rules.
    let small = RegionProfile {
        pixels: 1999,
        ..boxed.clone()
    };
    assert_eq!(
        choose(&small, &cfg, false, Some([&small, &mirror_half])).roughness,
        Some(0.5)
    );
    // Both halves rougher by more than the band: the median is the nearer of them.
    let (h2, h3) = (minimum_at(2), minimum_at(3));
    assert_eq!(
        choose(&boxed, &cfg, false, Some([&h3, &h2])).roughness,
        Some(0.5)
    );
    // Both halves at the mirror end: the median is no glossier than `interior_sigma`.
    assert_eq!(
        choose(&boxed, &cfg, false, Some([&mirror_half, &mirror_half])).roughness,
        Some(cfg.interior_sigma)
    );
    // A shallow curve (σ = 1 under 5 % above its minimum) keeps the lifted rules.
    let faint = RegionProfile {
        pixels: 5000,
        ..curve(vec![1.0; 5], vec![0.2, 0.1, 0.101, 0.102, 0.103])
    };
    assert_eq!(
        choose(&faint, &cfg, false, Some([&faint, &mirror_half])).roughness,
        choose(&faint, &off, false, Some([&faint, &mirror_half])).roughness
    );
}

#[test]
fn a_deep_mirror_end_minimum_that_a_half_finds_a_lobe_for_takes_the_median_not_none() {
    let cfg = SearchConfig::default();
    // A lamp pole: the minimum at the mirror end, σ = 1 10 % above it (within the 25 %
    // tolerance, so the lifted rules give no target and the training reads it rough).
    let pole = RegionProfile {
        pixels: 5000,
        ..curve(vec![1.0; 5], vec![0.100, 0.110, 0.112, 0.111, 0.110])
    };
    let (mirror, lobe, rough_lobe) = (minimum_at(0), minimum_at(1), minimum_at(2));
    let choose_with = |p: &RegionProfile, h: [&RegionProfile; 2], cfg: &SearchConfig| {
        choose(p, cfg, false, Some(h)).roughness
    };
    // One half finds a lobe at 0.25, the other the mirror end: the median is the mirror
    // end, held at `interior_sigma`.
    assert_eq!(
        choose_with(&pole, [&lobe, &mirror], &cfg),
        Some(cfg.interior_sigma)
    );
    // Both halves find one (0.25, 0.5): the median is the glossier half.
    assert_eq!(choose_with(&pole, [&rough_lobe, &lobe], &cfg), Some(0.25));
    // Both halves at the mirror end, no halves, a small region, a shallow curve, the rule
    // off: no target, as before.
    assert_eq!(choose_with(&pole, [&mirror, &mirror], &cfg), None);
    assert_eq!(choose(&pole, &cfg, false, None).roughness, None);
    let small = RegionProfile {
        pixels: 1999,
        ..pole.clone()
    };
    assert_eq!(choose_with(&small, [&lobe, &mirror], &cfg), None);
    let shallow = RegionProfile {
        pixels: 5000,
        ..curve(vec![1.0; 5], vec![0.100, 0.102, 0.103, 0.103, 0.104])
    };
    assert_eq!(choose_with(&shallow, [&lobe, &mirror], &cfg), None);
    let off = SearchConfig {
        deep_median_gain: 0.0,
        ..SearchConfig::default()
    };
    assert_eq!(choose_with(&pole, [&lobe, &mirror], &off), None);
}
