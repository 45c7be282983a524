//! Captures, not renders: 8/16-bit photos, their response curve, and the evidence that a
//! view's values are low dynamic range (capped at one level, on a quantiser's steps, clipped).
//!
//! A scene folder may hold `capture.json` beside its mesh:
//!
//! ```json
//! { "response": "srgb", "exposures": [1.0, 0.5, ...] }
//! ```
//!
//! `response` ([`Response`]) maps stored 8/16-bit values (PNG, JPEG) to linear ones: `"srgb"`
//! (the default for PNG and JPEG), `"linear"`, `{"gamma": 2.2}`, or `{"table": [...]}` (linear
//! values at evenly spaced stored values from 0 to 1, interpolated). EXR views are linear
//! unless `capture.json` says otherwise. `exposures` (optional) are the training views'
//! relative exposures (time × gain, as EXIF gives them): view k is divided by `exposures[k]`.
use crate::color::{srgb_eotf, srgb_oetf, Rgb};
use crate::error::{CoreError, Result};
use crate::image::Image;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// File name of the optional capture description in a scene folder.
pub const CAPTURE_FILE: &str = "capture.json";

/// A camera's response: stored value in [0, 1] ↔ linear value in [0, 1].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Response {
    /// The sRGB transfer function (IEC 61966-2-1).
    #[default]
    Srgb,
    /// Stored values are linear.
    Linear,
    /// stored = linear^(1/γ).
    Gamma(f32),
    /// Linear values at evenly spaced stored values 0, 1/(n−1), …, 1 (non-decreasing).
    Table(Vec<f32>),
}

impl Response {
    /// Linear value of a stored value `v` in [0, 1].
    pub fn to_linear(&self, v: f32) -> f32 {
        let v = v.clamp(0.0, 1.0);
        match self {
            Response::Srgb => srgb_eotf(v),
            Response::Linear => v,
            Response::Gamma(g) => v.powf(*g),
            Response::Table(t) => {
                let x = v * (t.len() - 1) as f32;
                let i = (x.floor() as usize).min(t.len() - 2);
                let f = x - i as f32;
                t[i] * (1.0 - f) + t[i + 1] * f
            }
        }
    }

    /// Stored value in [0, 1] of a linear value (clipped at 1: what a sensor does).
    pub fn to_stored(&self, x: f32) -> f32 {
        let x = x.clamp(0.0, 1.0);
        match self {
            Response::Srgb => srgb_oetf(x),
            Response::Linear => x,
            Response::Gamma(g) => x.powf(1.0 / g),
            Response::Table(t) => {
                let i = t.partition_point(|&y| y < x).clamp(1, t.len() - 1);
                let (a, b) = (t[i - 1], t[i]);
                let f = if b > a { (x - a) / (b - a) } else { 0.0 };
                ((i - 1) as f32 + f.clamp(0.0, 1.0)) / (t.len() - 1) as f32
            }
        }
    }

    /// Checks the curve; `path` names the file it came from.
    pub fn validate(&self, path: &Path) -> Result<()> {
        match self {
            Response::Gamma(g) if !(g.is_finite() && (0.1..=10.0).contains(g)) => {
                Err(CoreError::invalid(
                    path,
                    format!("response gamma {g} is outside [0.1, 10] (sRGB is close to 2.2)"),
                ))
            }
            Response::Table(t)
                if t.len() < 2
                    || t.iter().any(|v| !v.is_finite())
                    || t.windows(2).any(|w| w[1] < w[0]) =>
            {
                Err(CoreError::invalid(
                    path,
                    "response table: give at least 2 finite, non-decreasing linear values (for stored values 0 … 1)",
                ))
            }
            _ => Ok(()),
        }
    }
}

