//! Exposure settings from a photo's EXIF (JPEG, TIFF, PNG, HEIF, WebP; read with the
//! `kamadak-exif` crate): exposure time, f-number, ISO and the camera, and the relative
//! exposure of each view they give (time × ISO / N²), for captures whose views were taken
//! at different settings.
//!
//! EXR files hold no EXIF: they read as `Ok(None)`, as do PNG and JPEG files without it.
use crate::error::{CoreError, Result};
use ::exif::{Field, In, Reader, Tag, Value};
use std::path::Path;

/// ISO assumed for a view whose EXIF has none (only ratios of exposures matter).
const DEFAULT_ISO: f32 = 100.0;
/// f-number assumed for a view whose EXIF has none (only ratios of exposures matter).
const DEFAULT_F_NUMBER: f32 = 1.0;

/// What a photo's EXIF says of its exposure.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ExifExposure {
    /// Exposure time in seconds (`ExposureTime`).
    pub exposure_time: Option<f32>,
    /// The aperture's f-number N (`FNumber`).
    pub f_number: Option<f32>,
    /// Sensitivity (`PhotographicSensitivity`, else `ISOSpeed`).
    pub iso: Option<f32>,
    /// `Make` and `Model`, joined ("Canon EOS R5"; the make once when the model repeats it).
    pub camera: Option<String>,
}

impl ExifExposure {
    /// Relative exposure: time × ISO / N² (the light that reached the sensor, times the
    /// gain); None unless the exposure time is present. A missing ISO counts as 100 and a
    /// missing f-number as 1: constants, which cancel when every view lacks them
    /// ([`relative_exposures`] fills a value some views lack from the others).
    pub fn relative(&self) -> Option<f32> {
        let t = self.exposure_time?;
        let iso = self.iso.unwrap_or(DEFAULT_ISO);
        let n = self.f_number.unwrap_or(DEFAULT_F_NUMBER);
        Some(t * iso / (n * n))
    }
}

/// Reads a file's EXIF exposure settings.
///
/// `Ok(None)` when the file has no EXIF (EXR; PNG or JPEG without it; a format EXIF does not
/// live in), when its EXIF cannot be parsed, or when the EXIF holds none of the four
/// fields. An error only when the file cannot be opened or read — whatever its kind, so a
/// missing `.exr` is an error too.
pub fn read(path: &Path) -> Result<Option<ExifExposure>> {
    let file = std::fs::File::open(path).map_err(|e| CoreError::io(path, e))?;
    let parsed = Reader::new()
        .continue_on_error(true)
        .read_from_container(&mut std::io::BufReader::new(file))
        .or_else(|e| e.distill_partial_result(|_| {}));
    let exif = match parsed {
        Ok(exif) => exif,
        // A file that ends early is a broken container, not an unreadable file.
        Err(::exif::Error::Io(e)) if e.kind() != std::io::ErrorKind::UnexpectedEof => {
            return Err(CoreError::io(path, e))
        }
        Err(_) => return Ok(None),
    };
    let field = |tag: Tag| exif.get_field(tag, In::PRIMARY);
    let positive = |tag: Tag| field(tag).and_then(number).filter(|v| *v > 0.0);
    let iso = positive(Tag::PhotographicSensitivity)
        // 65535 is the 16-bit field saturated: the 32-bit one holds the value.
        .filter(|v| *v < 65535.0)
        .or_else(|| positive(Tag::ISOSpeed))
        .or_else(|| positive(Tag::PhotographicSensitivity));
    let found = ExifExposure {
        exposure_time: positive(Tag::ExposureTime),
        f_number: positive(Tag::FNumber),
        iso,
        camera: camera_name(field(Tag::Make), field(Tag::Model)),
    };
    let empty = found.exposure_time.is_none()
        && found.f_number.is_none()
        && found.iso.is_none()
        && found.camera.is_none();
    Ok((!empty).then_some(found))
}

/// Per-view relative exposures ([`ExifExposure::relative`]) divided by their median, so 1 is
/// a typical view's; when every view has an exposure time. A view without an f-number or
/// ISO takes the median of the views that have one (the same lens and settings are the
/// likeliest); when none has one the default cancels. Else the error says how many views
/// lack an exposure time and the first of them (by index).
pub fn relative_exposures(views: &[Option<ExifExposure>]) -> Result<Vec<f32>, String> {
    let lacking: Vec<usize> = (0..views.len())
        .filter(|&k| views[k].as_ref().and_then(|e| e.exposure_time).is_none())
        .collect();
    if let Some(first) = lacking.first() {
        return Err(format!(
            "{} of {} views have no exposure time in their EXIF (the first is view {first}): \
             relative exposures need it in every view",
            lacking.len(),
            views.len()
        ));
    }
    let present = views.iter().flatten();
    let typical = |get: fn(&ExifExposure) -> Option<f32>| {
        let mut v: Vec<f32> = present.clone().filter_map(get).collect();
        (!v.is_empty()).then(|| crate::image::median(&mut v))
    };
    let f_number = typical(|e| e.f_number);
    let iso = typical(|e| e.iso);
    let mut rel: Vec<f32> = present
        .map(|e| {
            let filled = ExifExposure {
                f_number: e.f_number.or(f_number),
                iso: e.iso.or(iso),
                ..e.clone()
            };
            filled.relative().unwrap_or(1.0)
        })
        .collect();
    let median = crate::image::median(&mut rel.clone());
    if median > 0.0 && median.is_finite() {
        rel.iter_mut().for_each(|r| *r /= median);
    }
    Ok(rel)
}

