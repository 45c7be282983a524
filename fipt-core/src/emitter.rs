//! The emitter-extraction contract: which triangles emit, how much, grouped into lights.
//!
//! Emitters are opaque, double-sided, constant radiance per triangle and reflect nothing
//! (method §1). A light is a connected group of emitter triangles (a lamp is one light).
use crate::color::Rgb;
use crate::error::Result;
use crate::field::MaterialField;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// One light: connected emitter triangles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Emitter {
    /// Mesh triangle indices.
    pub triangles: Vec<u32>,
    /// Radiance of each triangle (same order).
    pub radiance: Vec<[f32; 3]>,
    /// Total area (m²).
    pub area: f32,
    /// Area-weighted mean radiance.
    pub mean_radiance: [f32; 3],
    /// Emitted power, double-sided Lambertian: 2π·Σ A·L (W if L is in W·m⁻²·sr⁻¹).
    pub power: [f32; 3],
    /// Area-weighted centroid.
    pub centroid: [f32; 3],
    /// Training pixels whose centre ray hits the light.
    pub pixels: usize,
}

/// The geometry and observations an extractor works from.
pub struct EmitterInputs<'a> {
    pub positions: &'a [Vec3],
    pub triangles: &'a [[u32; 3]],
    pub field: &'a dyn MaterialField,
    /// Every training pixel whose centre ray hits the mesh.
    pub pixel_hits: &'a [PixelHit],
}

/// A training pixel as emitter extraction sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelHit {
    /// Mesh triangle hit by the pixel-centre ray.
    pub triangle: u32,
    /// Observed HDR radiance.
    pub radiance: Rgb,
    /// The most this point could reflect under its baked incident light, if known:
    /// Ld + max_σ Ls0 + max_σ Ls1 (a white surface with kd = ks = 1). Radiance above it must
    /// be emitted.
    pub max_reflected: Option<Rgb>,
}

/// Finds the emitters of a scene.
pub trait EmitterExtractor {
    fn name(&self) -> &str;
    fn extract(&self, inputs: &EmitterInputs) -> Result<Vec<Emitter>>;
}
