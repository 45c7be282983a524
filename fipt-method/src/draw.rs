//! The hit pixels a FIPT run will read from its shadings, drawn before its bake so that the
//! bake and the refinements compute those only (`fipt_core::shading::PixelDraw`).
//!
//! Two consumers read shadings pixel by pixel: the training set (at most `train.set_cap` ×
//! steps × batch pixels, a uniform share beyond) and the search (at most
//! `search.max_pixels`). Both draw their share from (`train.seed`, view, pixel), so the smaller
//! share is inside the larger, and the larger one is what the run needs. Where neither cap
//! binds (every scene under about 8 M hit pixels with the presets) every pixel is drawn and
//! nothing changes. The emitter extraction's per-pixel bound and the shadings' closure read
//! the drawn pixels only, so a run reads the same values whether its bake holds every pixel
//! (a `fipt bake` of the whole scene, reused) or the drawn ones.
use crate::error::Result;
use crate::scene::SceneRef;
use fipt_core::shading::PixelDraw;
use fipt_shading::records::HitPoint;

/// The pixels the run with `cfg` will read of `scene`'s training views (`records`: their hits).
pub(crate) fn plan(
    scene: &SceneRef,
    records: &[Vec<Option<HitPoint>>],
    cfg: &crate::settings::FiptSettings,
) -> Result<PixelDraw> {
    let hits: usize = records.iter().map(|r| r.iter().flatten().count()).sum();
    let train = crate::train_set::drawn_share(scene, &cfg.train, hits);
    let search = crate::search::drawn_share(scene, records, &cfg.search, hits)?;
    let draw = PixelDraw::new(cfg.train.seed, Some(train.max(search.unwrap_or(0.0))));
    if !draw.is_all() {
        let search = search.map_or("no".into(), |s| format!("{:.2} %", 100.0 * s));
        crate::note!(
            "pixels: the training set reads {:.2} % and the search {search} of the {hits} hit pixels; the bake and the refinements compute {draw} (train.set_cap, search.max_pixels)",
            100.0 * train,
        );
    }
    Ok(draw)
}
