//! The one-colour profile of faint gloss (`SearchConfig::one_colour_below`): a region's
//! pixels fitted with one base colour instead of one per surface cell.
use super::{profile, Albedo, RegionProfile, SearchPixel};
use fipt_core::image::Image;
use fipt_core::shading::ViewShadings;

/// `pixels` with each region as one surface cell (one base colour fitted per region).
pub fn one_cell_per_region(pixels: &[SearchPixel]) -> Vec<SearchPixel> {
    (pixels.iter())
        .map(|p| SearchPixel {
            cell: p.region,
            ..*p
        })
        .collect()
}

/// Each region's profile with its [`RegionProfile::one_colour`] row: `pixels` profiled again
/// with the whole region as one surface cell, at m = 0 only.
pub fn with_one_colour(
    mut profiles: Vec<RegionProfile>,
    pixels: &[SearchPixel],
    shadings: &[ViewShadings],
    images: &[Image],
    sigma: &[f32],
) -> Vec<RegionProfile> {
    let one = profile(
        &one_cell_per_region(pixels),
        shadings,
        images,
        profiles.len(),
        sigma,
        &[0.0],
        Albedo::Fitted,
    );
    for (p, o) in profiles.iter_mut().zip(one) {
        p.one_colour = o.cost.into_iter().next().unwrap_or_default();
    }
    profiles
}
