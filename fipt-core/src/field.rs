//! The material-field contract: BRDF parameters and the emission mask at any world point.
//!
//! A field maps a surface point to the network outputs of method §2 (albedo a, roughness σ,
//! metallic m) and to the emission mask α ∈ [0, 1]. [`Material::kd`] and [`Material::ks`] give
//! the BRDF inputs of the metallic workflow. Implementations: fipt-neural's hash-grid field;
//! an ablation can plug in anything (a per-face table, a voxel grid) behind the same trait.
use crate::color::Rgb;
use crate::error::Result;
use glam::Vec3;

/// Network outputs at a point (metallic workflow).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Base colour a ∈ [0, 1]³.
    pub albedo: Rgb,
    /// σ ∈ [0.02, 1].
    pub roughness: f32,
    /// m ∈ [0, 1].
    pub metallic: f32,
}

impl Material {
    /// Diffuse albedo kd = a·(1 − m).
    #[inline]
    pub fn kd(&self) -> Rgb {
        crate::reflectance::metallic_workflow(self.albedo, self.metallic).0
    }
    /// Specular reflectance (Fresnel F0) ks = 0.04·(1 − m) + a·m.
    #[inline]
    pub fn ks(&self) -> Rgb {
        crate::reflectance::metallic_workflow(self.albedo, self.metallic).1
    }

    /// The material whose (kd, ks) are a ground-truth surface point's: the base colour is ks
    /// for a metal, kd / (1 − m) otherwise.
    pub fn of_surface(sp: &crate::materials::SurfacePoint) -> Material {
        let albedo = if sp.metallic >= 0.999 {
            sp.ks
        } else {
            sp.kd / (1.0 - sp.metallic).max(1e-3)
        };
        Material {
            albedo,
            roughness: sp.roughness,
            metallic: sp.metallic,
        }
    }
}

/// A queryable BRDF field and emission mask.
pub trait MaterialField: Send + Sync {
    /// A short name for reports.
    fn name(&self) -> &str;
    /// Materials at `points` (world space), in order.
    fn materials(&self, points: &[Vec3]) -> Result<Vec<Material>>;
    /// Emission mask α ∈ [0, 1] at `points`.
    fn emission_mask(&self, points: &[Vec3]) -> Result<Vec<f32>>;
    /// The field as its own type, for a component that can do more with a field of its own
    /// kind (a trainer warm-starting from its previous round's field). None by default.
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metallic_workflow_limits() {
        let a = Vec3::new(0.8, 0.5, 0.2);
        let dielectric = Material {
            albedo: a,
            roughness: 0.5,
            metallic: 0.0,
        };
        assert_eq!(dielectric.kd(), a);
        assert_eq!(dielectric.ks(), Vec3::splat(0.04));
        let metal = Material {
            metallic: 1.0,
            ..dielectric
        };
        assert_eq!(metal.kd(), Vec3::ZERO);
        assert_eq!(metal.ks(), a);
    }
}
