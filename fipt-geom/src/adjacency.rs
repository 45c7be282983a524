//! Which triangles share an edge, with vertices welded by position (meshes stored without
//! shared vertices still connect).
use crate::Mesh;
use glam::Vec3;
use std::collections::HashMap;

impl Mesh {
    /// Vertex ids after welding positions closer than 1e-6 of the bounds' extent.
    pub fn welded_vertices(&self) -> Vec<u32> {
        let b = self.bounds();
        let q = (b.max - b.min).max_element().max(1e-6) * 1e-6;
        let key = |p: Vec3| {
            let k = (p / q).round();
            (k.x as i64, k.y as i64, k.z as i64)
        };
        let mut ids: HashMap<(i64, i64, i64), u32> = HashMap::new();
        self.positions
            .iter()
            .map(|&p| {
                let n = ids.len() as u32;
                *ids.entry(key(p)).or_insert(n)
            })
            .collect()
    }

    /// For every triangle, the triangles sharing one of its edges (welded by position).
    pub fn edge_neighbours(&self) -> Vec<Vec<u32>> {
        let welded = self.welded_vertices();
        let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            for i in 0..3 {
                let (a, b) = (welded[tri[i] as usize], welded[tri[(i + 1) % 3] as usize]);
                if a != b {
                    edges
                        .entry((a.min(b), a.max(b)))
                        .or_default()
                        .push(t as u32);
                }
            }
        }
        self.neighbours_from_groups(edges.values())
    }

    /// For every triangle, the triangles sharing one of its vertices (welded by position).
    pub fn vertex_neighbours(&self) -> Vec<Vec<u32>> {
        let welded = self.welded_vertices();
        let mut at: HashMap<u32, Vec<u32>> = HashMap::new();
        for (t, tri) in self.triangles.iter().enumerate() {
            for &v in tri {
                at.entry(welded[v as usize]).or_default().push(t as u32);
            }
        }
        self.neighbours_from_groups(at.values())
    }

    /// Fills the triangles whose `value` is None from their neighbours (sharing a vertex),
    /// breadth-first from those that have one: each takes `mean` of its neighbours' values
    /// when it is reached. Triangles no valued one connects to stay None. Returns how many
    /// were filled.
    pub fn spread_to_neighbours<T: Clone>(
        &self,
        value: &mut [Option<T>],
        mean: impl Fn(&[&T]) -> Option<T>,
    ) -> usize {
        let neighbours = self.vertex_neighbours();
        let mut queue: std::collections::VecDeque<u32> = (0..value.len() as u32)
            .filter(|&t| value[t as usize].is_some())
            .collect();
        let mut filled = 0;
        while let Some(t) = queue.pop_front() {
            for &n in &neighbours[t as usize] {
                if value[n as usize].is_some() {
                    continue;
                }
                let near: Vec<&T> = (neighbours[n as usize].iter())
                    .filter_map(|&k| value[k as usize].as_ref())
                    .collect();
                let m = mean(&near);
                value[n as usize] = m;
                filled += 1;
                queue.push_back(n);
            }
        }
        filled
    }

    /// Each triangle's neighbours: the others of every group it is in, sorted, once each.
    fn neighbours_from_groups<'a>(
        &self,
        groups: impl Iterator<Item = &'a Vec<u32>>,
    ) -> Vec<Vec<u32>> {
        let mut out = vec![Vec::new(); self.triangles.len()];
        for tris in groups {
            for &a in tris {
                out[a as usize].extend(tris.iter().copied().filter(|&b| b != a));
            }
        }
        for n in &mut out {
            n.sort_unstable();
            n.dedup();
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unwelded_quads_still_connect_along_shared_edges() {
        // Two triangles of a square stored with separate vertices, and a far one.
        let p = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::ZERO,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::Y,
            Vec3::splat(5.0),
            Vec3::new(6.0, 5.0, 5.0),
            Vec3::new(5.0, 6.0, 5.0),
        ];
        let m = Mesh::from_triangles(p, None, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]]);
        assert_eq!(m.edge_neighbours(), vec![vec![1], vec![0], vec![]]);
        assert_eq!(m.vertex_neighbours(), vec![vec![1], vec![0], vec![]]);
        // Touching at one corner only: vertex neighbours, not edge neighbours.
        let c = Mesh::from_triangles(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::X,
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
            ],
            None,
            vec![[0, 1, 2], [3, 4, 5]],
        );
        assert_eq!(c.vertex_neighbours(), vec![vec![1], vec![0]]);
        assert_eq!(c.edge_neighbours(), vec![Vec::<u32>::new(), vec![]]);
    }
}
