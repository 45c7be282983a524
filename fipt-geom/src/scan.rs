//! A mesh as a scanner gives it: denser than the modelled one (subdivided) and a few
//! millimetres off, smoothly (warped), for judging the stages on captures.
use crate::mesh::Mesh;
use fipt_core::rng::Pcg32;
use glam::Vec3;

/// Waves summed per axis of the warp field.
const WAVES: usize = 6;

impl Mesh {
    /// Every triangle split into four at its edge midpoints, `levels` times: 4^levels
    /// consecutive triangles per triangle (a per-face table's ranges scale by 4^levels). The
    /// surface and its shading normals stay the same.
    pub fn subdivided(&self, levels: u32) -> Mesh {
        let mut m = self.clone();
        for _ in 0..levels {
            let mut pos = m.positions.clone();
            let mut nor = m.normals.clone();
            let mut mids: std::collections::HashMap<(u32, u32), u32> = Default::default();
            let mut mid = |a: u32, b: u32| {
                *mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (pos[a as usize], pos[b as usize]);
                    pos.push((pa + pb) * 0.5);
                    if let Some(n) = nor.as_mut() {
                        let v = (n[a as usize] + n[b as usize]).normalize_or(n[a as usize]);
                        n.push(v);
                    }
                    pos.len() as u32 - 1
                })
            };
            let mut tris = Vec::with_capacity(m.triangles.len() * 4);
            for &[a, b, c] in &m.triangles {
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                tris.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
            }
            m = Mesh::from_triangles(pos, nor, tris);
        }
        m
    }

    /// Every vertex moved by a smooth random field of the position alone (so vertices that
    /// share a position, across a crease, stay together): per axis a sum of waves of
    /// wavelengths 1/4 to 1/1.5 of the bounds' diagonal, scaled so that the largest
    /// displacement is `amplitude` (metres). Shading normals are recomputed from the faces
    /// (area-weighted, per vertex) when the mesh has them. Deterministic in `seed`.
    pub fn warped(&self, amplitude: f32, seed: u64) -> Mesh {
        if amplitude <= 0.0 || self.positions.is_empty() {
            return self.clone();
        }
        let diag = (self.bounds().max - self.bounds().min).length().max(1e-6);
        let mut rng = Pcg32::new(seed, 0x5ca9);
        // (axis, direction k, phase) of each wave.
        let waves: Vec<(usize, Vec3, f32)> = (0..3 * WAVES)
            .map(|i| {
                let dir = loop {
                    let v =
                        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3::ONE;
                    if (0.05..=1.0).contains(&v.length_squared()) {
                        break v.normalize();
                    }
                };
                let wavelength = diag / (1.5 + 2.5 * rng.next_f32());
                let k = dir * (std::f32::consts::TAU / wavelength);
                (i / WAVES, k, std::f32::consts::TAU * rng.next_f32())
            })
            .collect();
        let field = |p: Vec3| {
            let mut d = Vec3::ZERO;
            for &(axis, k, phase) in &waves {
                d[axis] += (k.dot(p) + phase).sin();
            }
            d
        };
        let raw: Vec<Vec3> = self.positions.iter().map(|&p| field(p)).collect();
        let largest = raw.iter().map(|d| d.length()).fold(0.0f32, f32::max);
        let scale = if largest > 0.0 {
            amplitude / largest
        } else {
            0.0
        };
        let mut m = self.clone();
        for (p, d) in m.positions.iter_mut().zip(&raw) {
            *p += *d * scale;
        }
        if m.normals.is_some() {
            m.normals = Some(m.face_weighted_normals());
        }
        m
    }

    /// Per-vertex normals: the area-weighted sum of the adjacent faces' normals.
    fn face_weighted_normals(&self) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let w = (b - a).cross(c - a);
            for &i in t {
                n[i as usize] += w;
            }
        }
        let old = self.normals.as_ref();
        n.iter()
            .enumerate()
            .map(|(i, v)| {
                v.try_normalize()
                    .unwrap_or_else(|| old.map_or(Vec3::Z, |o| o[i]))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh::from_triangles(
            vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::Y,
                Vec3::Y, // a second vertex at a shared position (a crease)
            ],
            None,
            vec![[0, 1, 2], [0, 2, 4]],
        )
    }

    #[test]
    fn subdivision_keeps_the_area_and_multiplies_triangles() {
        let m = quad().subdivided(2);
        assert_eq!(m.triangles.len(), 2 * 16);
        let area: f32 = (0..m.triangles.len()).map(|t| m.area(t)).sum();
        assert!((area - 1.0).abs() < 1e-5, "{area}");
    }

    #[test]
    fn warp_is_bounded_smooth_and_keeps_shared_positions_together() {
        let m = quad().subdivided(5);
        let w = m.warped(0.008, 7);
        let d: Vec<f32> = m
            .positions
            .iter()
            .zip(&w.positions)
            .map(|(a, b)| (*a - *b).length())
            .collect();
        let max = d.iter().cloned().fold(0.0f32, f32::max);
        assert!((max - 0.008).abs() < 1e-6, "largest displacement {max}");
        // Neighbouring vertices (1/32 apart) move alike: the field is smooth.
        for t in &w.triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2])] {
                let da = w.positions[a as usize] - m.positions[a as usize];
                let db = w.positions[b as usize] - m.positions[b as usize];
                assert!((da - db).length() < 0.6 * 0.008, "{da} vs {db}");
            }
        }
        assert_eq!(w.positions[3], w.positions[4], "a shared position splits");
        assert_eq!(w, m.warped(0.008, 7), "not deterministic");
        assert_ne!(w, m.warped(0.008, 8));
    }
}
