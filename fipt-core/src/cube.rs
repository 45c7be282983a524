//! The axis-aligned cube around a scene's observed points, shared by the surface light field
//! and the material field's encoding.
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// A cube `[min, min + size]³`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cube {
    pub min: Vec3,
    pub size: f32,
}

impl Cube {
    /// The cube around the bounding box of the finite `points`, enlarged ×`scale` about its
    /// centre (the reference uses 1.1). None when there is no finite point.
    pub fn around(points: impl IntoIterator<Item = Vec3>, scale: f32) -> Option<Cube> {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in points {
            if p.is_finite() {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        if lo.x > hi.x {
            return None;
        }
        let size = ((hi - lo).max_element() * scale).max(1e-6);
        Some(Cube {
            min: (lo + hi) * 0.5 - Vec3::splat(0.5 * size),
            size,
        })
    }

    /// `p` mapped into the unit cube, clamped.
    #[inline]
    pub fn unit(&self, p: Vec3) -> [f32; 3] {
        ((p - self.min) / self.size)
            .clamp(Vec3::ZERO, Vec3::ONE)
            .to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encloses_the_finite_points_with_margin() {
        let pts = [Vec3::ZERO, Vec3::new(2.0, 1.0, 0.5), Vec3::splat(f32::NAN)];
        let c = Cube::around(pts, 1.1).unwrap();
        assert!((c.size - 2.2).abs() < 1e-6);
        assert_eq!(c.unit(Vec3::new(1.0, 0.5, 0.25)), [0.5, 0.5, 0.5]);
        assert_eq!(c.unit(Vec3::splat(-10.0)), [0.0, 0.0, 0.0]);
        assert!(Cube::around([Vec3::splat(f32::INFINITY)], 1.1).is_none());
    }
}
