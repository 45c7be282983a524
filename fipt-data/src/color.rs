//! Colour helpers: RGB is a `glam::Vec3` of linear radiance or reflectance.
use glam::Vec3;

/// Linear RGB (radiance, reflectance); an alias so that glam's maths applies directly.
pub type Rgb = Vec3;

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Where the sRGB curve's linear segment ends (linear value).
pub const SRGB_KNEE: f32 = 0.003_130_8;

/// sRGB opto-electronic transfer function of one linear value (no clamp above 1; negative
/// values give 0).
#[inline]
pub fn srgb_oetf(x: f32) -> f32 {
    if x <= SRGB_KNEE {
        12.92 * x.max(0.0)
    } else {
        srgb_oetf_extended(x)
    }
}

/// The sRGB OETF continued linearly below 0 (12.92·x), as the training loss compares values:
/// a negative prediction keeps a gradient.
#[inline]
pub fn srgb_oetf_extended(x: f32) -> f32 {
    if x <= SRGB_KNEE {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Derivative of [`srgb_oetf_extended`].
#[inline]
pub fn srgb_oetf_grad(x: f32) -> f32 {
    if x <= SRGB_KNEE {
        12.92
    } else {
        1.055 / 2.4 * x.powf(1.0 / 2.4 - 1.0)
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