/// `capture.json`: what is known of how the views were taken.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaptureInfo {
    /// Response of 8/16-bit views (PNG, JPEG); EXR views use it only when `exr_response` is
    /// true.
    #[serde(default)]
    pub response: Response,
    /// Apply `response` to EXR views too (an EXR that holds stored, not linear, values).
    #[serde(default)]
    pub exr_response: bool,
    /// Relative exposure of each training view (time × gain); the views are divided by it.
    #[serde(default)]
    pub exposures: Option<Vec<f32>>,
    /// Whether the file states `response` (else a run may estimate it from the views).
    #[serde(skip)]
    pub response_stated: bool,
}

impl CaptureInfo {
    /// Reads `root/capture.json` when present (the default description otherwise).
    pub fn read(root: &Path) -> Result<CaptureInfo> {
        let path = root.join(CAPTURE_FILE);
        if !path.is_file() {
            return Ok(CaptureInfo::default());
        }
        let mut c: CaptureInfo = crate::fsutil::read_json(&path)?;
        c.response.validate(&path)?;
        let raw: serde_json::Value = crate::fsutil::read_json(&path)?;
        c.response_stated = raw.get("response").is_some();
        if let Some(e) = &c.exposures {
            if let Some((k, v)) = e
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v > 0.0))
            {
                return Err(CoreError::invalid(
                    &path,
                    format!("exposures[{k}] = {v}: exposures must be finite and > 0"),
                ));
            }
        }
        Ok(c)
    }
}

/// Whether a file extension holds a low-dynamic-range (8/16-bit integer) image.
pub fn is_ldr_file(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg"))
}

/// Reads an 8/16-bit PNG or a JPEG and maps its values through `response` to linear ones.
pub fn read_ldr(path: &Path, response: &Response) -> Result<Image> {
    let bad = |message: String| CoreError::ImageRead {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| bad(e.to_string()))?;
    // The JPEG decoder fills what a cut-off file lacks with grey and reports no error.
    if jpeg_is_cut_off(&bytes) {
        return Err(bad("the JPEG ends inside its image data (its markers run out before the end-of-image marker): a truncated copy. Copy the photo again, or leave the view out of the camera file".into()));
    }
    let img = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| bad(e.to_string()))?
        .decode()
        .map_err(|e| {
            bad(format!(
                "{e} (a truncated or damaged file? views may be EXR, PNG or JPEG)"
            ))
        })?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    // A table of the linear value of every stored level: one curve evaluation per level.
    let to_image = |levels: usize, values: &mut dyn Iterator<Item = usize>| -> Image {
        let lut: Vec<f32> = (0..levels)
            .map(|i| response.to_linear(i as f32 / (levels - 1) as f32))
            .collect();
        let mut data = Vec::with_capacity(w * h);
        while let (Some(r), Some(g), Some(b)) = (values.next(), values.next(), values.next()) {
            data.push(Rgb::new(lut[r], lut[g], lut[b]));
        }
        Image {
            width: w,
            height: h,
            data,
        }
    };
    let sixteen = matches!(
        img.color(),
        image::ColorType::L16
            | image::ColorType::La16
            | image::ColorType::Rgb16
            | image::ColorType::Rgba16
    );
    Ok(if sixteen {
        let px = img.to_rgb16();
        to_image(65536, &mut px.into_raw().into_iter().map(usize::from))
    } else {
        let px = img.to_rgb8();
        to_image(256, &mut px.into_raw().into_iter().map(usize::from))
    })
}

