//! The per-view maps every run writes (`views/<split>/`): kd, ks, roughness, metallic,
//! emission mask and emission, the observation counts, the factorised re-render where
//! shadings exist.
use crate::error::{Context, Result};
use fipt_bake::bake::primary_records;
use fipt_core::dataset::View;
use fipt_core::field::MaterialField;
use fipt_core::image::{ExrPrecision, Image};
use fipt_core::shading::ViewShadings;
use fipt_geom::Geometry;
use fipt_neural::train::render_factorized;
use fipt_neural::NeuralField;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// Views whose maps are computed and encoded at once (on every core), then written in order.
const VIEWS_AT_ONCE: usize = 8;

/// Writes `{k:03}_kd|ks|roughness|metallic|emission_mask.exr` (+ PNG previews) per view,
/// `_emission.exr` (emitted radiance of the given emitter triangles) when `emission` is given, and
/// `_render.exr` where shadings exist: the trained model's prediction
/// (1 − α)·(kd·Ld + ks·Ls0(σ) + Ls1(σ)) + α·GT. Views are computed and encoded several at once
/// and their files written one after another, in view order.
#[allow(clippy::too_many_arguments)]
pub fn export_views(
    field: &dyn MaterialField,
    geometry: &Geometry,
    views: &[View],
    factorized: Option<(&NeuralField, &[ViewShadings], &[Image])>,
    emission: Option<&HashMap<u32, Vec3>>,
    observed: Option<&fipt_search::CellCounts>,
    radiance_scale: f32,
    dir: &Path,
) -> Result<()> {
    let at = |vi: usize| ViewMaps {
        field,
        geometry,
        vi,
        view: &views[vi],
        factorized,
        emission,
        observed,
    };
    let first: Vec<usize> = (0..views.len()).step_by(VIEWS_AT_ONCE).collect();
    for start in first {
        let end = (start + VIEWS_AT_ONCE).min(views.len());
        let files: Vec<Vec<(std::path::PathBuf, Vec<u8>)>> = (start..end)
            .into_par_iter()
            .map(|vi| encode_maps(views[vi].index, at(vi).maps()?, radiance_scale, dir))
            .collect::<Result<_>>()?;
        for (path, bytes) in files.iter().flatten() {
            fipt_core::fsutil::write_bytes_atomic(path, bytes)?;
        }
    }
    Ok(())
}

/// One view's maps and what they are computed from.
struct ViewMaps<'a> {
    field: &'a dyn MaterialField,
    geometry: &'a Geometry,
    vi: usize,
    view: &'a View,
    factorized: Option<(&'a NeuralField, &'a [ViewShadings], &'a [Image])>,
    emission: Option<&'a HashMap<u32, Vec3>>,
    observed: Option<&'a fipt_search::CellCounts>,
}

impl ViewMaps<'_> {
    /// The view's maps, by name.
    fn maps(&self) -> Result<Vec<(&'static str, Image)>> {
        let v = self.view;
        let (w, h) = (v.camera.width, v.camera.height);
        let recs = primary_records(self.geometry, v);
        let hit: Vec<usize> = (0..w * h).filter(|&i| recs[i].is_some()).collect();
        let pts: Vec<Vec3> = hit.iter().map(|&i| recs[i].unwrap().hit.p).collect();
        let mats = self.field.materials(&pts).context("querying the field")?;
        let alpha = self
            .field
            .emission_mask(&pts)
            .context("querying the field")?;
        let mut maps: Vec<(&str, Image)> = ["kd", "ks", "roughness", "metallic", "emission_mask"]
            .iter()
            .map(|n| (*n, Image::new(w, h)))
            .collect();
        for (j, &i) in hit.iter().enumerate() {
            let m = &mats[j];
            maps[0].1.data[i] = m.kd();
            maps[1].1.data[i] = m.ks();
            maps[2].1.data[i] = Vec3::splat(m.roughness);
            maps[3].1.data[i] = Vec3::splat(m.metallic);
            maps[4].1.data[i] = Vec3::splat(alpha[j]);
        }
        if let Some(em) = self.emission {
            let mut img = Image::new(w, h);
            for &i in &hit {
                if let Some(l) = em.get(&recs[i].unwrap().hit.tri) {
                    img.data[i] = *l;
                }
            }
            maps.push(("emission", img));
        }
        if let Some(counts) = self.observed {
            let mut img = Image::new(w, h);
            for &i in &hit {
                img.data[i] = Vec3::splat(counts.count(recs[i].unwrap().hit.p) as f32);
            }
            maps.push(("observed", img));
        }
        if let Some((field, sh, imgs)) = self.factorized {
            let s = &sh[self.vi];
            let idx: Vec<usize> = hit.iter().copied().filter(|&i| s.valid[i]).collect();
            let unit = field.to_unit(
                &idx.iter()
                    .map(|&i| recs[i].unwrap().hit.p)
                    .collect::<Vec<_>>(),
            );
            let (render, al) = render_factorized(field, &unit, s, &idx)?;
            let mut img = Image::new(w, h);
            for (j, &i) in idx.iter().enumerate() {
                let r = Vec3::from(render[j]);
                img.data[i] = r * (1.0 - al[j]) + imgs[self.vi].data[i] * al[j];
            }
            maps.push(("render", img));
        }
        Ok(maps)
    }
}

