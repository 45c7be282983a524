//! The fitted field: a material per group and an emission flag per triangle, looked up at a
//! world point through the nearest triangle (`fipt_geom::nearest`).
use fipt_core::field::{Material, MaterialField};
pub use fipt_geom::nearest::TriangleLocator;
use glam::Vec3;

/// The field the joint optimisation fitted.
pub struct IptField {
    pub locator: TriangleLocator,
    pub tri_group: Vec<u32>,
    pub group_materials: Vec<Material>,
    /// Whether each triangle is an emitter.
    pub emitting: Vec<bool>,
}

impl MaterialField for IptField {
    fn name(&self) -> &str {
        "ipt-table"
    }
    fn materials(&self, points: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        let fallback = Material {
            albedo: Vec3::splat(0.5),
            roughness: 1.0,
            metallic: 0.0,
        };
        Ok(points
            .iter()
            .map(|&p| {
                self.locator.nearest(p).map_or(fallback, |t| {
                    self.group_materials[self.tri_group[t as usize] as usize]
                })
            })
            .collect())
    }
    fn emission_mask(&self, points: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(points
            .iter()
            .map(|&p| {
                self.locator
                    .nearest(p)
                    .map_or(0.0, |t| f32::from(u8::from(self.emitting[t as usize])))
            })
            .collect())
    }
}