/// Whether `bytes`, a JPEG file, stop before its first image ends. The markers are walked
/// from the start: segments are skipped by their lengths (an EXIF thumbnail inside one is
/// never looked at), each scan's coded data up to the next marker (inside it FF is always
/// followed by 00 or a restart marker), until the end-of-image marker (FF D9); what follows
/// it (a phone's motion-photo video, a gain map) is not read. Not a JPEG (no FF D8 at the
/// start): false.
pub fn jpeg_is_cut_off(bytes: &[u8]) -> bool {
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return false;
    }
    let mut at = 2;
    loop {
        // A marker: FF (fill bytes allowed), then its code.
        if bytes.get(at) != Some(&0xFF) {
            return true;
        }
        while bytes.get(at) == Some(&0xFF) {
            at += 1;
        }
        let Some(&code) = bytes.get(at) else {
            return true;
        };
        at += 1;
        match code {
            0xD9 => return false,
            0x01 | 0xD0..=0xD7 => continue,
            _ => {}
        }
        let Some(len) = bytes
            .get(at..at + 2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]) as usize)
        else {
            return true;
        };
        at += len;
        if code == 0xDA {
            // The scan's coded data, up to the next marker that is not a restart.
            loop {
                let Some(&b) = bytes.get(at) else {
                    return true;
                };
                if b == 0xFF {
                    match bytes.get(at + 1) {
                        None => return true,
                        Some(0x00 | 0xD0..=0xD7) => at += 2,
                        Some(0xFF) => at += 1,
                        Some(_) => break,
                    }
                } else {
                    at += 1;
                }
            }
        }
    }
}