/// The files of view `k`'s maps: each map's EXR and PNG preview, radiance maps scaled by
/// `radiance_scale`.
fn encode_maps(
    k: usize,
    mut maps: Vec<(&'static str, Image)>,
    radiance_scale: f32,
    dir: &Path,
) -> Result<Vec<(std::path::PathBuf, Vec<u8>)>> {
    let mut files = vec![];
    for (name, img) in &mut maps {
        let radiance = matches!(*name, "emission" | "render");
        if radiance && radiance_scale != 1.0 {
            for p in &mut img.data {
                *p *= radiance_scale;
            }
        }
        let exr = dir.join(format!("{k:03}_{name}.exr"));
        files.push((exr.clone(), img.exr_bytes(ExrPrecision::F32, &exr)?));
        // Counts: white at 64 training pixels a cell; radiance at the working exposure.
        let exposure = match *name {
            "observed" => 1.0 / 64.0,
            _ if radiance => 1.0 / radiance_scale,
            _ => 1.0,
        };
        let png = dir.join("preview").join(format!("{k:03}_{name}.png"));
        files.push((png.clone(), img.png_bytes(exposure, &png)?));
    }
    Ok(files)
}

/// The views of a split whose maps a run wrote, where it left some out
/// (`views/<split>/maps.json`; absent when every view has its maps): `fipt eval` scores
/// these.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapsManifest {
    /// View indices with maps, ascending.
    pub views: Vec<usize>,
    /// Views in the split.
    pub of: usize,
    /// The budget that chose them (`[render] train_pixels`).
    pub train_pixels: u64,
}

impl MapsManifest {
    pub const FILE: &'static str = "maps.json";

    /// The manifest of the maps in `dir` (`views/<split>`), None where there is none (every
    /// view mapped).
    pub fn read(dir: &Path) -> Result<Option<MapsManifest>> {
        let p = dir.join(Self::FILE);
        if !p.is_file() {
            return Ok(None);
        }
        fipt_core::fsutil::read_json(&p)
            .map(Some)
            .with_context(|| format!("reading {} (remove it to score every view)", p.display()))
    }
}

/// Which views of `split` a run maps and re-renders: every one, but for the training split
/// those [`crate::run_config::ReRenderConfig::train_views`] keeps.
pub(crate) fn kept_views(
    scene: &crate::scene::LoadedScene,
    render: &crate::run_config::ReRenderConfig,
    split: &fipt_core::dataset::Split,
) -> Vec<bool> {
    if split.name == scene.ds.train().name {
        render.train_views(split.views.len(), scene.ds.width * scene.ds.height)
    } else {
        vec![true; split.views.len()]
    }
}

/// The views of `split` that get maps: every view but training views beyond `[render]
/// train_pixels`, the same ones the re-render covers (so the report shows maps and re-renders
/// of the same views). Where some are left out, says so, writes [`MapsManifest`] and removes
/// what a previous run left of theirs (`{k:03}_*` and its previews: another field's maps);
/// else removes any manifest.
pub(crate) fn mapped_views(
    scene: &crate::scene::LoadedScene,
    render: &crate::run_config::ReRenderConfig,
    split: &fipt_core::dataset::Split,
    dir: &Path,
) -> Result<Vec<View>> {
    let keep = kept_views(scene, render, split);
    let manifest = dir.join(MapsManifest::FILE);
    let views: Vec<View> = (split.views.iter().zip(&keep))
        .filter(|(_, k)| **k)
        .map(|(v, _)| v.clone())
        .collect();
    if views.len() == split.views.len() {
        remove_if_present(&manifest)?;
        return Ok(views);
    }
    let left: std::collections::HashSet<String> = (split.views.iter().zip(&keep))
        .filter(|(_, k)| !**k)
        .map(|(v, _)| format!("{:03}", v.index))
        .collect();
    for d in [dir.to_path_buf(), dir.join("preview")] {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.split_once('_').is_some_and(|(k, _)| left.contains(k)) {
                remove_if_present(&e.path())?;
            }
        }
    }
    crate::note!(
        "maps: {} of {} {} views, evenly spaced (render.train_pixels = {}; 0 for every one)",
        views.len(),
        split.views.len(),
        split.name,
        render.train_pixels
    );
    let m = MapsManifest {
        views: views.iter().map(|v| v.index).collect(),
        of: split.views.len(),
        train_pixels: render.train_pixels,
    };
    std::fs::create_dir_all(dir).map_err(|e| fipt_core::CoreError::io(dir, e))?;
    fipt_core::fsutil::write_json_atomic(&manifest, &m)?;
    Ok(views)
}

fn remove_if_present(p: &Path) -> Result<()> {
    match std::fs::remove_file(p) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(fipt_core::CoreError::io(p, e).into())
        }
        _ => Ok(()),
    }
}
