//! The nearest triangle of a point: a uniform grid of the triangles' bounds searched in rings
//! of cells outwards, and the closest point of a triangle (Ericson, *Real-Time Collision
//! Detection* §5.1.5). Material tables and tests look a surface point's triangle up with it.
use crate::Mesh;
use glam::Vec3;

/// The nearest triangle of a point.
pub struct TriangleLocator {
    min: Vec3,
    cell: f32,
    dims: [usize; 3],
    /// Triangles overlapping each cell (CSR).
    start: Vec<u32>,
    items: Vec<u32>,
    tris: Vec<[Vec3; 3]>,
}

impl TriangleLocator {
    /// A grid of about two cells per triangle, at most 128 per axis.
    pub fn new(mesh: &Mesh) -> Self {
        let tris: Vec<[Vec3; 3]> = (0..mesh.triangles.len())
            .map(|t| mesh.vertices(t))
            .collect();
        let b = mesh.bounds();
        let ext = (b.max - b.min).max(Vec3::splat(1e-6));
        let target = (2.0 * tris.len().max(1) as f32).min(128.0f32.powi(3));
        let cell = (ext.x * ext.y * ext.z / target)
            .cbrt()
            .max(ext.max_element() / 128.0);
        let dims = [0, 1, 2].map(|a| ((ext[a] / cell).ceil() as usize).clamp(1, 128));
        let mut loc = TriangleLocator {
            min: b.min,
            cell,
            dims,
            start: vec![],
            items: vec![],
            tris,
        };
        let ncells = dims[0] * dims[1] * dims[2];
        let mut lists: Vec<Vec<u32>> = vec![vec![]; ncells];
        for (t, v) in loc.tris.iter().enumerate() {
            let lo = loc.coords(v[0].min(v[1]).min(v[2]));
            let hi = loc.coords(v[0].max(v[1]).max(v[2]));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        lists[loc.index([x, y, z])].push(t as u32);
                    }
                }
            }
        }
        loc.start.push(0);
        for l in lists {
            loc.items.extend(l);
            loc.start.push(loc.items.len() as u32);
        }
        loc
    }

    fn coords(&self, p: Vec3) -> [usize; 3] {
        let q = (p - self.min) / self.cell;
        [0, 1, 2].map(|a| (q[a].max(0.0) as usize).min(self.dims[a] - 1))
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// The triangle nearest `p` (searching rings of cells outwards), None for an empty mesh.
    pub fn nearest(&self, p: Vec3) -> Option<u32> {
        let c = self.coords(p);
        let mut best: Option<(f32, u32)> = None;
        let max_ring = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_ring {
            // A triangle found within ring r is at most (r+1)·√3 cells away; rings beyond
            // that cannot beat it.
            if let Some((d2, _)) = best {
                let reach = (r as f32 - 1.0).max(0.0) * self.cell;
                if reach * reach > d2 {
                    break;
                }
            }
            let lo = c.map(|x| x.saturating_sub(r));
            let hi = [0, 1, 2].map(|a| (c[a] + r).min(self.dims[a] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        let on_shell = [x, y, z].iter().zip(c).any(|(&v, cv)| v.abs_diff(cv) == r);
                        if !on_shell {
                            continue;
                        }
                        let i = self.index([x, y, z]);
                        for &t in &self.items[self.start[i] as usize..self.start[i + 1] as usize] {
                            let d2 =
                                (closest_point(p, &self.tris[t as usize]) - p).length_squared();
                            if best.is_none_or(|(b, bt)| d2 < b || (d2 == b && t < bt)) {
                                best = Some((d2, t));
                            }
                        }
                    }
                }
            }
        }
        best.map(|(_, t)| t)
    }
}

/// The point of triangle `v` closest to `p` (Voronoi regions of the vertices, edges, face).
pub fn closest_point(p: Vec3, v: &[Vec3; 3]) -> Vec3 {
    let [a, b, c] = *v;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The grid finds the same nearest triangle as a scan over all of them.
    #[test]
    fn nearest_matches_brute_force() {
        let mut rng = fipt_core::rng::Pcg32::new(3, 1);
        let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let mut pos = vec![];
        let mut tris = vec![];
        for t in 0..300u32 {
            let c = r3() * 4.0;
            pos.extend([c, c + r3() * 0.3, c + r3() * 0.3]);
            tris.push([3 * t, 3 * t + 1, 3 * t + 2]);
        }
        // One large triangle spanning the scene.
        let k = pos.len() as u32;
        pos.extend([
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 4.0),
        ]);
        tris.push([k, k + 1, k + 2]);
        let mesh = Mesh::from_triangles(pos, None, tris);
        let loc = TriangleLocator::new(&mesh);
        for _ in 0..500 {
            let p = r3() * 5.0 - 0.5;
            let brute = (0..mesh.triangles.len())
                .map(|t| (closest_point(p, &mesh.vertices(t)) - p).length_squared())
                .fold(f32::INFINITY, f32::min);
            let t = loc.nearest(p).unwrap() as usize;
            let got = (closest_point(p, &mesh.vertices(t)) - p).length_squared();
            assert!(
                (got - brute).abs() <= 1e-6 * brute.max(1e-6),
                "{got} vs {brute}"
            );
        }
        // A point on a face maps to a point at distance 0.
        let [a, b, c] = mesh.vertices(5);
        let p = (a + b + c) / 3.0;
        assert!((closest_point(p, &mesh.vertices(5)) - p).length() < 1e-6);
    }
}
