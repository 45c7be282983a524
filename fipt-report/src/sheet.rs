//! Contact sheets: the report's pictures of a split tiled into one PNG.
use crate::font;
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
    let mut header: Vec<String> = ["input", "re-render", "error"].map(String::from).to_vec();
    header.extend(MAPS.iter().map(|m| m.0.to_string()));
    let mut lines: Vec<Vec<Option<RgbImage>>> = Vec::new();
    let mut row_labels: Vec<String> = Vec::new();
    for v in rows {
        let mut line = vec![
            load(run, &Some(v.input.clone())),
            load(run, &v.render),
            load(run, &v.error),
        ];
        line.extend(v.maps.iter().map(|m| load(run, &m.0)));
        lines.push(line);
        row_labels.push(String::new());
        if v.maps.iter().any(|m| m.1.is_some()) {
            let mut gt = vec![None, None, None];
            gt.extend(v.maps.iter().map(|m| load(run, &m.1)));
            lines.push(gt);
            row_labels.push("truth".to_string());
        }
    }
    let labels = Labels {
        columns: &header,
        rows: &row_labels,
    };
    tile(&lines, cols, w, h, &labels, path)
}

/// Words drawn on a sheet: one per column above it, and one per row inside the row's first
/// cell where that cell is empty (`""`: none).
pub struct Labels<'a> {
    pub columns: &'a [String],
    pub rows: &'a [String],
}

const INK: Rgb<u8> = Rgb([230, 230, 230]);

/// `text` cut to the characters that fit in `room` pixels at scale 1; scale 2 only where its
/// height fits `height` too.
fn fitted(text: &str, room: u32, height: u32) -> (String, u32) {
    match font::fitting_scale(text, room) {
        Some(2) if font::height(2) <= height => (text.to_string(), 2),
        Some(_) => (text.to_string(), 1),
        None => (text.chars().take(((room + 1) / 6) as usize).collect(), 1),
    }
}

/// Tiles `lines` of pictures of `w`×`h` (None: left empty) into `cols` columns under a row of
/// column labels and writes the PNG (through a temporary file).
pub fn tile(
    lines: &[Vec<Option<RgbImage>>],
    cols: u32,
    w: u32,
    h: u32,
    labels: &Labels,
    path: &Path,
) -> Result<()> {
    let columns: Vec<(String, u32)> = labels.columns.iter().map(|t| fitted(t, w, h)).collect();
    let scale = columns.iter().map(|c| c.1).min().unwrap_or(1);
    let top = if columns.is_empty() {
        0
    } else {
        font::height(scale) + GAP
    };
    let width = cols * w + (cols + 1) * GAP;
    let height = top + lines.len() as u32 * h + (lines.len() as u32 + 1) * GAP;
    let mut sheet = RgbImage::from_pixel(width, height, Rgb([40, 40, 40]));
    for (c, (text, _)) in columns.iter().enumerate() {
        let x = GAP + c as u32 * (w + GAP) + (w.saturating_sub(font::width(text, scale))) / 2;
        font::draw(&mut sheet, text, x, GAP, scale, INK);
    }
    for (r, text) in labels.rows.iter().enumerate() {
        let empty = lines
            .get(r)
            .is_some_and(|l| l.first().is_some_and(|c| c.is_none()));
        if !text.is_empty() && empty {
            let (text, s) = fitted(text, w, h);
            let y = top + GAP + r as u32 * (h + GAP) + h.saturating_sub(font::height(s)) / 2;
            let x = GAP + w.saturating_sub(font::width(&text, s)) / 2;
            font::draw(&mut sheet, &text, x, y, s, INK);
        }
    }
    for (r, line) in lines.iter().enumerate() {
        for (c, img) in line.iter().enumerate() {
            if let Some(img) = img {
                let (x0, y0) = (GAP + c as u32 * (w + GAP), top + GAP + r as u32 * (h + GAP));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_columns_are_named_by_their_light_set_folder() {
        let dir = std::env::temp_dir().join(format!("fipt-sheet-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut pictures = vec![];
        for set in ["lamp", "window"] {
            let p = dir.join(set).join("preview").join("000_render.png");
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            RgbImage::from_pixel(64, 40, Rgb([0, 0, 0]))
                .save(&p)
                .unwrap();
            pictures.push(p);
        }
        let out = dir.join("strip.png");
        crate::write_strip(&pictures, &out).unwrap();
        let img = image::open(&out).unwrap().to_rgb8();
        // A header row of labels above the pictures: 7 px of text (all at scale 1, the only
        // one at which "window" fits 64 px) and a gap.
        let top = font::height(1) + GAP;
        assert_eq!(img.height(), top + 40 + 2 * GAP);
        let ink_in = |x0: u32, x1: u32| {
            (x0..x1).any(|x| (GAP..GAP + font::height(2)).any(|y| img.get_pixel(x, y) == &INK))
        };
        // Each column has its label: ink over both pictures, none in the gap between them.
        assert!(ink_in(GAP, GAP + 64) && ink_in(2 * GAP + 64, 2 * GAP + 128));
        // The label is the set's name: "lamp" is 23 px wide at scale 1, centred.
        let w = font::width("lamp", 1);
        let x = GAP + (64 - w) / 2;
        assert!(ink_in(x, x + w) && !ink_in(GAP, x));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
