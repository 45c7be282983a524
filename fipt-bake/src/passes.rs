//! The passes over the training views that the bake and the refinement share: the SLF and the
//! diffuse cache's cells built one view at a time, and one view's per-pixel diffuse and
//! specular shadings.
use crate::diffuse::DiffuseCells;
use crate::slf::{SlfBuilder, SurfaceLightField};
use crate::specular::specular_shading_mixture;
use crate::stream::{SampleStream, SamplerKind};
use fipt_core::color::Rgb;
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::rng::Pcg32;
use fipt_core::shading::{RayQuery, Scope, ViewShadings, NUM_LEVELS};
use fipt_shading::incident::IncidentLight;
use fipt_shading::records::{primary_records, PixelRecord};
use glam::Vec3;
use rayon::prelude::*;

/// What the per-pixel specular estimator of a stage needs.
pub(crate) struct SpecularSettings<'a> {
    pub levels: &'a [f32; NUM_LEVELS],
    pub counts: &'a [u32; NUM_LEVELS],
    /// Emitter samples per pixel (used when the light has emitters).
    pub n_light: u32,
    pub sampler: SamplerKind,
    pub seed: u64,
    pub model: ReflectanceModel,
}

/// Ls0 and Ls1 of one view's pixels by [`specular_shading_mixture`] (pixels that `skip`
/// accepts keep 0), each pixel's sample streams keyed by its view and pixel index.
pub(crate) fn specular_mixture_view<L: IncidentLight + Sync>(
    light: &L,
    geometry: &dyn RayQuery,
    set: &SpecularSettings,
    vi: usize,
    r: &[Option<PixelRecord>],
    s: &mut ViewShadings,
    skip: &(dyn Fn(&PixelRecord) -> bool + Sync),
) {
    let seed = set.seed;
    let ViewShadings { ls0, ls1, .. } = s;
    ls0.par_iter_mut()
        .zip(ls1.par_iter_mut())
        .zip(r.par_iter())
        .enumerate()
        .with_min_len(64)
        .for_each(|(i, ((l0, l1), rec))| {
            let Some(rec) = rec.filter(|r| !skip(r)) else {
                return;
            };
            let mut st: [SampleStream; NUM_LEVELS] = std::array::from_fn(|l| {
                SampleStream::new(set.sampler, &[seed, 0x5BEC, vi as u64, i as u64, l as u64])
            });
            let mut rng = Pcg32::from_keys(&[seed, 0x5BED, vi as u64, i as u64]);
            (*l0, *l1) = specular_shading_mixture(
                light,
                geometry,
                rec.hit.p,
                rec.ng,
                rec.ns,
                rec.wo,
                set.levels,
                set.counts,
                set.n_light,
                &mut st,
                &mut rng,
                set.model,
            );
        });
}

/// The SLF (from the hit pixels `keep` accepts, less those within `margin` pixels of a hit
/// pixel it rejects) and the diffuse cache's cells (when `cached`; the cells of the pixels
/// `scope` asks for marked used), built one view at a time from every pixel, the selected
/// views' (pixels, hit pixels `scope` asks for), and how many hit pixels `keep` accepts the
/// margin left out.
#[allow(clippy::too_many_arguments)]
pub(crate) fn slf_and_cells(
    geometry: &dyn RayQuery,
    views: &[View],
    images: &[Image],
    mut slf: SlfBuilder,
    mut cells: DiffuseCells,
    cached: bool,
    scope: Scope,
    keep: impl Fn(&PixelRecord) -> bool,
    margin: usize,
) -> (SurfaceLightField, DiffuseCells, usize, usize, usize) {
    let draw = scope.pixels;
    let (mut pixels, mut hit, mut bled) = (0, 0, 0);
    for (k, (v, img)) in views.iter().zip(images).enumerate() {
        let r = primary_records(geometry, v);
        // Per pixel: None off the geometry, else whether `keep` accepts the hit.
        let kept: Vec<Option<bool>> = r.iter().map(|rec| rec.as_ref().map(&keep)).collect();
        let near = (margin > 0).then(|| {
            let rejected: Vec<bool> = kept.iter().map(|k| *k == Some(false)).collect();
            fipt_core::image::dilate(&rejected, img.width, img.height, margin)
        });
        let mut observed = Vec::with_capacity(r.len());
        for (i, ((rec, l), k)) in r.iter().zip(&img.data).zip(&kept).enumerate() {
            match (rec, k) {
                (Some(_), Some(true)) if near.as_ref().is_some_and(|n| n[i]) => bled += 1,
                (Some(rec), Some(true)) => observed.push((rec.hit.p, *l)),
                _ => {}
            }
        }
        slf.add_all(&observed);
        let selected = scope.shard.contains(k);
        if cached {
            cells.add_view_where(&r, |i| selected && draw.keeps(k, i));
        }
        if selected {
            pixels += r.len();
            hit += (r.iter().enumerate())
                .filter(|(i, rec)| rec.is_some() && draw.keeps(k, *i))
                .count();
        }
    }
    (slf.finish(), cells.finish(), pixels, hit, bled)
}

/// Refuses views and images that do not pair up.
pub(crate) fn check_counts(stage: &str, views: &[View], images: &[Image]) -> fipt_core::Result<()> {
    if views.len() != images.len() {
        return Err(fipt_core::CoreError::invalid(
            stage,
            format!("{} views but {} images", views.len(), images.len()),
        ));
    }
    Ok(())
}

/// Ld per pixel of one view (no cache): `ld_at(pixel, record)` gives one pixel's
/// (Ld0, [Ld1, Ld2]); the pixels `skip` accepts keep 0.
pub(crate) fn diffuse_per_pixel(
    r: &[Option<PixelRecord>],
    s: &mut ViewShadings,
    skip: impl Fn(&PixelRecord) -> bool + Sync,
    ld_at: impl Fn(usize, &PixelRecord) -> (Rgb, [Rgb; 2]) + Sync,
) {
    let computed: Vec<(Rgb, [Rgb; 2])> = (0..s.ld.len())
        .into_par_iter()
        .map(|i| match r[i].filter(|r| !skip(r)) {
            None => (Vec3::ZERO, [Vec3::ZERO; 2]),
            Some(rec) => ld_at(i, &rec),
        })
        .collect();
    for (i, (l0, lp)) in computed.into_iter().enumerate() {
        s.ld[i] = l0;
        if let Some(slot) = s.ld_poly.get_mut(i) {
            *slot = lp;
        }
    }
}
