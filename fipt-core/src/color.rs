//! Colour helpers: RGB is a `glam::Vec3` of linear radiance or reflectance.
use glam::Vec3;

/// Linear RGB (radiance, reflectance); an alias so that glam's maths applies directly.
pub type Rgb = Vec3;

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// sRGB opto-electronic transfer function of one linear value (no clamp above 1).
#[inline]
pub fn srgb_oetf(x: f32) -> f32 {
    if x <= 0.0031308 {
        12.92 * x.max(0.0)
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb_oetf`] on [0, 1]: linear value of an sRGB-encoded one.
#[inline]
pub fn srgb_eotf(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// True when all three channels are finite.
#[inline]
pub fn is_finite(c: Rgb) -> bool {
    c.x.is_finite() && c.y.is_finite() && c.z.is_finite()
}
