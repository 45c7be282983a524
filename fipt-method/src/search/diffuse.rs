//! The diffuse shading the search reads: each pixel's Ld (and [Ld1, Ld2]) averaged with those of
//! its neighbours in the same view and region that lie within two median pixel footprints of
//! it on the surface (`[search] diffuse_radius`).
//!
//! The search fits a base colour per surface cell at every σ, with Ld as the regressor. Noise
//! in Ld (the refinement's Monte Carlo estimate, per pixel or per diffuse-cache cell) leaves a
//! residual that a glossier lobe explains in part, so it moves the minima of faintly glossy
//! surfaces towards glossier σ. Measured with the ground truth's materials and lights
//! refined (`docs/roughness-rooms.md`, *Where rough walls' glossy minima come from*): on
//! `room`'s walls (σ 0.85–0.95) the minima sat at 0.62–0.72 with the Ld as refined and at
//! 0.74–0.80 with Ld averaged over 3 × 3 pixels of the same region, the glossy parts' minima
//! unchanged. The light on a wall changes little from one pixel to the next; the estimate's
//! noise does. The distance bound keeps the mean from reaching across a surface seen at a
//! grazing angle: there neighbouring pixels lie far apart, and averaging a hot spot's
//! falloff over them made an error that changes with the view, which a σ lobe fits (the
//! ceiling above `room`'s lamp read 0.42 for 1.0 with image neighbours alone).
use fipt_core::shading::ViewShadings;
use glam::Vec3;

/// Which of a view's pixels the mean over a pixel's neighbourhood takes.
pub(crate) struct Neighbours<'a> {
    /// Pixels at most this far from the pixel, in the view's rows and columns.
    pub radius: usize,
    /// The pixel's region (None: none).
    pub region: &'a dyn Fn(usize) -> Option<u32>,
    /// Whether the pixel's shadings are valid.
    pub valid: &'a dyn Fn(usize) -> bool,
    /// Whether two pixels' hits lie close enough on the surface.
    pub near: &'a dyn Fn(usize, usize) -> bool,
}

/// How far apart two hits may lie, in median pixel footprints, to share their diffuse shading.
pub(crate) const NEAR_FOOTPRINTS: f32 = 2.0;

/// For each pixel of `idx` (indices into a `width × height` view, row by row): itself and the
/// pixels of its neighbourhood ([`Neighbours`]).
fn neighbourhoods(idx: &[u32], (width, height): (usize, usize), nb: &Neighbours) -> Vec<Vec<u32>> {
    let Neighbours {
        radius,
        region,
        valid,
        near,
    } = nb;
    let r = *radius as isize;
    idx.iter()
        .map(|&i| {
            let i = i as usize;
            let own = region(i);
            let (x, y) = ((i % width) as isize, (i / width) as isize);
            let mut hood = vec![i as u32];
            for dy in -r..=r {
                for dx in -r..=r {
                    let (nx, ny) = (x + dx, y + dy);
                    if (dx, dy) == (0, 0)
                        || nx < 0
                        || ny < 0
                        || nx >= width as isize
                        || ny >= height as isize
                    {
                        continue;
                    }
                    let j = ny as usize * width + nx as usize;
                    if own.is_some() && region(j) == own && valid(j) && near(i, j) {
                        hood.push(j as u32);
                    }
                }
            }
            hood
        })
        .collect()
}

/// `rows`, the shadings of one view's pixels `idx` (in that order), with each pixel's diffuse
/// shading the mean over its neighbourhood ([`neighbourhoods`]); `select` reads any of the
/// view's pixels' shadings. A radius of 0 leaves `rows` as they are.
pub(crate) fn smooth(
    rows: &mut ViewShadings,
    idx: &[u32],
    size: (usize, usize),
    nb: &Neighbours,
    select: &dyn Fn(&[u32]) -> ViewShadings,
) {
    if nb.radius == 0 || idx.is_empty() {
        return;
    }
    let hoods = neighbourhoods(idx, size, nb);
    let mut all: Vec<u32> = hoods.iter().flatten().copied().collect();
    all.sort_unstable();
    all.dedup();
    let wide = select(&all);
    let at = |j: &u32| all.binary_search(j).expect("a pixel of the neighbourhoods");
    let poly = !rows.ld_poly.is_empty() && !wide.ld_poly.is_empty();
    for (k, hood) in hoods.iter().enumerate() {
        let n = hood.len() as f32;
        rows.ld[k] = hood.iter().map(|j| wide.ld[at(j)]).sum::<Vec3>() / n;
        if poly {
            rows.ld_poly[k] =
                [0, 1].map(|c| hood.iter().map(|j| wide.ld_poly[at(j)][c]).sum::<Vec3>() / n);
        }
    }
}

