//! The memory a run will need, estimated before any work from what dominates it: per training
//! pixel, the training set (or, before it, the search's copy of the shadings, whichever is
//! larger: they are never held together) and what the run holds throughout (each pixel's hit
//! point, image value and search target); and the hash tables with their optimiser state. The
//! bake and the refinement write each view as it is done and hold one view at a time. A run
//! that would not fit is refused with the figures; one that would take most of the memory is
//! warned about.
use crate::bail;
use crate::error::Result;
use fipt_core::memory::{available_bytes, gib};
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::NUM_LEVELS;

/// Estimated bytes of a run on `pixels` training pixels, by part.
pub fn estimate(
    pixels: u64,
    cfg: &crate::settings::FiptSettings,
    model: ReflectanceModel,
) -> Vec<(&'static str, u64)> {
    let poly = model.diffuse_depends_on_roughness() as u64;
    // Ld, Ld1/Ld2 for principled, Ls0 and Ls1 at every level.
    let shadings = 12 * (1 + 2 * poly + 2 * NUM_LEVELS as u64);
    // The search's copy adds the valid flag, and its cost curves the cell order and what the
    // loss reads of the pixel's value (8 + 36 bytes), on at most `search.max_pixels` pixels;
    // the training set the image value, the position, the Morton code, the origin, the
    // segment and the search target, on at most `train.set_cap · steps · batch` pixels.
    let searched = match cfg.search.max_pixels {
        0 => pixels,
        m => pixels.min(m as u64),
    };
    let search = searched * (shadings + 1 + 44);
    let kept = cfg
        .train
        .set_limit()
        .map_or(pixels, |l| pixels.min(l as u64));
    let training = kept * (shadings + 12 + 12 + 8 + 8 + 4 + 8);
    // Held through the run: the hit point and triangle, the image value, the search target
    // (an index into the distinct targets).
    let held = 20 + 12 + 4;
    let g = &cfg.train.field.grid;
    // Parameters and two Adam moments, f32.
    let tables = g.levels as u64 * (1u64 << g.log2_table) * g.features as u64 * 4 * 3;
    vec![
        ("training set or search", search.max(training)),
        ("hits and images", pixels * held),
        ("hash tables", tables),
    ]
}

/// Refuses a run whose estimate exceeds the memory available.
pub fn check(
    pixels: u64,
    cfg: &crate::settings::FiptSettings,
    model: ReflectanceModel,
) -> Result<u64> {
    let parts = estimate(pixels, cfg, model);
    let total: u64 = parts.iter().map(|p| p.1).sum();
    let Some(avail) = available_bytes() else {
        return Ok(total);
    };
    let list = parts
        .iter()
        .map(|(n, b)| format!("{n} {:.2} GiB", gib(*b)))
        .collect::<Vec<_>>()
        .join(", ");
    if total > avail {
        bail!(
            "this run needs at least {:.1} GiB ({list}; {pixels} training pixels) but {:.1} GiB are available: \
             use fewer or smaller views, a smaller `train.field.grid.log2_table` or `levels`, or a machine with more memory",
            gib(total),
            gib(avail)
        );
    }
    if total > avail / 2 {
        crate::note!(
            "warning: this run needs at least {:.1} GiB of the {:.1} GiB available ({list})",
            gib(total),
            gib(avail)
        );
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::FiptSettings;

    fn part(parts: &[(&'static str, u64)], name: &str) -> u64 {
        parts.iter().find(|p| p.0 == name).unwrap().1
    }

    /// A scene of the reference's size (200 views of 640×480): the search and the training set
    /// are bounded by their caps, not by the pixels; without the caps they grow with them.
    #[test]
    fn the_caps_bound_the_estimate_of_a_large_scene() {
        let pixels = 200 * 640 * 480;
        let cfg = FiptSettings::preset("fast").unwrap();
        let model = ReflectanceModel::Principled;
        let capped = part(&estimate(pixels, &cfg, model), "training set or search");
        let set = cfg.train.set_limit().unwrap() as u64;
        let searched = cfg.search.max_pixels as u64;
        assert!(set < pixels && searched < pixels);
        // Per pixel: the search's shadings and valid flag; the training set's 52 bytes more.
        let poly = model.diffuse_depends_on_roughness() as u64;
        let shadings = 12 * (1 + 2 * poly + 2 * NUM_LEVELS as u64);
        assert_eq!(
            capped,
            (searched * (shadings + 45)).max(set * (shadings + 52))
        );
        let mut open = cfg.clone();
        open.search.max_pixels = 0;
        open.train.set_cap = 0.0;
        let uncapped = part(&estimate(pixels, &open, model), "training set or search");
        assert_eq!(uncapped, pixels * (shadings + 52));
        assert!(capped * 5 < uncapped, "{capped} vs {uncapped}");
        assert_eq!(
            part(&estimate(pixels, &cfg, model), "hits and images"),
            pixels * 36
        );
    }
}
