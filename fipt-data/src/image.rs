//! `Image`: f32 linear RGB, row-major, origin at the top-left pixel.
//!
//! EXR read/write (float32 or half, channels found by name) and sRGB PNG previews.
use crate::color::{srgb_oetf, Rgb};
use crate::error::{CoreError, Result};
use glam::Vec3;
use std::path::Path;

/// Storage precision of an EXR file written by fipt.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExrPrecision {
    /// 32-bit float: exact round trip.
    F32,
    /// 16-bit half float: ground-truth maps and previews of parameters.
    F16,
}

/// Largest finite half-float value.
pub const HALF_MAX: f32 = 65504.0;

/// What to do with NaN, infinite or negative pixel values found in an input image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BadPixelPolicy {
    /// Refuse the image with an error that counts the bad values (default).
    #[default]
    Reject,
    /// NaN → 0, negative → 0, +Inf → the largest finite value of the image.
    Clamp,
}

/// Counts of bad values found in an image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct BadPixelCount {
    pub nan: usize,
    pub inf: usize,
    pub negative: usize,
    /// First offending pixel (x, y).
    pub first: Option<(usize, usize)>,
}

impl BadPixelCount {
    pub fn total(&self) -> usize {
        self.nan + self.inf + self.negative
    }
}

/// A linear RGB image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// `width * height` pixels, row by row from the top.
    pub data: Vec<Rgb>,
}