/// A field's first value as a number (rationals, integers, floats), when finite.
fn number(field: &Field) -> Option<f32> {
    let v = match &field.value {
        Value::Rational(r) => r.first().filter(|r| r.denom != 0).map(|r| r.to_f64()),
        Value::SRational(r) => r.first().filter(|r| r.denom != 0).map(|r| r.to_f64()),
        Value::Float(f) => f.first().map(|f| *f as f64),
        Value::Double(f) => f.first().copied(),
        other => other.get_uint(0).map(f64::from),
    }?;
    v.is_finite().then_some(v as f32)
}

/// The ASCII text of a field (trimmed; None when empty).
fn text(field: Option<&Field>) -> Option<String> {
    let Value::Ascii(parts) = &field?.value else {
        return None;
    };
    let s = String::from_utf8_lossy(parts.first()?)
        .trim_matches(|c: char| c == '\0' || c.is_whitespace())
        .to_string();
    (!s.is_empty()).then_some(s)
}

/// "Make Model", or the model alone when it already starts with the make.
fn camera_name(make: Option<&Field>, model: Option<&Field>) -> Option<String> {
    match (text(make), text(model)) {
        (Some(make), Some(model)) => {
            if model.to_lowercase().starts_with(&make.to_lowercase()) {
                Some(model)
            } else {
                Some(format!("{make} {model}"))
            }
        }
        (make, model) => make.or(model),
    }
}

