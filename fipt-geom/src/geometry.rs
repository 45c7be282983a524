//! [`Geometry`]: a mesh with its BVH, answering the shading stages' [`RayQuery`].
use crate::{hit_point, shading_normal, BuildQuality, Bvh, Mesh};
use fipt_core::shading::{RayQuery, SurfaceHit};
use glam::Vec3;

/// A mesh and its BVH.
pub struct Geometry {
    pub mesh: Mesh,
    pub bvh: Bvh,
}

impl Geometry {
    pub fn new(mesh: Mesh) -> Self {
        let bvh = Bvh::build(&mesh, BuildQuality::Medium);
        Geometry { mesh, bvh }
    }
}

impl RayQuery for Geometry {
    #[inline]
    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit> {
        let h = self.bvh.closest_hit(origin, dir, 0.0, f32::INFINITY)?;
        Some(SurfaceHit {
            t: h.t,
            tri: h.tri,
            p: hit_point(&self.mesh, &h),
            ng: h.ng,
            ns: shading_normal(&self.mesh, &h),
        })
    }
    #[inline]
    fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        self.bvh.occluded(origin, dir, tmax)
    }
    #[inline]
    fn offset(&self, p: Vec3, n: Vec3) -> Vec3 {
        self.bvh.offset(p, n)
    }
    fn bounds(&self) -> (Vec3, Vec3) {
        let b = self.mesh.bounds();
        (b.min, b.max)
    }
}
