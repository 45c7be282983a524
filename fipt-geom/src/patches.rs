//! Smooth patches of a mesh: triangles joined across shared edges whose faces bend by less than
//! a given angle. A box falls into its six faces, a tessellated sphere stays one patch, a room's
//! walls separate at their corners. Used as material regions when a scene has no segmentation.
use crate::mesh::{face_normal, Mesh};
use fipt_core::disjoint::DisjointSets;
use glam::Vec3;
use std::collections::HashMap;

/// Patch id of every triangle (dense, in order of first triangle) and the number of patches.
/// Vertices are matched by position, so meshes that split vertices for normals or UVs still
/// join; an edge shared by more than two triangles joins all pairs within the angle.
pub fn smooth_patches(mesh: &Mesh, max_angle_deg: f32) -> (Vec<u32>, usize) {
    patches_among(mesh, max_angle_deg, |_| true)
}

/// [`smooth_patches`] where only triangles `joins(t)` join across their edges (the others
/// are patches of their own): with 180°, the connected pieces of a set of triangles.
pub fn patches_among(
    mesh: &Mesh,
    max_angle_deg: f32,
    joins: impl Fn(u32) -> bool,
) -> (Vec<u32>, usize) {
    patches_of(&mesh.positions, &mesh.triangles, max_angle_deg, joins)
}

/// [`smooth_patches`] of a mesh given as its vertex positions and triangles.
pub fn smooth_patches_of(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    max_angle_deg: f32,
) -> (Vec<u32>, usize) {
    patches_of(positions, triangles, max_angle_deg, |_| true)
}

/// [`patches_among`] of a mesh given as its vertex positions and triangles.
pub fn patches_of(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    max_angle_deg: f32,
    joins: impl Fn(u32) -> bool,
) -> (Vec<u32>, usize) {
    let n = triangles.len();
    let key = |v: u32| {
        let p = positions[v as usize];
        [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
    };
    let mut edges: HashMap<([u32; 3], [u32; 3]), Vec<u32>> = HashMap::new();
    for (t, tri) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (key(tri[e]), key(tri[(e + 1) % 3]));
            let k = if a <= b { (a, b) } else { (b, a) };
            edges.entry(k).or_default().push(t as u32);
        }
    }
    let normals: Vec<_> = triangles
        .iter()
        .map(|t| face_normal(t.map(|v| positions[v as usize])))
        .collect();
    let cos_max = max_angle_deg.to_radians().cos();
    let mut sets = DisjointSets::new(n);
    for tris in edges.values() {
        for (i, &a) in tris.iter().enumerate() {
            for &b in &tris[i + 1..] {
                if joins(a) && joins(b) && normals[a as usize].dot(normals[b as usize]) >= cos_max {
                    sets.union(a as usize, b as usize);
                }
            }
        }
    }
    let mut dense: HashMap<u32, u32> = HashMap::new();
    let ids = (0..n as u32)
        .map(|t| {
            let r = sets.find(t as usize) as u32;
            let next = dense.len() as u32;
            *dense.entry(r).or_insert(next)
        })
        .collect();
    (ids, dense.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        Mesh::from_triangles(positions, None, triangles)
    }

    #[test]
    fn a_cube_falls_into_six_faces_and_a_bent_strip_joins_below_the_angle() {
        // Unit cube with 8 shared vertices, 12 triangles (outward winding).
        let p: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2 & 1) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let tris: Vec<[u32; 3]> = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        let (ids, n) = smooth_patches(&mesh(p, tris), 30.0);
        assert_eq!(n, 6);
        for f in 0..6 {
            assert_eq!(ids[2 * f], ids[2 * f + 1]);
        }
        // Two quads meeting at 20°: one patch at 30°, two at 10°.
        let a = 20f32.to_radians();
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0 + a.cos(), 0.0, a.sin()),
            Vec3::new(1.0 + a.cos(), 1.0, a.sin()),
        ];
        let tris = vec![[0, 2, 3], [0, 3, 1], [2, 4, 5], [2, 5, 3]];
        assert_eq!(smooth_patches(&mesh(p.clone(), tris.clone()), 30.0).1, 1);
        assert_eq!(smooth_patches(&mesh(p, tris), 10.0).1, 2);
    }
}
