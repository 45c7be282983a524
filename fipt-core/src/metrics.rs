//! Image metrics used by tests and by `fipt eval`.
use glam::Vec3;

/// Mean squared error over the pixels where `mask` is true (all pixels when `mask` is None).
/// Returns None when no pixel is selected.
pub fn mse(a: &[Vec3], b: &[Vec3], mask: Option<&[bool]>) -> Option<f64> {
    assert_eq!(a.len(), b.len(), "mse: images differ in size");
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for i in 0..a.len() {
        if mask.is_some_and(|m| !m[i]) {
            continue;
        }
        let d = a[i] - b[i];
        sum += (d.x as f64).powi(2) + (d.y as f64).powi(2) + (d.z as f64).powi(2);
        n += 3;
    }
    (n > 0).then(|| sum / n as f64)
}

/// PSNR in dB for signals with peak value `peak`; capped at 100 dB for identical inputs.
pub fn psnr(a: &[Vec3], b: &[Vec3], mask: Option<&[bool]>, peak: f64) -> Option<f64> {
    mse(a, b, mask).map(|m| {
        if m <= 1e-10 * peak * peak {
            100.0
        } else {
            10.0 * (peak * peak / m).log10()
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn psnr_of_known_error() {
        let a = vec![Vec3::splat(0.5); 10];
        let b = vec![Vec3::splat(0.6); 10];
        // mse = 0.01 → 20 dB
        assert!((psnr(&a, &b, None, 1.0).unwrap() - 20.0).abs() < 1e-5);
        let mask = vec![false; 10];
        assert!(psnr(&a, &b, Some(&mask), 1.0).is_none());
        assert_eq!(psnr(&a, &a, None, 1.0), Some(100.0));
    }
}

/// PSNR of HDR images as displayed: sRGB OETF of the linear values clamped to [0, 1], peak 1.
/// Used for re-render comparisons (the training loss works in the same space).
pub fn srgb_psnr(a: &[Vec3], b: &[Vec3], mask: Option<&[bool]>) -> Option<f64> {
    let t = |v: &[Vec3]| -> Vec<Vec3> {
        v.iter()
            .map(|p| {
                Vec3::from_array(p.to_array().map(|c| {
                    crate::color::srgb_oetf(if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })
                }))
            })
            .collect()
    };
    psnr(&t(a), &t(b), mask, 1.0)
}
