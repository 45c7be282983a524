//! One rule for every numeric setting and option: it has a documented range and a value
//! outside it (NaN included) is refused with a message naming the key, the value and the range
//! (`render.spp = 4000000000 (use 0..=65536)`). Sizes that multiply are checked with
//! [`product`] against a stated budget before any work starts.
use std::fmt::Display;

/// The largest radiance (W·m⁻²·sr⁻¹), intensity (W·sr⁻¹) or emission factor a light or an edit
/// may have: a path's throughput, the inverse of its pdfs and a pixel's sum of samples stay
/// far below f32's 3.4e38 (the sun's radiance is about 2e7).
pub const MAX_RADIANCE: f32 = 1e15;

/// The largest coordinate or size (metres) of a light or an inserted object: beyond it f32
/// keeps no millimetre of an indoor scene.
pub const MAX_EXTENT: f32 = 1e6;

/// A radiance-like value `v` in [0, [`MAX_RADIANCE`]].
pub fn radiance(key: &str, v: f32) -> Result<(), String> {
    check(key, v, 0.0, MAX_RADIANCE)
}

/// `key = v` refused unless `lo <= v <= hi` (NaN never is).
pub fn check<T: PartialOrd + Display + Copy>(key: &str, v: T, lo: T, hi: T) -> Result<(), String> {
    match (v.partial_cmp(&lo), v.partial_cmp(&hi)) {
        (Some(a), Some(b)) if a.is_ge() && b.is_le() => Ok(()),
        _ => Err(format!("{key} = {v} (use [{lo}, {hi}])")),
    }
}

/// `key = v` refused unless `0 < v <= hi` and finite (sizes, lengths, scales).
pub fn positive(key: &str, v: f64, hi: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 && v <= hi {
        Ok(())
    } else {
        Err(format!("{key} = {v} (use a value in (0, {hi}])"))
    }
}

/// A product of sizes (`what`: e.g. "spp × pixels") refused above `budget` with the factors
/// named, so that the message says which setting to lower.
pub fn product(
    what: &str,
    factors: &[(&str, f64)],
    budget: f64,
    unit: &str,
) -> Result<f64, String> {
    let total: f64 = factors.iter().map(|(_, v)| v).product();
    if total.is_finite() && total <= budget {
        return Ok(total);
    }
    let list: Vec<String> = factors.iter().map(|(k, v)| format!("{k} {v}")).collect();
    Err(format!(
        "{what} = {total:.3e} {unit} ({}) is more than the {budget:.3e} {unit} this machine can do in reasonable time and memory: lower one of them",
        list.join(" × ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_outside_their_range_and_nan_are_refused_by_name() {
        assert!(check("a", 3u32, 1, 4).is_ok());
        assert!(check("a", 1.0f32, 1.0, 4.0).is_ok());
        let e = check("render.spp", 4_000_000_000u64, 1, 65_536).unwrap_err();
        assert_eq!(e, "render.spp = 4000000000 (use [1, 65536])");
        assert!(check("x", f32::NAN, 0.0, 1.0)
            .unwrap_err()
            .contains("x = NaN"));
        assert!(positive("texel", 0.0, 10.0).is_err());
        assert!(positive("texel", f64::NAN, 10.0).is_err());
        assert!(positive("texel", f64::INFINITY, 10.0).is_err());
        assert!(positive("texel", 1e-3, 10.0).is_ok());
        let e = product("samples", &[("spp", 1e9), ("pixels", 1e5)], 1e12, "paths").unwrap_err();
        assert!(
            e.contains("spp 1000000000") && e.contains("pixels 100000"),
            "{e}"
        );
        assert_eq!(
            product("s", &[("a", 2.0), ("b", 3.0)], 10.0, "u").unwrap(),
            6.0
        );
    }
}
