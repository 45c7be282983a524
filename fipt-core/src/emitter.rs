//! The emitter-extraction contract: which triangles emit, how much, grouped into lights.
//!
//! Emitters are opaque, constant radiance per triangle and reflect nothing (method §1). The
//! method assumes they emit on both sides; an extractor may say per triangle which side emits
//! ([`EmitSide`]): a luminaire's back, or an area light in Mitsuba, is dark, and a panel hung
//! 1 cm under a ceiling would otherwise light a ring of ceiling no view shows lit. A light is
//! a connected group of emitter triangles (a lamp is one light).
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
    /// Emitted power, Lambertian on each emitting side: π·Σ A·L per side (W if L is in
    /// W·m⁻²·sr⁻¹).
    pub power: [f32; 3],
    /// Area-weighted centroid.
    pub centroid: [f32; 3],
    /// Training pixels whose centre ray hits the light.
    pub pixels: usize,
    /// The side each triangle emits from (same order as `triangles`); empty: every triangle
    /// emits on both sides (the method's assumption, and files written before sides).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sides: Vec<EmitSide>,
}

/// Which side of a triangle emits: the side its winding faces (`Front`, where
/// (b − a) × (c − a) points), the other (`Back`) or both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EmitSide {
    #[default]
    Both,
    Front,
    Back,
}

impl EmitSide {
    /// Whether a triangle with geometric (winding) normal `ng` emits towards direction `w`
    /// (from the triangle to the receiver; any length).
    #[inline]
    pub fn emits_towards(self, ng: Vec3, w: Vec3) -> bool {
        match self {
            EmitSide::Both => true,
            EmitSide::Front => ng.dot(w) > 0.0,
            EmitSide::Back => ng.dot(w) < 0.0,
        }
    }
    /// The side seen by `front` pixels looking at the winding side and `back` at the other:
    /// the only side seen, or both when both or neither were seen.
    pub fn from_counts(front: usize, back: usize) -> EmitSide {
        match (front > 0, back > 0) {
            (true, false) => EmitSide::Front,
            (false, true) => EmitSide::Back,
            _ => EmitSide::Both,
        }
    }
    /// How many sides emit (1 or 2).
    pub fn count(self) -> f32 {
        if self == EmitSide::Both {
            2.0
        } else {
            1.0
        }
    }
}

impl Emitter {
    /// The same light with its radiance and power multiplied by `k` (an exposure change).
    pub fn scaled(&self, k: f32) -> Emitter {
        let m = |v: [f32; 3]| v.map(|x| x * k);
        Emitter {
            radiance: self.radiance.iter().map(|&l| m(l)).collect(),
            mean_radiance: m(self.mean_radiance),
            power: m(self.power),
            ..self.clone()
        }
    }

    /// The light of triangles `tris` (indices into `triangles`, vertices in `positions`) with
    /// radiance `radiance` each: area, area-weighted mean radiance and centroid, and the
    /// double-sided Lambertian power 2π·Σ A·L. None when the area is zero or a triangle index is
    /// out of range. `pixels`: training pixels that saw it.
    pub fn from_triangles(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        tris: Vec<u32>,
        radiance: Vec<Rgb>,
        pixels: usize,
    ) -> Option<Emitter> {
        let (mut area, mut wsum, mut csum) = (0f32, Vec3::ZERO, Vec3::ZERO);
        for (&t, &l) in tris.iter().zip(&radiance) {
            let ([a, b, c], ar) = corners_and_area(positions, triangles, t)?;
            area += ar;
            wsum += l * ar;
            csum += (a + b + c) / 3.0 * ar;
        }
        (area > 0.0 && tris.len() == radiance.len()).then(|| Emitter {
            triangles: tris,
            radiance: radiance.iter().map(|l| l.to_array()).collect(),
            area,
            mean_radiance: (wsum / area).to_array(),
            power: (wsum * 2.0 * std::f32::consts::PI).to_array(),
            centroid: (csum / area).to_array(),
            pixels,
            sides: Vec::new(),
        })
    }

    /// The same light emitting from `sides` (one per triangle), its power recomputed: π·A·L
    /// per emitting side. `positions` and `triangles` as in [`Emitter::from_triangles`].
    pub fn with_sides(
        mut self,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        sides: Vec<EmitSide>,
    ) -> Emitter {
        if sides.len() != self.triangles.len() {
            return self;
        }
        let mut power = Vec3::ZERO;
        for ((&t, l), s) in self.triangles.iter().zip(&self.radiance).zip(&sides) {
            let Some((_, ar)) = corners_and_area(positions, triangles, t) else {
                return self;
            };
            power += Vec3::from(*l) * ar * s.count() * std::f32::consts::PI;
        }
        self.power = power.to_array();
        self.sides = if sides.iter().all(|&s| s == EmitSide::Both) {
            Vec::new()
        } else {
            sides
        };
        self
    }

    /// The side triangle `i` (an index into `triangles`) emits from.
    pub fn side(&self, i: usize) -> EmitSide {
        self.sides.get(i).copied().unwrap_or_default()
    }
}

/// The corners and area of triangle `t` (None when an index is out of range).
fn corners_and_area(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    t: u32,
) -> Option<([Vec3; 3], f32)> {
    let [a, b, c] = triangles
        .get(t as usize)?
        .map(|v| positions.get(v as usize).copied());
    let (a, b, c) = (a?, b?, c?);
    Some(([a, b, c], 0.5 * (b - a).cross(c - a).length()))
}

/// The geometry and observations an extractor works from.
pub struct EmitterInputs<'a> {
    pub positions: &'a [Vec3],
    pub triangles: &'a [[u32; 3]],
    pub field: &'a dyn MaterialField,
    /// Every training pixel whose centre ray hits the mesh, visited in view and pixel order.
    pub pixel_hits: &'a dyn PixelHits,
}

/// The training pixels whose centre ray hits the mesh, visited in view and pixel order. A
/// source may build them one view at a time (the pipeline's does), so that a scene of any size
/// never holds them all: an extractor keeps what it needs of them.
pub trait PixelHits {
    /// Calls `f` with every pixel hit, in order.
    fn visit(&self, f: &mut dyn FnMut(&PixelHit)) -> Result<()>;
}

impl PixelHits for Vec<PixelHit> {
    fn visit(&self, f: &mut dyn FnMut(&PixelHit)) -> Result<()> {
        for h in self {
            f(h);
        }
        Ok(())
    }
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
    /// Where the pixel lies, `[view, x, y]`, if known: an extractor can then tell a light's
    /// inner pixels from its outline, whose footprint also covers what lies beside the light.
    pub at: Option<[u32; 3]>,
    /// Whether the pixel looks at the triangle's winding side (true) or the other, if known:
    /// an extractor can then leave dark a side no view saw ([`EmitSide`]).
    pub front: Option<bool>,
}

/// Finds the emitters of a scene.
pub trait EmitterExtractor {
    fn name(&self) -> &str;
    fn extract(&self, inputs: &EmitterInputs) -> Result<Vec<Emitter>>;
    /// Checked before any work of a run: whether the extraction on a mesh of `triangles`
    /// triangles stays within this extractor's bounds (Err: what to change). Ok by default.
    fn check(&self, triangles: usize) -> std::result::Result<(), String> {
        let _ = triangles;
        Ok(())
    }
    /// What the last [`EmitterExtractor::extract`] left out and why, one line each, for the
    /// run's log (none by default).
    fn notes(&self) -> Vec<String> {
        vec![]
    }
}