/// Size of a PNG or JPEG from its header.
pub fn ldr_size(path: &Path) -> Result<(usize, usize)> {
    image::image_dimensions(path)
        .map(|(w, h)| (w as usize, h as usize))
        .map_err(|e| CoreError::ImageRead {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// An 8-bit file format for stored values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LdrFormat {
    Png,
    /// JPEG at this quality (1–100).
    Jpeg(u8),
}

/// A stored value in [0, 1] as 8 bits (rounded).
#[inline]
pub fn quantise8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Writes stored values (in [0, 1], e.g. [`Response::to_stored`] of exposed radiance) as an
/// 8-bit RGB file, atomically.
pub fn write_ldr(path: &Path, stored: &Image, format: LdrFormat) -> Result<()> {
    let bytes: Vec<u8> = stored
        .data
        .iter()
        .flat_map(|p| p.to_array().map(quantise8))
        .collect();
    let (w, h) = (stored.width as u32, stored.height as u32);
    let err = |e: image::ImageError| CoreError::ImageWrite {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    crate::fsutil::write_atomic(path, |tmp| match format {
        LdrFormat::Png => image::save_buffer_with_format(
            tmp,
            &bytes,
            w,
            h,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(err),
        LdrFormat::Jpeg(q) => {
            let f = std::fs::File::create(tmp).map_err(|e| CoreError::io(tmp, e))?;
            let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(
                std::io::BufWriter::new(f),
                q.clamp(1, 100),
            );
            enc.encode(&bytes, w, h, image::ExtendedColorType::Rgb8)
                .map_err(err)
        }
    })
}

/// One view's evidence of a low dynamic range.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ViewLdr {
    /// Largest channel value.
    pub max: f32,
    /// Pixels with a channel within 0.2 % of `max` (clipped when the view is LDR).
    pub at_max: usize,
    /// Channel values between 1 % and 99 % of the level (1, or `max` above 1) that lie on
    /// 8-bit sRGB steps of it (within 0.05 of a step), and how many such values were tested.
    pub on_steps: usize,
    pub tested: usize,
    pub pixels: usize,
}

impl ViewLdr {
    /// Reads the evidence off an image.
    pub fn of(img: &Image) -> ViewLdr {
        let max = img
            .data
            .iter()
            .map(|p| p.max_element())
            .filter(|v| v.is_finite())
            .fold(0.0f32, f32::max);
        let mut v = ViewLdr {
            max,
            pixels: img.data.len(),
            ..Default::default()
        };
        if max <= 0.0 {
            return v;
        }
        // 8-bit steps of 1 when the values stay below it, else of the maximum (a scaled copy).
        let level = if max <= 1.0 + 1e-4 { 1.0 } else { max };
        for p in &img.data {
            if p.max_element() >= max * 0.998 {
                v.at_max += 1;
            }
            for c in p.to_array() {
                let x = c / level;
                if (0.01..0.99).contains(&x) {
                    let s = srgb_oetf(x) * 255.0;
                    v.tested += 1;
                    v.on_steps += usize::from((s - s.round()).abs() < 0.05);
                }
            }
        }
        v
    }

    /// Share of pixels at the view's maximum.
    pub fn clipped_share(&self) -> f64 {
        self.at_max as f64 / self.pixels.max(1) as f64
    }

    /// Share of tested values on 8-bit sRGB steps (about 0.1 for continuous values).
    pub fn step_share(&self) -> f64 {
        self.on_steps as f64 / self.tested.max(1) as f64
    }
}

/// What a split's images say of their dynamic range.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LdrCheck {
    /// The views are low dynamic range (an 8/16-bit file format, or values on 8-bit steps or
    /// capped at a level many pixels share).
    pub ldr: bool,
    /// Why `ldr` was decided, in words.
    pub evidence: Vec<String>,
    /// Share of all pixels at their view's maximum (clipped, when `ldr`).
    pub clipped_share: f64,
    /// Views with ≥ 0.1 % of their pixels clipped: (view index, share).
    pub clipped_views: Vec<(usize, f64)>,
}

/// Pixels at the maximum that make a view capped (with 0.1 % of its pixels).
pub const CAPPED_PIXELS: usize = 16;
/// A view counts as clipped above this share of its pixels at its maximum.
pub const CLIPPED_VIEW_SHARE: f64 = 0.001;

/// Decides whether the views `views` (index, evidence) are LDR; `files_ldr` when their files
/// are 8/16-bit formats.
pub fn ldr_check(views: &[(usize, ViewLdr)], files_ldr: bool) -> LdrCheck {
    let mut c = LdrCheck::default();
    let lit: Vec<&(usize, ViewLdr)> = views.iter().filter(|(_, v)| v.max > 0.0).collect();
    if lit.is_empty() {
        return c;
    }
    let pixels: usize = lit.iter().map(|(_, v)| v.pixels).sum();
    let at_max: usize = lit.iter().map(|(_, v)| v.at_max).sum();
    c.clipped_share = at_max as f64 / pixels.max(1) as f64;
    let tested: usize = lit.iter().map(|(_, v)| v.tested).sum();
    let steps = lit.iter().map(|(_, v)| v.on_steps).sum::<usize>() as f64 / tested.max(1) as f64;
    let top = lit.iter().map(|(_, v)| v.max).fold(0.0f32, f32::max);
    // A view is capped when it reaches the common maximum with many pixels (an HDR render's
    // maximum is a handful of pixels).
    let capped = lit
        .iter()
        .filter(|(_, v)| v.max >= top * 0.998 && v.at_max >= CAPPED_PIXELS.max(v.pixels / 1000))
        .count();
    if files_ldr {
        c.evidence
            .push("the views are 8/16-bit files (PNG or JPEG)".into());
    }
    if steps > 0.6 {
        c.evidence.push(format!(
            "{:.0} % of their values lie on 8-bit sRGB steps (about 10 % would by chance)",
            100.0 * steps
        ));
    }
    // A cap: most views reach one common maximum, and many pixels sit there.
    let cap = capped * 2 >= lit.len() && c.clipped_share >= CLIPPED_VIEW_SHARE;
    if cap {
        c.evidence.push(format!(
            "{capped} of {} views reach one maximum ({top:.4}) and {:.2} % of all pixels sit at it",
            lit.len(),
            100.0 * c.clipped_share
        ));
    }
    c.ldr = files_ldr || steps > 0.6 || (cap && top <= 1.0 + 1e-3);
    for (k, v) in &lit {
        if v.clipped_share() >= CLIPPED_VIEW_SHARE {
            c.clipped_views.push((*k, v.clipped_share()));
        }
    }
    c
}

/// The pixels of an LDR view that are clipped: a channel at 250 of 255 sRGB steps of `level`
/// or above (JPEG rings a clipped region down to 250 and so loses its exact cap).
pub fn clipped_mask(img: &Image, level: f32) -> Vec<bool> {
    clipped_mask_at(img, level * srgb_eotf(250.0 / 255.0))
}

/// The pixels with a channel at or above the linear value `at`.
pub fn clipped_mask_at(img: &Image, at: f32) -> Vec<bool> {
    img.data.iter().map(|p| p.max_element() >= at).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A photo cut off anywhere inside its image data is refused with the file and the fix;
    /// the whole file, or one with bytes after its end (a phone's trailer), reads.
    #[test]
    fn a_cut_off_jpeg_is_refused_and_a_whole_one_reads() {
        let tmp = crate::test_temp::Temp::new();
        let img = image::RgbImage::from_fn(48, 32, |x, y| {
            image::Rgb([(x * 5) as u8, (y * 7) as u8, 90])
        });
        let mut whole = Vec::new();
        image::DynamicImage::ImageRgb8(img)
            .write_to(
                &mut std::io::Cursor::new(&mut whole),
                image::ImageFormat::Jpeg,
            )
            .unwrap();
        let p = tmp.0.join("view.jpg");
        // What a phone appends after the image (a motion photo's video): bytes that hold
        // both markers.
        let mut trailer = whole.clone();
        trailer.extend_from_slice(b"ftypmp4 \xFF\xDA\x00\x08 data \xFF\xD8\xFF\xDA");
        // An APP1 segment (where EXIF keeps its thumbnail) holding an end marker and a scan
        // marker of its own.
        let mut thumb = whole[..2].to_vec();
        thumb.extend_from_slice(&[0xFF, 0xE1, 0x00, 0x08, 0xFF, 0xD9, 0xFF, 0xDA, 0x00, 0x00]);
        thumb.extend_from_slice(&whole[2..]);
        for ok in [&whole, &trailer, &thumb] {
            assert!(!jpeg_is_cut_off(ok));
            std::fs::write(&p, ok).unwrap();
            let read = read_ldr(&p, &Response::Srgb).unwrap();
            assert_eq!((read.width, read.height), (48, 32));
        }
        for keep in [whole.len() / 2, whole.len() - 2, whole.len() - 1] {
            let cut = &whole[..keep];
            assert!(jpeg_is_cut_off(cut), "cut at {keep} of {}", whole.len());
            std::fs::write(&p, cut).unwrap();
            let e = read_ldr(&p, &Response::Srgb).unwrap_err().to_string();
            assert!(
                e.contains("view.jpg")
                    && e.contains("truncated")
                    && e.contains("Copy the photo again"),
                "{e}"
            );
        }
        assert!(!jpeg_is_cut_off(b"\x89PNG not a jpeg"));
    }

    #[test]
    fn responses_round_trip() {
        for r in [
            Response::Srgb,
            Response::Linear,
            Response::Gamma(2.2),
            Response::Table(vec![0.0, 0.05, 0.2, 0.5, 1.0]),
        ] {
            for i in 0..=100 {
                let x = i as f32 / 100.0;
                let back = r.to_linear(r.to_stored(x));
                assert!((back - x).abs() < 1e-4, "{r:?}: {x} -> {back}");
            }
            assert!((r.to_stored(7.0) - 1.0).abs() < 1e-6, "{r:?} clips above 1");
        }
    }

    #[test]
    fn continuous_values_are_not_ldr_and_quantised_ones_are() {
        let n = 64 * 64;
        let mut hdr = Image::new(64, 64);
        let mut ldr = Image::new(64, 64);
        for i in 0..n {
            let x = ((i as f32 * 0.618034).fract() * 3.0).powi(2);
            hdr.data[i] = Rgb::splat(x);
            let q = (srgb_oetf(x.min(1.0)) * 255.0).round() / 255.0;
            ldr.data[i] = Rgb::splat(srgb_eotf(q));
        }
        let h = ldr_check(&[(0, ViewLdr::of(&hdr))], false);
        assert!(!h.ldr, "{:?}", h.evidence);
        let l = ldr_check(&[(0, ViewLdr::of(&ldr))], false);
        assert!(l.ldr && l.evidence.len() == 2, "{:?}", l.evidence);
        assert!(l.clipped_share > 0.5, "{}", l.clipped_share);
        assert_eq!(l.clipped_views.len(), 1);
    }
}
