//! Contact sheets: the report's pictures of a split tiled into one PNG.
use crate::{ReportError, Result, ViewPictures, MAPS};
use image::{Rgb, RgbImage};
use std::path::Path;

const GAP: u32 = 4;

fn load(run: &Path, rel: &Option<String>) -> Option<RgbImage> {
    rel.as_ref()
        .and_then(|r| image::open(run.join(r)).ok())
        .map(|i| i.to_rgb8())
}

/// Writes the sheet of `rows` (one split) to `path`: per view input | re-render | error |
/// kd | σ | metallic | emission, and a ground-truth row under the maps when there is one.
pub fn write_sheet(run: &Path, rows: &[&ViewPictures], path: &Path) -> Result<()> {
    let first = load(run, &Some(rows[0].input.clone())).ok_or_else(|| ReportError::Io {
        path: run.join(&rows[0].input),
        message: "cannot read the input picture".into(),
    })?;
    let (w, h) = first.dimensions();
    let cols = 3 + MAPS.len() as u32;
    let mut lines: Vec<Vec<Option<RgbImage>>> = Vec::new();
    for v in rows {
        let mut line = vec![
            load(run, &Some(v.input.clone())),
            load(run, &v.render),
            load(run, &v.error),
        ];
        line.extend(v.maps.iter().map(|m| load(run, &m.0)));
        lines.push(line);
        if v.maps.iter().any(|m| m.1.is_some()) {
            let mut gt = vec![None, None, None];
            gt.extend(v.maps.iter().map(|m| load(run, &m.1)));
            lines.push(gt);
        }
    }
    tile(&lines, cols, w, h, path)
}

/// Tiles `lines` of pictures of `w`×`h` (None: left empty) into `cols` columns and writes the
/// PNG (through a temporary file).
pub fn tile(lines: &[Vec<Option<RgbImage>>], cols: u32, w: u32, h: u32, path: &Path) -> Result<()> {
    let width = cols * w + (cols + 1) * GAP;
    let height = lines.len() as u32 * h + (lines.len() as u32 + 1) * GAP;
    let mut sheet = RgbImage::from_pixel(width, height, Rgb([40, 40, 40]));
    for (r, line) in lines.iter().enumerate() {
        for (c, img) in line.iter().enumerate() {
            if let Some(img) = img {
                let (x0, y0) = (GAP + c as u32 * (w + GAP), GAP + r as u32 * (h + GAP));
                for (x, y, p) in img.enumerate_pixels() {
                    if x < w && y < h {
                        sheet.put_pixel(x0 + x, y0 + y, *p);
                    }
                }
            }
        }
    }
    let mut png = std::io::Cursor::new(Vec::new());
    sheet
        .write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| ReportError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    fipt_core::fsutil::write_bytes_atomic(path, png.get_ref())?;
    Ok(())
}