/// Every view of `shadings` (whole views) smoothed in place as [`smooth`] does the search's
/// rows: the pixels with valid shadings and a region; `near(v, i, j)` as [`Neighbours::near`].
pub(crate) fn smooth_views(
    shadings: &mut [ViewShadings],
    radius: usize,
    region: &dyn Fn(usize, usize) -> Option<u32>,
    near: &dyn Fn(usize, usize, usize) -> bool,
) {
    if radius == 0 {
        return;
    }
    for (v, sh) in shadings.iter_mut().enumerate() {
        let idx: Vec<u32> = (0..sh.ld.len() as u32)
            .filter(|&i| sh.valid[i as usize] && region(v, i as usize).is_some())
            .collect();
        let mut rows = sh.select(&idx);
        let full: &ViewShadings = sh;
        let nb = Neighbours {
            radius,
            region: &|j| region(v, j),
            valid: &|j| full.valid[j],
            near: &|i, j| near(v, i, j),
        };
        smooth(&mut rows, &idx, (full.width, full.height), &nb, &|ix| {
            full.select(ix)
        });
        for (k, &i) in idx.iter().enumerate() {
            sh.ld[i as usize] = rows.ld[k];
            if let (Some(dst), Some(src)) = (sh.ld_poly.get_mut(i as usize), rows.ld_poly.get(k)) {
                *dst = *src;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_core::shading::DEFAULT_LEVELS;

    /// A 4 × 3 view: region 0 in the left two columns, 1 in the right two, pixel 5 invalid.
    fn view() -> (ViewShadings, Vec<Option<u32>>) {
        let mut s = ViewShadings::zeros_for(4, 3, DEFAULT_LEVELS, true);
        for i in 0..12 {
            s.ld[i] = Vec3::splat(i as f32);
            s.ld_poly[i] = [Vec3::splat(2.0 * i as f32), Vec3::splat(-(i as f32))];
            s.valid[i] = i != 5;
        }
        let region = (0..12).map(|i| Some(u32::from(i % 4 >= 2))).collect();
        (s, region)
    }

    #[test]
    fn the_mean_stays_inside_the_region_and_skips_invalid_pixels() {
        let (s, region) = view();
        let mut views = vec![s.clone()];
        smooth_views(&mut views, 1, &|_, i| region[i], &|_, _, _| true);
        let out = &views[0];
        // Pixel 0 (x 0, y 0): itself, 1 and 4 (5 is invalid) → (0 + 1 + 4) / 3.
        assert_eq!(out.ld[0], Vec3::splat(5.0 / 3.0));
        assert_eq!(
            out.ld_poly[0],
            [Vec3::splat(10.0 / 3.0), Vec3::splat(-5.0 / 3.0)]
        );
        // Pixel 2 (region 1): itself, 3, 6, 7 → 4.5; never the left columns.
        assert_eq!(out.ld[2], Vec3::splat(4.5));
        // Pixel 9 (region 0, bottom row): itself, 8, 4 (5 invalid) → 7.
        assert_eq!(out.ld[9], Vec3::splat(7.0));
        // The invalid pixel keeps its value.
        assert_eq!(out.ld[5], Vec3::splat(5.0));
        // Radius 0: unchanged.
        let mut again = vec![s.clone()];
        smooth_views(&mut again, 0, &|_, i| region[i], &|_, _, _| true);
        assert_eq!(again[0], s);
    }

    #[test]
    fn rows_of_some_pixels_get_what_whole_views_get() {
        let (s, region) = view();
        // Pixels 4 and 8 lie too far from the others (a surface seen at a grazing angle).
        let near = |i: usize, j: usize| ![4, 8].contains(&i) && ![4, 8].contains(&j) || i == j;
        let mut whole = vec![s.clone()];
        smooth_views(&mut whole, 1, &|_, i| region[i], &|_, i, j| near(i, j));
        assert_eq!(whole[0].ld[0], Vec3::splat(0.5), "pixel 0: itself and 1");
        assert_eq!(whole[0].ld[4], Vec3::splat(4.0), "pixel 4: itself alone");
        let idx = [0u32, 7, 10];
        let mut rows = s.select(&idx);
        let nb = Neighbours {
            radius: 1,
            region: &|j| region[j],
            valid: &|j| s.valid[j],
            near: &near,
        };
        smooth(&mut rows, &idx, (4, 3), &nb, &|ix| s.select(ix));
        for (k, &i) in idx.iter().enumerate() {
            assert_eq!(rows.ld[k], whole[0].ld[i as usize]);
            assert_eq!(rows.ld_poly[k], whole[0].ld_poly[i as usize]);
        }
    }
}
