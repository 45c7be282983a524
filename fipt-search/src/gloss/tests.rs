//! The gloss split's tests: planes of one or two finishes rendered by the factorised model.
use super::*;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{DEFAULT_LEVELS, NUM_LEVELS};

/// One region of 20 × 20 cells on a plane, one colour with a little variation, its σ
/// `sigma(x)` by the cell's column; each cell seen by 12 views, 3 pixels each, of random
/// shadings (the factorised model renders the views), with relative noise `noise`.
fn plane(sigma: &dyn Fn(i32) -> f32, noise: f32, seed: u64) -> Plane {
    plane_of(sigma, noise, seed, 3, false)
}

type Plane = (
    Vec<SearchPixel>,
    Vec<[i32; 3]>,
    Vec<ViewShadings>,
    Vec<Image>,
);

/// [`plane`] with `per` pixels of each cell in each view; with `same_light`, a cell's
/// pixels in one view have the same shadings (neighbouring pixels), and differ by noise.
fn plane_of(
    sigma: &dyn Fn(i32) -> f32,
    noise: f32,
    seed: u64,
    per: usize,
    same_light: bool,
) -> Plane {
    let mut rng = Pcg32::new(seed, 3);
    let (side, views) = (20i32, 12u32);
    let voxels: Vec<[i32; 3]> = (0..side * side).map(|c| [c % side, 0, c / side]).collect();
    let n = voxels.len() * per;
    let (mut pixels, mut shadings, mut images) = (vec![], vec![], vec![]);
    for v in 0..views {
        let mut sh = ViewShadings::zeros(n, 1, DEFAULT_LEVELS);
        let mut img = Image::new(n, 1);
        for i in 0..n {
            let cell = i / per;
            sh.valid[i] = true;
            if same_light && i % per != 0 {
                let first = i - i % per;
                (sh.ld[i], sh.ls0[i], sh.ls1[i]) = (sh.ld[first], sh.ls0[first], sh.ls1[first]);
            } else {
                sh.ld[i] = Vec3::splat(0.5 + rng.next_f32());
                for l in 0..NUM_LEVELS {
                    let u = rng.next_f32();
                    sh.ls0[i][l] = Vec3::splat(0.2 + 3.0 * u * (1.0 - l as f32 / 6.0));
                    sh.ls1[i][l] = Vec3::splat(0.05 * rng.next_f32());
                }
            }
            let base = Vec3::new(0.5, 0.4, 0.3) * (1.0 + 0.05 * rng.next_f32());
            let (b, c) = super::super::linear_terms(&sh, i, sigma(voxels[cell][0]), 0.0);
            let e = 1.0 + noise * (2.0 * rng.next_f32() - 1.0);
            img.data[i] = (base * b + c) * e;
            pixels.push(SearchPixel {
                view: v,
                pixel: i as u32,
                region: 0,
                cell: cell as u32,
                clipped: false,
            });
        }
        shadings.push(sh);
        images.push(img);
    }
    (pixels, voxels, shadings, images)
}

fn run(sigma: &dyn Fn(i32) -> f32, noise: f32) -> (ColourSplit, Vec<GlossCut>) {
    let (px, vox, sh, img) = plane(sigma, noise, 11);
    let grid: Vec<f32> = crate::sigma_grid(DEFAULT_LEVELS[0], 1.0, 50);
    let cfg = SplitConfig::default();
    gloss_split(ColourSplit::none(1), &px, &vox, &sh, &img, &grid, 10, &cfg)
}

#[test]
fn two_finishes_of_one_colour_divide_along_their_edge() {
    let (split, cuts) = run(&|x| if x < 8 { 0.25 } else { 0.65 }, 0.02);
    assert_eq!(split.sub, vec![Some(1)], "{cuts:?}");
    let c = &cuts[0];
    assert!((c.sigma[0] - 0.25).abs() < 0.05, "{c:?}");
    assert!((c.sigma[1] - 0.65).abs() < 0.05, "{c:?}");
    assert!(c.agreement > 0.9, "{c:?}");
    // Cells away from the edge are on their finish's side.
    for x in [0, 5, 11, 19] {
        let cell = 7 * 20 + x as usize;
        assert_eq!(split.side[cell], u8::from(x >= 8), "column {x}");
    }
}

/// The gloss split of a plane whose cells show 16 pixels in each view, which see the same
/// light and differ by `noise` (σ by column), per pixel or per view.
fn split_at(sigma: &dyn Fn(i32) -> f32, noise: f32, view_means: bool) -> Vec<GlossCut> {
    let (px, vox, sh, img) = plane_of(sigma, noise, 11, 16, true);
    let grid: Vec<f32> = crate::sigma_grid(DEFAULT_LEVELS[0], 1.0, 50);
    let cfg = SplitConfig {
        gloss_view_means: view_means,
        ..SplitConfig::default()
    };
    gloss_split(ColourSplit::none(1), &px, &vox, &sh, &img, &grid, 10, &cfg).1
}