impl Image {
    /// A black image.
    pub fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            height,
            data: vec![Vec3::ZERO; width * height],
        }
    }

    /// An image filled with `value`.
    pub fn filled(width: usize, height: usize, value: Rgb) -> Self {
        Image {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize) -> Rgb {
        self.data[y * self.width + x]
    }

    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: Rgb) {
        self.data[y * self.width + x] = v;
    }

    /// Smallest and largest channel value over finite pixels.
    pub fn range(&self) -> (f32, f32) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for p in &self.data {
            for c in p.to_array() {
                if c.is_finite() {
                    lo = lo.min(c);
                    hi = hi.max(c);
                }
            }
        }
        (lo, hi)
    }

    /// No finite channel value above 0 (a lens cap): `fipt info`'s and `fipt run`'s black view.
    pub fn is_black(&self) -> bool {
        self.range().1 <= 0.0
    }

    /// Counts NaN, infinite and negative channel values.
    pub fn count_bad(&self) -> BadPixelCount {
        let mut c = BadPixelCount::default();
        for (i, p) in self.data.iter().enumerate() {
            let mut bad = false;
            for v in p.to_array() {
                if v.is_nan() {
                    c.nan += 1;
                    bad = true;
                } else if v.is_infinite() {
                    c.inf += 1;
                    bad = true;
                } else if v < 0.0 {
                    c.negative += 1;
                    bad = true;
                }
            }
            if bad && c.first.is_none() {
                c.first = Some((i % self.width, i / self.width));
            }
        }
        c
    }

    /// Applies `policy` to bad values; returns what was found. With `Reject`, any bad value is
    /// an error naming `path`.
    pub fn sanitize(&mut self, policy: BadPixelPolicy, path: &Path) -> Result<BadPixelCount> {
        let count = self.count_bad();
        if count.total() == 0 {
            return Ok(count);
        }
        match policy {
            BadPixelPolicy::Reject => {
                let (x, y) = count.first.unwrap_or((0, 0));
                Err(CoreError::BadPixels {
                    path: path.to_path_buf(),
                    nan: count.nan,
                    inf: count.inf,
                    negative: count.negative,
                    x,
                    y,
                })
            }
            BadPixelPolicy::Clamp => {
                let (_, hi) = self.range();
                let hi = if hi.is_finite() { hi.max(0.0) } else { 0.0 };
                for p in &mut self.data {
                    *p = Vec3::from_array(p.to_array().map(|v| {
                        if v.is_nan() || v < 0.0 {
                            0.0
                        } else if v.is_infinite() {
                            hi
                        } else {
                            v
                        }
                    }));
                }
                Ok(count)
            }
        }
    }

    /// Reads an EXR file. Channels are found by name (`R`, `G`, `B`, optionally behind a layer
    /// prefix such as `Image.R`); a single `Y` channel (or a lone channel of any name) is
    /// broadcast to grey. Half, float and uint samples are accepted.
    pub fn read_exr(path: &Path) -> Result<Image> {
        use exr::prelude::*;
        let size = exr_size_checked(path)?;
        let broken = |what: String| CoreError::Exr {
            path: path.to_path_buf(),
            message: what,
        };
        let img = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .map_err(|e| match e {
                exr::error::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
                    broken(format!(
                        "the file ends early ({size} bytes): truncated? write it again"
                    ))
                }
                exr::error::Error::Io(io) => CoreError::io(path, io),
                exr::error::Error::Invalid(m)
                    if m.contains("missing bytes") || m.contains("end of file") =>
                {
                    broken(format!(
                        "the file ends early ({size} bytes; {m}): truncated? write it again"
                    ))
                }
                other => broken(format!("not a readable EXR ({size} bytes): {other}")),
            })?;
        let layer = &img.layer_data;
        let (w, h) = (layer.size.width(), layer.size.height());
        let chans = &layer.channel_data.list;
        let short = |c: &AnyChannel<FlatSamples>| {
            let name = c.name.to_string();
            name.rsplit('.').next().unwrap_or("").to_ascii_uppercase()
        };
        let find = |n: &str| chans.iter().find(|c| short(c) == n);
        let to_f32 = |c: &AnyChannel<FlatSamples>| -> Vec<f32> {
            match &c.sample_data {
                FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
                FlatSamples::F32(v) => v.clone(),
                FlatSamples::U32(v) => v.iter().map(|&x| x as f32).collect(),
            }
        };
        let (r, g, b) = match (find("R"), find("G"), find("B")) {
            (Some(r), Some(g), Some(b)) => (to_f32(r), to_f32(g), to_f32(b)),
            _ => {
                let grey = find("Y").or(if chans.len() == 1 {
                    chans.first()
                } else {
                    None
                });
                match grey {
                    Some(c) => {
                        let v = to_f32(c);
                        (v.clone(), v.clone(), v)
                    }
                    None => {
                        let names: Vec<String> = chans.iter().map(|c| c.name.to_string()).collect();
                        return Err(CoreError::Exr {
                            path: path.to_path_buf(),
                            message: format!(
                                "no R, G, B (or Y) channels; channels present: {names:?}"
                            ),
                        });
                    }
                }
            }
        };
        if r.len() != w * h {
            return Err(CoreError::Exr {
                path: path.to_path_buf(),
                message: format!("channel holds {} samples for a {w}x{h} image", r.len()),
            });
        }
        let data = (0..w * h).map(|i| Vec3::new(r[i], g[i], b[i])).collect();
        Ok(Self {
            width: w,
            height: h,
            data,
        })
    }

    /// Writes an RGB EXR (ZIP compression), atomically. Half precision saturates at ±65504
    /// (no infinities are written); use `F32` for radiance.
    pub fn write_exr(&self, path: &Path, precision: ExrPrecision) -> Result<()> {
        let bytes = self.exr_bytes(precision, path)?;
        crate::fsutil::write_bytes_atomic(path, &bytes)
    }

    /// The bytes of [`Image::write_exr`]'s file (`path` names it in errors), to encode apart
    /// from writing (several images encoded at once, written in order).
    pub fn exr_bytes(&self, precision: ExrPrecision, path: &Path) -> Result<Vec<u8>> {
        use exr::prelude::*;
        let (w, h) = (self.width, self.height);
        let mut out = std::io::Cursor::new(Vec::new());
        let written = match precision {
            ExrPrecision::F32 => {
                let ch = SpecificChannels::rgb(|pos: Vec2<usize>| {
                    let p = self.data[pos.y() * w + pos.x()];
                    (p.x, p.y, p.z)
                });
                exr::image::Image::from_encoded_channels((w, h), Encoding::SMALL_LOSSLESS, ch)
                    .write()
                    .to_buffered(&mut out)
            }
            ExrPrecision::F16 => {
                let ch = SpecificChannels::rgb(|pos: Vec2<usize>| {
                    let p = self.data[pos.y() * w + pos.x()];
                    let h = |v: f32| f16::from_f32(v.clamp(-HALF_MAX, HALF_MAX));
                    (h(p.x), h(p.y), h(p.z))
                });
                exr::image::Image::from_encoded_channels((w, h), Encoding::SMALL_LOSSLESS, ch)
                    .write()
                    .to_buffered(&mut out)
            }
        };
        written.map_err(|e| CoreError::ImageWrite {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Ok(out.into_inner())
    }

    /// 8-bit sRGB pixels after multiplying by `exposure` (clamped to [0, 1]); NaN shows as magenta.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.data.len() * 3);
        for p in &self.data {
            if !crate::color::is_finite(*p) {
                out.extend_from_slice(&[255, 0, 255]);
                continue;
            }
            for c in p.to_array() {
                let v = srgb_oetf((c * exposure).clamp(0.0, 1.0));
                out.push((v * 255.0 + 0.5) as u8);
            }
        }
        out
    }

    /// Writes an sRGB PNG preview (linear values × `exposure`, clamped), atomically.
    pub fn write_png(&self, path: &Path, exposure: f32) -> Result<()> {
        let bytes = self.png_bytes(exposure, path)?;
        crate::fsutil::write_bytes_atomic(path, &bytes)
    }

    /// The bytes of [`Image::write_png`]'s file (`path` names it in errors).
    pub fn png_bytes(&self, exposure: f32, path: &Path) -> Result<Vec<u8>> {
        let pixels = self.to_srgb8(exposure);
        let mut out = std::io::Cursor::new(Vec::new());
        image::write_buffer_with_format(
            &mut out,
            &pixels,
            self.width as u32,
            self.height as u32,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| CoreError::ImageWrite {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        Ok(out.into_inner())
    }

    /// Reads an 8-bit PNG (sRGB values are returned as stored, divided by 255).
    pub fn read_png(path: &Path) -> Result<Image> {
        let img = image::open(path)
            .map_err(|e| CoreError::Exr {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?
            .to_rgb8();
        let (w, h) = (img.width() as usize, img.height() as usize);
        let data = img
            .pixels()
            .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0)
            .collect();
        Ok(Image {
            width: w,
            height: h,
            data,
        })
    }

    /// An exposure that maps the 99th luminance percentile to 0.9 (for previews of HDR images).
    pub fn auto_exposure(&self) -> f32 {
        let mut l: Vec<f32> = self
            .data
            .iter()
            .map(|&p| crate::color::luminance(p))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        if l.is_empty() {
            return 1.0;
        }
        let k = ((l.len() as f32 * 0.99) as usize).min(l.len() - 1);
        let (_, v, _) = l.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        if *v > 0.0 {
            0.9 / *v
        } else {
            1.0
        }
    }
}

/// The size of the EXR file at `path`, after refusing an empty file and a header that declares
/// far more pixels than the file could hold.
fn exr_size_checked(path: &Path) -> Result<u64> {
    let size = std::fs::metadata(path)
        .map_err(|e| CoreError::io(path, e))?
        .len();
    let broken = |what: String| CoreError::Exr {
        path: path.to_path_buf(),
        message: what,
    };
    if size == 0 {
        return Err(broken(
            "the file is empty (0 bytes): an interrupted copy or render? write it again".into(),
        ));
    }
    // The reader allocates what the header declares: a corrupt size would ask for
    // gigabytes. Real files carry at least a byte per ~2000 pixels (even a constant image).
    if let Ok(meta) = exr::meta::MetaData::read_from_file(path, false) {
        let limit = (16u64 << 20) + size * 2048;
        for h in meta.headers.iter() {
            let px = h.layer_size.0 as u64 * h.layer_size.1 as u64;
            if px > limit {
                return Err(broken(format!(
                    "the header declares {}x{} pixels in a {size}-byte file: corrupt",
                    h.layer_size.0, h.layer_size.1
                )));
            }
        }
    }
    Ok(size)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Zeros, negatives and NaN are black; one channel at 1e-6 is light.
    #[test]
    fn a_view_is_black_when_nothing_finite_is_above_zero() {
        let mut img = Image::new(3, 2);
        assert!(img.is_black());
        img.data[1] = Vec3::new(-0.5, 0.0, -1.0);
        img.data[2] = Vec3::splat(f32::NAN);
        assert!(img.is_black());
        img.data[4].y = 1e-6;
        assert!(!img.is_black());
    }

    /// One set pixel grows into the 3×3 square around it (cut at the border); radius 0 and an
    /// empty mask change nothing.
    #[test]
    fn dilate_grows_a_mask_by_a_square() {
        let (w, h) = (7, 5);
        let mut m = vec![false; w * h];
        m[2 * w + 1] = true;
        let d = dilate(&m, w, h, 1);
        for y in 0..h {
            for x in 0..w {
                let near = x <= 2 && (1..=3).contains(&y);
                assert_eq!(d[y * w + x], near, "pixel ({x}, {y})");
            }
        }
        assert_eq!(dilate(&m, w, h, 0), m);
        assert!(dilate(&vec![false; w * h], w, h, 3).iter().all(|&b| !b));
    }

    /// A lamp pixel marks its neighbours within the radius, not itself, not beyond, and not
    /// for a contrast it does not reach; noise below the floor marks nothing.
    #[test]
    fn bleed_mask_marks_the_ring_around_a_bright_pixel() {
        let (w, h) = (9, 9);
        let mut img = Image::new(w, h);
        img.data.fill(Vec3::ONE);
        img.data[4 * w + 4] = Vec3::splat(20.0);
        let m = bleed_mask(&img, 2, 10.0, 0.01);
        for y in 0..h {
            for x in 0..w {
                let near = x.abs_diff(4) <= 2 && y.abs_diff(4) <= 2 && (x, y) != (4, 4);
                assert_eq!(m[y * w + x], near, "pixel ({x}, {y})");
            }
        }
        assert!(bleed_mask(&img, 2, 25.0, 0.01).iter().all(|&b| !b));
        // A dark view with noise, 1e-4 next to 5e-3: below the floor, no edge.
        for (i, c) in img.data.iter_mut().enumerate() {
            *c = Vec3::splat(if i % 2 == 0 { 1e-4 } else { 5e-3 });
        }
        assert!(bleed_mask(&img, 2, 10.0, 0.01).iter().all(|&b| !b));
    }

    fn test_image() -> Image {
        let mut img = Image::new(7, 5);
        for y in 0..5 {
            for x in 0..7 {
                img.set(
                    x,
                    y,
                    Vec3::new(x as f32 * 0.1, y as f32 * 1e-6, 1e5 / (1 + x + y) as f32),
                );
            }
        }
        img
    }

    #[test]
    fn exr_f32_round_trip_is_exact() {
        let dir = std::env::temp_dir().join(format!("fipt-img-{}", std::process::id()));
        let p = dir.join("a.exr");
        let img = test_image();
        img.write_exr(&p, ExrPrecision::F32).unwrap();
        let back = Image::read_exr(&p).unwrap();
        assert_eq!(img, back);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn empty_and_truncated_exrs_say_so() {
        let dir = std::env::temp_dir().join(format!("fipt-img-trunc-{}", std::process::id()));
        let p = dir.join("a.exr");
        let mut img = Image::new(32, 16);
        for (i, v) in img.data.iter_mut().enumerate() {
            *v = Vec3::splat(i as f32);
        }
        img.write_exr(&p, ExrPrecision::F32).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        for (cut, want) in [
            (0, "empty"),
            (bytes.len() / 2, "ends early"),
            (40, "truncated"),
        ] {
            std::fs::write(&p, &bytes[..cut]).unwrap();
            let err = Image::read_exr(&p).unwrap_err().to_string();
            assert!(
                err.contains(want) || err.contains("truncated"),
                "{cut} bytes: {err}"
            );
            assert!(err.contains("a.exr"), "{err}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn exr_f16_round_trip_within_half_precision() {
        let dir = std::env::temp_dir().join(format!("fipt-img16-{}", std::process::id()));
        let p = dir.join("a.exr");
        let img = test_image();
        img.write_exr(&p, ExrPrecision::F16).unwrap();
        let back = Image::read_exr(&p).unwrap();
        for (a, b) in img.data.iter().zip(&back.data) {
            for (x, y) in a.to_array().iter().zip(b.to_array()) {
                // half has an 11-bit significand; values below 6e-5 are subnormal (abs 6e-8).
                let x = x.min(HALF_MAX);
                assert!((x - y).abs() <= x.abs() * 1e-3 + 6e-8, "{x} vs {y}");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn png_round_trip_matches_srgb_quantisation() {
        let dir = std::env::temp_dir().join(format!("fipt-png-{}", std::process::id()));
        let p = dir.join("a.png");
        let mut img = Image::new(4, 3);
        img.set(1, 1, Vec3::new(0.18, 1.0, 4.0));
        img.write_png(&p, 1.0).unwrap();
        let back = Image::read_png(&p).unwrap();
        assert_eq!((back.width, back.height), (4, 3));
        let v = back.get(1, 1);
        assert!((v.x - srgb_oetf(0.18)).abs() < 1.0 / 255.0);
        assert_eq!(v.y, 1.0);
        assert_eq!(v.z, 1.0, "values above 1 clamp");
        assert_eq!(back.get(0, 0), Vec3::ZERO);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_pixels_are_counted_rejected_or_clamped() {
        let mut img = Image::filled(3, 2, Vec3::ONE);
        img.set(1, 0, Vec3::new(f32::NAN, 2.0, -1.0));
        img.set(2, 1, Vec3::new(f32::INFINITY, 1.0, 1.0));
        let c = img.count_bad();
        assert_eq!((c.nan, c.inf, c.negative, c.first), (1, 1, 1, Some((1, 0))));
        let err = img
            .clone()
            .sanitize(BadPixelPolicy::Reject, Path::new("x.exr"))
            .unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("x.exr") && msg.contains("1 NaN") && msg.contains("clamp"),
            "{msg}"
        );
        img.sanitize(BadPixelPolicy::Clamp, Path::new("x.exr"))
            .unwrap();
        assert_eq!(img.get(1, 0), Vec3::new(0.0, 2.0, 0.0));
        assert_eq!(img.get(2, 1), Vec3::new(2.0, 1.0, 1.0));
        assert_eq!(img.count_bad().total(), 0);
    }

    #[test]
    fn failed_write_leaves_previous_file() {
        let dir = std::env::temp_dir().join(format!("fipt-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("keep.json");
        std::fs::write(&p, "old").unwrap();
        let r = crate::fsutil::write_atomic(&p, |tmp| {
            std::fs::write(tmp, "partial").unwrap();
            Err(CoreError::invalid(tmp, "simulated failure"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "temporary removed"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}

/// `mask` (row-major, `width` × `height`) grown by `radius` pixels (a square): a pixel is set
/// when any within `radius` is.
pub fn dilate(mask: &[bool], width: usize, height: usize, radius: usize) -> Vec<bool> {
    assert_eq!(
        mask.len(),
        width * height,
        "dilate: mask of {} for {width}×{height}",
        mask.len()
    );
    window_max(mask, width, height, radius, |a, b| a || b)
}

/// The largest of each pixel's neighbours within `radius` (a square; the pixel included) by
/// `max`: a separable filter, rows then columns.
fn window_max<T: Copy + Default>(
    v: &[T],
    w: usize,
    h: usize,
    radius: usize,
    max: impl Fn(T, T) -> T,
) -> Vec<T> {
    let mut rows = vec![T::default(); w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(radius), (x + radius).min(w - 1));
            rows[y * w + x] = v[y * w + a..=y * w + b]
                .iter()
                .copied()
                .fold(T::default(), &max);
        }
    }
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let (a, b) = (y.saturating_sub(radius), (y + radius).min(h - 1));
            (a..=b).map(|yy| rows[yy * w + x]).fold(T::default(), &max)
        })
        .collect()
}

/// The contrast of [`bleed_mask`] the training set uses by default (`train.bleed_contrast`).
pub const BLEED_CONTRAST: f32 = 10.0;

/// Pixels within `radius` pixels (a square) of one at least `contrast` times brighter, by
/// luminance; a pixel darker than `floor` counts as `floor`.
pub fn bleed_mask(img: &Image, radius: usize, contrast: f32, floor: f32) -> Vec<bool> {
    let (w, h) = (img.width, img.height);
    let lum: Vec<f32> = img
        .data
        .iter()
        .map(|&c| crate::color::luminance(c).max(0.0))
        .collect();
    let floor = floor.max(f32::MIN_POSITIVE);
    let brightest = window_max(&lum, w, h, radius, f32::max);
    (0..w * h)
        .map(|i| brightest[i] >= contrast * lum[i].max(floor))
        .collect()
}

/// The median luminance the pipeline works at: views are scaled to it (camera exposure is
/// arbitrary; the thresholds and the display-space loss are not). The presets were tuned on
/// scenes whose median luminance is 0.15–0.20.
pub const CANONICAL_MEDIAN: f32 = 0.18;

/// Median luminance of the finite pixels of `images` (every 7th pixel; 0 for black views).
pub fn median_luminance(images: &[Image]) -> f32 {
    let mut l: Vec<f32> = images
        .iter()
        .flat_map(|i| i.data.iter().step_by(7))
        .map(|&p| crate::color::luminance(p))
        .filter(|v| v.is_finite())
        .collect();
    median(&mut l)
}

/// The median of `values` (reordered; 0 when empty).
pub fn median(values: &mut [f32]) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let n = values.len() / 2;
    *values.select_nth_unstable_by(n, f32::total_cmp).1
}

/// The exposure scale s of views with median luminance `median`: the pipeline works on
/// images / s, whose median is [`CANONICAL_MEDIAN`], and scales radiance results back by s.
/// 1 for black views (nothing to normalise).
pub fn exposure_scale(median: f32) -> f32 {
    if median > 0.0 && median.is_finite() {
        median / CANONICAL_MEDIAN
    } else {
        1.0
    }
}

#[cfg(test)]
mod exposure_tests {
    use super::*;

    #[test]
    fn exposure_brings_the_median_to_the_canonical_one() {
        assert_eq!(exposure_scale(0.18), 1.0);
        assert_eq!(exposure_scale(0.0), 1.0);
        assert_eq!(exposure_scale(f32::NAN), 1.0);
        for k in [1e-6f32, 0.7, 1e5] {
            let m = 0.31 * k;
            assert!(((m / exposure_scale(m)) / CANONICAL_MEDIAN - 1.0).abs() < 1e-6);
        }
        let img = Image {
            width: 3,
            height: 1,
            data: vec![Vec3::splat(1.0), Vec3::splat(2.0), Vec3::splat(f32::NAN)],
        };
        assert_eq!(median_luminance(&[img]), 1.0);
    }
}

/// The four source pixels and weights of `out(x, y) = in(x + dx, y + dy)` (bilinear, clamped
/// at the borders).
fn bilinear_taps(
    x: usize,
    y: usize,
    (w, h): (usize, usize),
    (dx, dy): (f32, f32),
) -> [(usize, f32); 4] {
    let (sx, sy) = (x as f32 + dx, y as f32 + dy);
    let (x0, y0) = (sx.floor(), sy.floor());
    let (fx, fy) = (sx - x0, sy - y0);
    let cx = |v: f32| (v.max(0.0) as usize).min(w - 1);
    let cy = |v: f32| (v.max(0.0) as usize).min(h - 1);
    let (xa, xb, ya, yb) = (cx(x0), cx(x0 + 1.0), cy(y0), cy(y0 + 1.0));
    [
        (ya * w + xa, (1.0 - fx) * (1.0 - fy)),
        (ya * w + xb, fx * (1.0 - fy)),
        (yb * w + xa, (1.0 - fx) * fy),
        (yb * w + xb, fx * fy),
    ]
}

/// `img` moved so that what it shows at `(x + dx, y + dy)` lands at `(x, y)` (bilinear; the
/// borders repeat). Lays a view whose content sits `(dx, dy)` pixels off its camera's
/// geometry back over it.
pub fn shifted(img: &Image, dx: f32, dy: f32) -> Image {
    let mut out = Image::new(img.width, img.height);
    for y in 0..img.height {
        for x in 0..img.width {
            let taps = bilinear_taps(x, y, (img.width, img.height), (dx, dy));
            let v = taps
                .iter()
                .filter(|t| t.1 > 0.0)
                .map(|&(i, t)| img.data[i] * t)
                .sum();
            out.set(x, y, v);
        }
    }
    out
}

/// A pixel mask moved as [`shifted`] moves its image: a pixel is set when any source pixel
/// that [`shifted`] mixes into it is (a clipped value mixed in is still not a measurement).
pub fn shifted_mask(mask: &[bool], width: usize, height: usize, dx: f32, dy: f32) -> Vec<bool> {
    let mut out = vec![false; mask.len()];
    for y in 0..height {
        for x in 0..width {
            let taps = bilinear_taps(x, y, (width, height), (dx, dy));
            out[y * width + x] = taps.iter().any(|&(i, t)| t > 0.0 && mask[i]);
        }
    }
    out
}

#[cfg(test)]
mod shift_tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Image {
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                img.set(x, y, Vec3::new(x as f32, y as f32, (x * y) as f32));
            }
        }
        img
    }

    #[test]
    fn a_whole_shift_moves_pixels_and_a_half_one_averages_them() {
        let img = ramp(6, 4);
        let s = shifted(&img, 1.0, -1.0);
        assert_eq!(s.get(2, 2), img.get(3, 1));
        assert_eq!(s.get(5, 0), img.get(5, 0), "borders repeat");
        let zero = shifted(&img, 0.0, 0.0);
        assert_eq!(zero, img);
        // A linear ramp is reproduced exactly inside the image at any sub-pixel shift.
        let s = shifted(&img, 0.25, 0.5);
        let v = s.get(2, 1);
        assert!((v.x - 2.25).abs() < 1e-5 && (v.y - 1.5).abs() < 1e-5, "{v}");
        let mask: Vec<bool> = (0..24).map(|i| i == 9).collect();
        let m = shifted_mask(&mask, 6, 4, 0.5, 0.0);
        let set: Vec<usize> = (0..24).filter(|&i| m[i]).collect();
        assert_eq!(set, vec![8, 9], "both pixels that mix the masked one in");
        assert_eq!(shifted_mask(&mask, 6, 4, 0.0, 0.0), mask);
    }
}
