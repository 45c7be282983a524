//! Which pixels the search reads: a region's outline pixels that mix two surfaces (beside a
//! much brighter region, or across an occlusion) are left out.
use crate::regions::Regions;
use crate::scene::SceneRef;
use fipt_core::color::luminance;
use fipt_core::image::Image;
use fipt_search::{on_region_edge, on_silhouette, SearchConfig};
use fipt_shading::records::HitPoint;

/// A pixel's search region: its region, unless `cfg.drop_edges` leaves it out as an outline
/// pixel: one with a neighbour `cfg.edge_contrast` times brighter in another region or in
/// none, or any outline pixel of a region whose outline is a small share of it
/// ([`fipt_search::small_outlines`]), or, with `cfg.silhouette_gap`, a pixel beside another
/// region across an occlusion (its neighbour's hit far from its own, `eyes[v]` the view's
/// camera centre) and `cfg.silhouette_contrast` times brighter or darker, in a region whose
/// silhouette is at most [`SILHOUETTE_SHARE`] of it.
pub(super) fn region_rule<'a>(
    images: &'a [Image],
    records: &'a [Vec<Option<HitPoint>>],
    eyes: Vec<glam::Vec3>,
    regions: &'a Regions,
    cfg: &'a SearchConfig,
) -> impl Fn(usize, usize, &HitPoint) -> Option<u32> + 'a {
    let whole_outline = if cfg.drop_edges && cfg.outline_share > 0.0 {
        let widths: Vec<usize> = images.iter().map(|img| img.width).collect();
        let shares =
            fipt_search::outline_shares(&regions.ids, &widths, regions.len(), Regions::NONE);
        let small = fipt_search::small_outlines(&shares, cfg.outline_share);
        note_small_outlines(&regions.labels, &shares, &small);
        small
    } else {
        vec![]
    };
    let (gap, contrast) = (cfg.silhouette_gap, cfg.silhouette_contrast);
    let silhouette = move |v: usize, i: usize| {
        let (ids, img) = (&regions.ids[v], &images[v]);
        // Luminances of 0 (or below) compare as a tiny positive value: two black pixels are
        // alike, a black one beside a lit one contrasts.
        let lum = |k: usize| luminance(img.data[k]).max(1e-6);
        let own = lum(i);
        let apart = |j: usize| {
            let other = lum(j);
            other.max(own) >= contrast * other.min(own)
        };
        on_silhouette(ids, &records[v], img.width, i, eyes[v], gap, &apart)
    };
    let silhouettes = if cfg.drop_edges && gap > 0.0 {
        let shares =
            fipt_search::region_shares(&regions.ids, regions.len(), Regions::NONE, &silhouette);
        let small = fipt_search::small_outlines(&shares, SILHOUETTE_SHARE);
        note_kept_silhouettes(&regions.labels, &shares, &small);
        small
    } else {
        vec![]
    };
    move |v, i, _| {
        let (ids, img) = (&regions.ids[v], &images[v]);
        let region = regions.id(v, i)?;
        if cfg.drop_edges {
            let any = whole_outline.get(region as usize) == Some(&true);
            let floor = cfg.edge_contrast * luminance(img.data[i]);
            let counts = |j: usize| any || luminance(img.data[j]) >= floor;
            if on_region_edge(ids, img.width, i, &counts) {
                return None;
            }
            if silhouettes.get(region as usize) == Some(&true) && silhouette(v, i) {
                return None;
            }
        }
        Some(region)
    }
}

/// A region loses its silhouette pixels (`[search] silhouette_gap`) only where they are at
/// most this share of its pixels over the views: a thin or small region (a lamp's stand at
/// 160 × 120, 44 % silhouette, lost its metal with them) keeps them.
const SILHOUETTE_SHARE: f32 = 0.25;

/// The training views' camera centres.
pub(super) fn train_eyes(scene: &SceneRef) -> Vec<glam::Vec3> {
    (scene.ds.train().views.iter())
        .map(|v| v.camera.origin)
        .collect()
}

/// Prints the regions that keep their silhouette pixels (over [`SILHOUETTE_SHARE`] of them).
fn note_kept_silhouettes(labels: &[i64], shares: &[Option<f64>], small: &[bool]) {
    let kept: Vec<String> = (labels.iter().zip(shares).zip(small))
        .filter_map(|((label, share), &small)| Some((label, (*share)?)).filter(|_| !small))
        .map(|(label, share)| format!("{label} ({:.0} %)", 100.0 * share))
        .collect();
    if !kept.is_empty() {
        crate::note!(
            "search: {} region(s) keep their silhouette pixels, over a quarter of their pixels: {}",
            kept.len(),
            kept.join(", ")
        );
    }
}

/// Prints the regions whose whole outline the search leaves out, with its share of their
/// pixels (the first 12).
fn note_small_outlines(labels: &[i64], shares: &[Option<f64>], small: &[bool]) {
    const LISTED: usize = 12;
    let listed: Vec<String> = (labels.iter().zip(shares).zip(small))
        .filter(|(_, &small)| small)
        .map(|((label, share), _)| format!("{label} ({:.0} %)", 100.0 * share.unwrap_or(0.0)))
        .collect();
    if listed.is_empty() {
        return;
    }
    let more = listed.len().saturating_sub(LISTED);
    crate::note!(
        "search: the whole outline left out on {} region(s) (its share of their pixels): {}{}",
        listed.len(),
        listed[..listed.len().min(LISTED)].join(", "),
        if more > 0 {
            format!(", and {more} more")
        } else {
            String::new()
        }
    );
}