#[test]
fn a_cuts_depth_per_view_is_not_drowned_by_the_pixels_noise() {
    let two = |x: i32| if x < 10 { 0.25 } else { 0.65 };
    // Per pixel, the noise makes most of each side's cost: the depth falls from several
    // times the gate to under the old one (0.25).
    let [quiet, noisy] = [0.05, 0.3].map(|n| split_at(&two, n, false)[0].clone());
    assert!(
        quiet.depth > 2.0 && noisy.depth < 0.25,
        "{quiet:?} {noisy:?}"
    );
    // Per view, the same cut stays far above the gate and divides.
    let per_view = split_at(&two, 0.3, true)[0].clone();
    assert!(
        per_view.depth > 3.0 * 0.6 && per_view.divided,
        "{per_view:?}"
    );
    assert!((per_view.sigma[0] - 0.25).abs() <= 0.04, "{per_view:?}");
    assert!((per_view.sigma[1] - 0.65).abs() <= 0.04, "{per_view:?}");
    // One finish under the same noise stays whole.
    for sigma in [0.3f32, 0.7] {
        let cuts = split_at(&|_| sigma, 0.3, true);
        assert!(cuts.iter().all(|c| !c.divided), "σ {sigma}: {cuts:?}");
    }
}

#[test]
fn a_colour_division_as_deep_per_view_as_a_gloss_cut_is_as_firm() {
    let two = |x: i32| if x < 10 { 0.25 } else { 0.65 };
    let grid: Vec<f32> = crate::sigma_grid(DEFAULT_LEVELS[0], 1.0, 50);
    let cfg = SplitConfig::default();
    // The colour divides the plane where its finish changes (column 10), or by rows,
    // which its finish does not follow.
    let by = |side: &dyn Fn(i32, i32) -> bool, sigma: &dyn Fn(i32) -> f32| {
        let (px, vox, sh, img) = plane_of(sigma, 0.3, 11, 16, true);
        let base = ColourSplit {
            sub: vec![Some(1)],
            side: vox.iter().map(|v| u8::from(side(v[0], v[2]))).collect(),
            deep_per_view: vec![],
        };
        gloss_split(base, &px, &vox, &sh, &img, &grid, 10, &cfg)
    };
    let (along, cuts) = by(&|x, _| x >= 10, &two);
    assert_eq!(along.sub, vec![Some(1)], "{cuts:?}");
    assert_eq!(cuts.len(), 1, "{cuts:?}");
    assert!(cuts[0].colour_stands && !cuts[0].divided, "{cuts:?}");
    assert_eq!(along.deep_per_view, vec![true], "{cuts:?}");
    // Colour sides across the finishes (by rows) each hold both: a shallow division, which
    // the gloss cut replaces; it is firm as the gloss cut, not as the colour.
    let (across, cuts) = by(&|_, z| z >= 10, &two);
    assert_eq!(cuts.len(), 1, "{cuts:?}");
    assert!(cuts[0].divided && !cuts[0].colour_stands, "{cuts:?}");
    assert_eq!(across.deep_per_view, vec![true], "{cuts:?}");
    let side = |cell: usize| across.side[cell];
    assert_ne!(
        side(7 * 20 + 2),
        side(7 * 20 + 17),
        "sides by column, not by row"
    );
}

#[test]
fn one_finish_with_noise_stays_whole() {
    for sigma in [0.3f32, 0.7, 1.0] {
        let (split, cuts) = run(&|_| sigma, 0.05);
        assert_eq!(split.sub, vec![None], "σ {sigma}: {cuts:?}");
    }
}

#[test]
fn cells_whose_own_evidence_is_noisy_follow_their_neighbours_to_the_edge() {
    let edge = 10;
    let (px, vox, sh, img) = plane(&|x| if x < edge { 0.25 } else { 0.65 }, 0.4, 5);
    let grid: Vec<f32> = crate::sigma_grid(DEFAULT_LEVELS[0], 1.0, 50);
    let mut by_cell: Vec<Vec<usize>> = vec![vec![]; vox.len()];
    for (j, p) in px.iter().enumerate() {
        by_cell[p.cell as usize].push(j);
    }
    let wanted = vec![true; vox.len()];
    let curves = cell_curves(&by_cell, &wanted, &px, &sh, &img, &grid, Views::All, false);
    let cells = RegionCells::new((0..vox.len()).collect(), &vox, &by_cell, 3);
    let right = |c: &Cut| {
        let ok = (0..vox.len())
            .filter(|&k| c.side[k] == Some(u8::from(vox[k][0] >= edge)))
            .count();
        ok as f64 / vox.len() as f64
    };
    let own = cut(&cells, &curves, 0.0).expect("a cut by the cells' own curves");
    let outlined = cut(&cells, &curves, 0.5).expect("a cut with a price on the edge");
    assert!(
        right(&own) < 0.95,
        "the test's noise leaves own curves right: {}",
        right(&own)
    );
    assert!(
        right(&outlined) >= 0.97,
        "{} (own curves {})",
        right(&outlined),
        right(&own)
    );
}

#[test]
fn the_threshold_is_the_two_means_cut() {
    let mut v = vec![(1, 1.0), (2, 1.0), (9, 1.0), (10, 1.0), (3, 1.0)];
    assert_eq!(threshold(&mut v), Some(3));
    assert_eq!(threshold(&mut [(4, 1.0), (4, 2.0)]), None);
}
