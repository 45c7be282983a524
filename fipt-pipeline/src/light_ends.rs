//! The kd maps at the ends of each unpinned light's range (`views/<split>/NNN_kd_light<e>_<end>.exr`
//! and previews), for the views the report shows: what the materials would be if a light the
//! views leave open lay at either end of the range they allow ([`fipt_capture::light_ends`]).
use crate::error::{Context, Result};
use fipt_core::image::{ExrPrecision, Image};
use rayon::prelude::*;
use std::path::Path;

/// Pixels per computed factor in each direction (the factors are smooth but for shadows).
const STRIDE: usize = 2;

/// Writes the end maps of every light the views do not pin for the `views` first views per
/// split the report shows; returns how many maps it wrote (none where every light is pinned
/// or the views are HDR).
pub fn write(scene: &crate::scene::LoadedScene, out: &Path, views: usize) -> Result<usize> {
    // A previous run's end maps are not this run's (its lights may be pinned now).
    for split in &scene.ds.splits {
        let dir = out.join("views").join(&split.name);
        for d in [dir.clone(), dir.join("preview")] {
            for f in std::fs::read_dir(&d).into_iter().flatten().flatten() {
                if f.file_name().to_string_lossy().contains("_kd_light") {
                    let _ = std::fs::remove_file(f.path());
                }
            }
        }
    }
    let Some(cl) = &scene.capture.clipped_lights else {
        return Ok(0);
    };
    let Some(model) = &cl.model else {
        return Ok(0);
    };
    if fipt_capture::light_ends::ends(&cl.estimates).is_empty() {
        return Ok(0);
    }
    let mut written = 0;
    for split in &scene.ds.splits {
        let dir = out.join("views").join(&split.name);
        let shown = fipt_report::shown_views(out, split, views);
        let files: Vec<Vec<(std::path::PathBuf, Vec<u8>)>> = shown
            .par_iter()
            .map(|v| -> Result<_> {
                let kd_path = dir.join(format!("{:03}_kd.exr", v.index));
                let kd = Image::read_exr(&kd_path).context("reading the kd map")?;
                let ends = fipt_capture::light_ends::end_factors(
                    model,
                    &scene.geometry,
                    v,
                    &cl.estimates,
                    STRIDE,
                );
                let mut files = vec![];
                for e in ends {
                    let mut img = kd.clone();
                    if (img.width, img.height) != (e.factor.width, e.factor.height) {
                        continue;
                    }
                    for (p, f) in img.data.iter_mut().zip(&e.factor.data) {
                        *p *= *f;
                    }
                    let stem = fipt_report::light_end_stem(v.index, e.light, e.end);
                    let exr = dir.join(format!("{stem}.exr"));
                    let png = dir.join("preview").join(format!("{stem}.png"));
                    files.push((exr.clone(), img.exr_bytes(ExrPrecision::F32, &exr)?));
                    files.push((png.clone(), img.png_bytes(1.0, &png)?));
                }
                Ok(files)
            })
            .collect::<Result<_>>()?;
        for (path, bytes) in files.iter().flatten() {
            fipt_core::fsutil::write_bytes_atomic(path, bytes)?;
            written += usize::from(path.extension().is_some_and(|x| x == "exr"));
        }
    }
    Ok(written)
}
