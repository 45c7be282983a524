//! Simple meshes made by code: the icosphere (procedural scenes, light bulbs, tests).
use crate::mesh::Mesh;
use glam::Vec3;

/// An icosphere with `subdiv` subdivisions (20·4^subdiv triangles), normals outward.
pub fn icosphere_into(
    pos: &mut Vec<Vec3>,
    tris: &mut Vec<[u32; 3]>,
    center: Vec3,
    radius: f32,
    subdiv: u32,
) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1., t, 0.),
        (1., t, 0.),
        (-1., -t, 0.),
        (1., -t, 0.),
        (0., -1., t),
        (0., 1., t),
        (0., -1., -t),
        (0., 1., -t),
        (t, 0., -1.),
        (t, 0., 1.),
        (-t, 0., -1.),
        (-t, 0., 1.),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdiv {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *cache.entry(key).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                v.len() as u32 - 1
            })
        };
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let ab = mid(a, b, &mut v);
            let bc = mid(b, c, &mut v);
            let ca = mid(c, a, &mut v);
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    let off = pos.len() as u32;
    pos.extend(v.iter().map(|&p| center + p * radius));
    tris.extend(f.iter().map(|t| t.map(|i| i + off)));
}

/// An icosphere mesh of 20·4^subdiv triangles.
pub fn icosphere_mesh(center: Vec3, radius: f32, subdiv: u32) -> Mesh {
    let (mut p, mut t) = (Vec::new(), Vec::new());
    icosphere_into(&mut p, &mut t, center, radius, subdiv);
    Mesh::from_triangles(p, None, t)
}