/// `jpeg` (a whole JPEG file) with an EXIF segment holding `exp`'s settings, spliced in after
/// its start-of-image marker: what a camera writes (`fipt degrade --exif`).
pub fn jpeg_with_exif(jpeg: &[u8], exp: &ExifExposure) -> Result<Vec<u8>, String> {
    if jpeg.len() < 2 || jpeg[..2] != [0xFF, 0xD8] {
        return Err("not a JPEG (no start-of-image marker)".into());
    }
    let rational = |v: f32| {
        // Seconds as 1/n when under a second (as cameras write them), else v/1000.
        let r = if v > 0.0 && v < 1.0 {
            ::exif::Rational::from((1000, (1000.0 / v).round() as u32))
        } else {
            ::exif::Rational::from(((v * 1000.0).round() as u32, 1000))
        };
        Value::Rational(vec![r])
    };
    let field = |tag: Tag, value: Value| Field {
        tag,
        ifd_num: In::PRIMARY,
        value,
    };
    let mut fields = vec![];
    if let Some(t) = exp.exposure_time {
        fields.push(field(Tag::ExposureTime, rational(t)));
    }
    if let Some(n) = exp.f_number {
        fields.push(field(Tag::FNumber, rational(n)));
    }
    if let Some(iso) = exp.iso {
        fields.push(field(
            Tag::PhotographicSensitivity,
            Value::Short(vec![iso.round() as u16]),
        ));
    }
    if let Some(c) = &exp.camera {
        fields.push(field(Tag::Model, Value::Ascii(vec![c.as_bytes().to_vec()])));
    }
    let mut w = ::exif::experimental::Writer::new();
    for f in &fields {
        w.push_field(f);
    }
    let mut tiff = std::io::Cursor::new(Vec::new());
    w.write(&mut tiff, true).map_err(|e| e.to_string())?;
    let payload = [b"Exif\0\0".as_slice(), tiff.get_ref()].concat();
    let len = u16::try_from(payload.len() + 2).map_err(|_| "EXIF over 64 KiB")?;
    let mut out = jpeg[..2].to_vec();
    out.extend([0xFF, 0xE1]);
    out.extend(len.to_be_bytes());
    out.extend(payload);
    out.extend(&jpeg[2..]);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_temp::Temp;

    /// A TIFF entry: tag, type (2 ASCII, 3 SHORT, 4 LONG, 5 RATIONAL), count, value bytes.
    type Entry = (u16, u16, u32, Vec<u8>);

    fn rational(num: u32, denom: u32) -> Vec<u8> {
        [num.to_le_bytes(), denom.to_le_bytes()].concat()
    }

    fn ascii(s: &str) -> Entry {
        let mut b = s.as_bytes().to_vec();
        b.push(0);
        (0, 2, b.len() as u32, b)
    }

    /// Size of an IFD at `entries` with its out-of-line values after it.
    fn ifd_size(entries: &[Entry]) -> usize {
        let data: usize = entries
            .iter()
            .filter(|e| e.3.len() > 4)
            .map(|e| e.3.len().next_multiple_of(2))
            .sum();
        2 + 12 * entries.len() + 4 + data
    }

    /// Appends an IFD (entries sorted by tag, next-IFD offset 0) and its values to `out`,
    /// whose byte 0 is the TIFF header's.
    fn push_ifd(out: &mut Vec<u8>, entries: &[Entry]) {
        let mut data_at = out.len() + 2 + 12 * entries.len() + 4;
        let mut data = Vec::new();
        out.extend((entries.len() as u16).to_le_bytes());
        for (tag, ty, count, bytes) in entries {
            out.extend(tag.to_le_bytes());
            out.extend(ty.to_le_bytes());
            out.extend(count.to_le_bytes());
            if bytes.len() <= 4 {
                let mut inline = bytes.clone();
                inline.resize(4, 0);
                out.extend(inline);
            } else {
                out.extend((data_at as u32).to_le_bytes());
                let mut b = bytes.clone();
                b.resize(b.len().next_multiple_of(2), 0);
                data_at += b.len();
                data.extend(b);
            }
        }
        out.extend(0u32.to_le_bytes());
        out.extend(data);
    }

    /// A little-endian TIFF: IFD0 with Make, Model and the Exif IFD pointer; the Exif IFD
    /// with ExposureTime 1/60, FNumber 2.8, ISO 400.
    fn exif_tiff() -> Vec<u8> {
        let with_tag = |tag: u16, e: Entry| (tag, e.1, e.2, e.3);
        let mut ifd0 = vec![
            with_tag(0x010F, ascii("Fipt")),
            with_tag(0x0110, ascii("Fipt Test Camera")),
            (0x8769, 4, 1, vec![0; 4]),
        ];
        let exif_at = 8 + ifd_size(&ifd0);
        ifd0[2].3 = (exif_at as u32).to_le_bytes().to_vec();
        let exif_ifd = vec![
            (0x829A, 5, 1, rational(1, 60)),
            (0x829D, 5, 1, rational(28, 10)),
            (0x8827, 3, 1, 400u16.to_le_bytes().to_vec()),
        ];
        let mut out = b"II\x2A\x00".to_vec();
        out.extend(8u32.to_le_bytes());
        push_ifd(&mut out, &ifd0);
        assert_eq!(out.len(), exif_at);
        push_ifd(&mut out, &exif_ifd);
        out
    }

    /// A 16×16 JPEG encoded by `image`, with `app1` (a TIFF) spliced in after SOI.
    fn jpeg(app1: Option<Vec<u8>>) -> Vec<u8> {
        let img =
            image::RgbImage::from_fn(16, 16, |x, y| image::Rgb([x as u8 * 16, y as u8 * 16, 90]));
        let mut enc = std::io::Cursor::new(Vec::new());
        img.write_to(&mut enc, image::ImageFormat::Jpeg).unwrap();
        let enc = enc.into_inner();
        assert_eq!(&enc[..2], &[0xFF, 0xD8]);
        let Some(tiff) = app1 else {
            return enc;
        };
        let payload = [b"Exif\0\0".as_slice(), &tiff].concat();
        let len = (payload.len() + 2) as u16;
        let mut out = enc[..2].to_vec();
        out.extend([0xFF, 0xE1]);
        out.extend(len.to_be_bytes());
        out.extend(payload);
        out.extend(&enc[2..]);
        out
    }

    #[test]
    fn a_jpeg_with_exif_gives_its_exposure() {
        let tmp = Temp::new();
        let p = tmp.0.join("exif.jpg");
        std::fs::write(&p, jpeg(Some(exif_tiff()))).unwrap();
        // Still a JPEG the image crate decodes.
        assert_eq!(image::image_dimensions(&p).unwrap(), (16, 16));
        let e = read(&p).unwrap().expect("EXIF present");
        assert!(
            (e.exposure_time.unwrap() - 1.0 / 60.0).abs() < 1e-7,
            "{e:?}"
        );
        assert!((e.f_number.unwrap() - 2.8).abs() < 1e-6, "{e:?}");
        assert_eq!(e.iso, Some(400.0));
        assert_eq!(e.camera.as_deref(), Some("Fipt Test Camera"));
        let expected = (1.0 / 60.0) * 400.0 / (2.8 * 2.8);
        assert!((e.relative().unwrap() - expected).abs() < 1e-6);
    }

    #[test]
    fn written_exif_reads_back() {
        let tmp = Temp::new();
        let p = tmp.0.join("written.jpg");
        let e = ExifExposure {
            exposure_time: Some(1.0 / 125.0),
            f_number: Some(2.0),
            iso: Some(200.0),
            camera: Some("fipt degrade".into()),
        };
        std::fs::write(&p, jpeg_with_exif(&jpeg(None), &e).unwrap()).unwrap();
        assert_eq!(image::image_dimensions(&p).unwrap(), (16, 16));
        let back = read(&p).unwrap().unwrap();
        assert!(
            (back.exposure_time.unwrap() - 0.008).abs() < 1e-7,
            "{back:?}"
        );
        assert_eq!((back.f_number, back.iso), (Some(2.0), Some(200.0)));
        assert_eq!(back.camera.as_deref(), Some("fipt degrade"));
        assert!(jpeg_with_exif(b"PNG", &e).is_err());
    }

    #[test]
    fn files_without_exif_give_none_and_missing_files_an_error() {
        let tmp = Temp::new();
        let plain = tmp.0.join("plain.jpg");
        std::fs::write(&plain, jpeg(None)).unwrap();
        assert_eq!(read(&plain).unwrap(), None);
        let png = tmp.0.join("plain.png");
        image::RgbImage::new(4, 4).save(&png).unwrap();
        assert_eq!(read(&png).unwrap(), None);
        let exr = tmp.0.join("view.exr");
        crate::image::Image::new(4, 4)
            .write_exr(&exr, crate::image::ExrPrecision::F16)
            .unwrap();
        assert_eq!(read(&exr).unwrap(), None);
        let text = tmp.0.join("notes.txt");
        std::fs::write(&text, "not an image").unwrap();
        assert_eq!(read(&text).unwrap(), None);
        // A JPEG whose APP1 holds a broken TIFF: no usable EXIF, not an error.
        let broken = tmp.0.join("broken.jpg");
        std::fs::write(&broken, jpeg(Some(b"II\x2A\x00\xFF\xFF\xFF\x00".to_vec()))).unwrap();
        assert_eq!(read(&broken).unwrap(), None);
        // A file that is not there, EXR or not, is an error naming it.
        for missing in ["missing.exr", "missing.jpg"] {
            let e = read(&tmp.0.join(missing)).unwrap_err().to_string();
            assert!(e.contains(missing), "{e}");
        }
    }

    fn exposure(t: Option<f32>, n: Option<f32>, iso: Option<f32>) -> Option<ExifExposure> {
        Some(ExifExposure {
            exposure_time: t,
            f_number: n,
            iso,
            camera: None,
        })
    }

    #[test]
    fn relative_exposures_are_normalised_to_their_median() {
        let views = [
            exposure(Some(1.0 / 60.0), Some(2.8), Some(400.0)),
            exposure(Some(1.0 / 30.0), Some(2.8), Some(400.0)),
            exposure(Some(1.0 / 60.0), Some(2.8), Some(100.0)),
        ];
        let rel = relative_exposures(&views).unwrap();
        for (r, e) in rel.iter().zip([1.0, 2.0, 0.25]) {
            assert!((r - e).abs() < 1e-6, "{rel:?}");
        }
        // A view without f-number and ISO takes the others' (median): same as theirs.
        let views = [
            exposure(Some(0.01), Some(4.0), Some(200.0)),
            exposure(Some(0.02), None, None),
            exposure(Some(0.04), Some(4.0), Some(200.0)),
        ];
        let rel = relative_exposures(&views).unwrap();
        for (r, e) in rel.iter().zip([0.5, 1.0, 2.0]) {
            assert!((r - e).abs() < 1e-6, "{rel:?}");
        }
        // None has them: the defaults cancel.
        let views = [
            exposure(Some(0.5), None, None),
            exposure(Some(0.25), None, None),
        ];
        let rel = relative_exposures(&views).unwrap();
        assert!((rel[0] / rel[1] - 2.0).abs() < 1e-6, "{rel:?}");
        assert_eq!(relative_exposures(&[]).unwrap(), Vec::<f32>::new());
    }

    #[test]
    fn views_without_an_exposure_time_are_counted() {
        let views = [
            exposure(Some(0.01), Some(2.0), None),
            None,
            exposure(None, Some(2.0), Some(100.0)),
        ];
        let e = relative_exposures(&views).unwrap_err();
        assert!(e.contains("2 of 3 views") && e.contains("view 1"), "{e}");
        assert_eq!(exposure(None, Some(2.0), None).unwrap().relative(), None);
    }
}
