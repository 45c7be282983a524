//! # fipt-geom
//!
//! Geometry for fipt-rs: one indexed triangle mesh loaded from OBJ (tobj), glTF/GLB (gltf) or
//! PLY (ASCII/binary), degenerate triangles dropped and counted; a BVH on obvhs's CWBVH with
//! closest-hit (triangle id, distance, barycentrics, geometric normal), occlusion and batched
//! parallel queries; robust ray-origin offsets; area sampling of triangle sets.
//!
//! ```
//! use fipt_geom::{Mesh, Bvh, BuildQuality};
//! use glam::Vec3;
//! let mesh = Mesh::from_triangles(vec![Vec3::ZERO, Vec3::X, Vec3::Y], None, vec![[0, 1, 2]]);
//! let bvh = Bvh::build(&mesh, BuildQuality::Medium);
//! let hit = bvh.closest_hit(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 0.0, f32::INFINITY).unwrap();
//! assert_eq!(hit.tri, 0);
//! assert!((hit.t - 1.0).abs() < 1e-6);
//! ```
mod adjacency;
pub mod bvh;
pub mod error;
pub mod geometry;
pub mod glb;
mod load;
pub mod mesh;
pub mod nearest;
pub mod patches;
mod ply;
pub mod sampling;
mod scan;
pub mod shapes;

pub use bvh::{hit_point, offset_ray_origin, shading_normal, BuildQuality, Bvh, Hit};
pub use error::{GeomError, Result};
pub use geometry::Geometry;
pub use mesh::{Bounds, Mesh};
pub use sampling::{SurfaceSample, TriangleSampler};

/// Fraction of a camera's pixel-centre rays (every `stride`-th pixel in each direction) that hit
/// the mesh. A view at 0 % usually means a pose in the wrong convention or the wrong mesh.
pub fn view_coverage(bvh: &Bvh, camera: &fipt_core::camera::Camera, stride: usize) -> f32 {
    let stride = stride.max(1);
    let mut n = 0usize;
    let mut hits = 0usize;
    for j in (0..camera.height).step_by(stride) {
        for i in (0..camera.width).step_by(stride) {
            let (o, d) = camera.pixel_center_ray(i, j);
            n += 1;
            if bvh.closest_hit(o, d, 0.0, f32::INFINITY).is_some() {
                hits += 1;
            }
        }
    }
    hits as f32 / n.max(1) as f32
}
