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
        let diag = (self.bounds().max - self.bounds().min).length().max(1e-6);
        self.displaced(
            amplitude,
            |u| diag / (1.5 + 2.5 * u),
            Pcg32::new(seed, 0x5ca9),
        )
    }

    /// A scanner's ripple: the same kind of field as [`Mesh::warped`] with wavelengths of 0.75
    /// to 1.33 times `wavelength` (metres), largest displacement `amplitude`. It tilts the
    /// faces by about 2π·amplitude/wavelength; the mesh must be fine enough to carry it
    /// ([`Mesh::refined`] to a sixth of the wavelength). Deterministic in `seed`.
    pub fn rippled(&self, amplitude: f32, wavelength: f32, seed: u64) -> Mesh {
        let l = wavelength.max(1e-6);
        self.displaced(
            amplitude,
            |u| l / (0.75 + 0.58 * u),
            Pcg32::new(seed, 0x41bb),
        )
    }

    /// Every position moved by `WAVES` waves per axis, each of the wavelength `wavelength(u)`
    /// for a uniform u, scaled so that the largest displacement is `amplitude`.
    fn displaced(&self, amplitude: f32, wavelength: impl Fn(f32) -> f32, mut rng: Pcg32) -> Mesh {
        if amplitude <= 0.0 || self.positions.is_empty() {
            return self.clone();
        }
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
                let k = dir * (std::f32::consts::TAU / wavelength(rng.next_f32()));
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

    /// Every edge longer than `max_edge` (metres) halved, again and again, until none is: the
    /// triangles beside a halved edge split in two, three or four, so the surface stays closed
    /// (both sides of an edge halve it, even across a crease's repeated vertices: they split at
    /// the same position). The surface and its shading normals stay the same. Returns the mesh
    /// and, per file face of `self`, the index of its first triangle in it (one more entry at
    /// the end): a face's triangles are consecutive, in the faces' order.
    pub fn refined(&self, max_edge: f32) -> (Mesh, Vec<u32>) {
        let mut pos = self.positions.clone();
        let mut nor = self.normals.clone();
        let mut tris = self.triangles.clone();
        let mut owner = self.face_ids.clone();
        let long =
            |pos: &[Vec3], a: u32, b: u32| (pos[a as usize] - pos[b as usize]).length() > max_edge;
        // Each pass halves the long edges of the previous one (64 passes are 2^64 times
        // shorter) and the first pass that halves none ends it. A bound that is not positive
        // halves nothing.
        let mut finished = !(max_edge > 0.0);
        for _ in 0..64 {
            if finished {
                break;
            }
            let mut mids: std::collections::HashMap<(u32, u32), u32> = Default::default();
            let (mut next, mut next_owner) = (Vec::with_capacity(tris.len() * 2), vec![]);
            for (&t, &o) in tris.iter().zip(&owner) {
                let mut mid = |e: usize| {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    if !long(&pos, a, b) {
                        return None;
                    }
                    Some(*mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
                        pos.push((pos[a as usize] + pos[b as usize]) * 0.5);
                        if let Some(n) = nor.as_mut() {
                            let v = (n[a as usize] + n[b as usize]).normalize_or(n[a as usize]);
                            n.push(v);
                        }
                        pos.len() as u32 - 1
                    }))
                };
                let m = [mid(0), mid(1), mid(2)];
                split_triangle(t, m, &pos, &mut next);
                next_owner.resize(next.len(), o);
            }
            finished = mids.is_empty();
            tris = next;
            owner = next_owner;
        }
        debug_assert!(
            finished,
            "edges longer than {max_edge} after 64 halvings (non-finite positions?)"
        );
        let mut mesh = Mesh::from_triangles(pos, nor, tris);
        // from_triangles keeps every triangle of a non-degenerate parent but drops a sliver
        // it finds degenerate: follow its face ids.
        let kept: Vec<u32> = mesh.face_ids.iter().map(|&f| owner[f as usize]).collect();
        let mut starts = vec![0u32; self.num_file_faces + 1];
        for &o in &kept {
            starts[o as usize + 1] += 1;
        }
        for f in 0..self.num_file_faces {
            starts[f + 1] += starts[f];
        }
        mesh.num_file_faces = mesh.triangles.len();
        mesh.face_ids = (0..mesh.triangles.len() as u32).collect();
        (mesh, starts)
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

/// Triangle `t` split at the midpoints `m[e]` of its halved edges (edge e from corner e to
/// e + 1), its corners' order (and so its facing) kept.
fn split_triangle(t: [u32; 3], m: [Option<u32>; 3], pos: &[Vec3], out: &mut Vec<[u32; 3]>) {
    match m {
        [None, None, None] => out.push(t),
        [Some(ab), Some(bc), Some(ca)] => {
            let [a, b, c] = t;
            out.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        _ => {
            // Rotate so that edge 0 (a→b) is halved and, with two halved, edge 1 (b→c) too.
            let r = (0..3)
                .find(|&r| {
                    m[r].is_some() && (m.iter().flatten().count() == 1 || m[(r + 1) % 3].is_some())
                })
                .unwrap_or(0);
            let [a, b, c] = [t[r], t[(r + 1) % 3], t[(r + 2) % 3]];
            let (ab, bc) = (m[r].unwrap_or(a), m[(r + 1) % 3]);
            match bc {
                None => out.extend([[a, ab, c], [ab, b, c]]),
                Some(bc) => {
                    out.push([ab, b, bc]);
                    // The quad a, ab, bc, c by its shorter diagonal.
                    let d = |i: u32, j: u32| (pos[i as usize] - pos[j as usize]).length_squared();
                    if d(a, bc) <= d(ab, c) {
                        out.extend([[a, ab, bc], [a, bc, c]]);
                    } else {
                        out.extend([[a, ab, c], [ab, bc, c]]);
                    }
                }
            }
        }
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

    /// A unit cube, its faces outward; the top face's four corners repeated (a crease's
    /// own vertices), so its edges are shared by position only.
    fn cube() -> Mesh {
        let mut p: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        p.extend([p[4], p[5], p[6], p[7]]); // 8..12: the top's own corners
        let tris = vec![
            [0, 2, 1],
            [1, 2, 3], // z = 0
            [8, 9, 10],
            [9, 11, 10], // z = 1 (own vertices)
            [0, 1, 4],
            [1, 5, 4], // y = 0
            [2, 6, 3],
            [3, 6, 7], // y = 1
            [0, 4, 2],
            [2, 4, 6], // x = 0
            [1, 3, 5],
            [3, 7, 5], // x = 1
        ];
        Mesh::from_triangles(p, None, tris)
    }

    fn normal(m: &Mesh, t: usize) -> Vec3 {
        let [a, b, c] = m.triangles[t].map(|i| m.positions[i as usize]);
        (b - a).cross(c - a).normalize()
    }

    #[test]
    fn refinement_halves_long_edges_keeps_the_surface_closed_and_maps_faces() {
        let src = cube();
        let (m, starts) = src.refined(0.3);
        assert_eq!(starts.len(), 13);
        assert_eq!(starts[0], 0);
        assert_eq!(*starts.last().unwrap() as usize, m.triangles.len());
        let key = |v: Vec3| (v * 1024.0).round().as_ivec3().to_array();
        let mut edges: std::collections::HashMap<_, u32> = Default::default();
        for t in &m.triangles {
            for e in 0..3 {
                let (a, b) = (
                    m.positions[t[e] as usize],
                    m.positions[t[(e + 1) % 3] as usize],
                );
                assert!(
                    (a - b).length() <= 0.3 + 1e-6,
                    "an edge of {}",
                    (a - b).length()
                );
                let (ka, kb) = (key(a), key(b));
                *edges.entry((ka.min(kb), ka.max(kb))).or_default() += 1;
            }
        }
        // Closed: every edge is met by exactly two triangles (no T-junction, no crack), also
        // along the top face's repeated corners.
        assert!(edges.values().all(|&n| n == 2), "an open edge");
        for f in 0..12 {
            let (lo, hi) = (starts[f] as usize, starts[f + 1] as usize);
            assert!(hi > lo);
            let area: f32 = (lo..hi).map(|t| m.area(t)).sum();
            assert!((area - src.area(f)).abs() < 1e-5, "face {f}: {area}");
            for t in lo..hi {
                assert!(
                    normal(&m, t).dot(normal(&src, f)) > 0.999,
                    "face {f} turned"
                );
            }
        }
        assert_eq!(
            src.refined(2.0).0.triangles,
            src.triangles,
            "nothing to halve"
        );
    }

    #[test]
    fn a_ripple_is_bounded_tilts_the_faces_and_is_deterministic() {
        let flat = Mesh::from_triangles(
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            None,
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let (m, _) = flat.refined(0.2 / 6.0);
        let (amp, wl) = (0.003, 0.2);
        let r = m.rippled(amp, wl, 5);
        let moved = m.positions.iter().zip(&r.positions);
        let max = moved
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0f32, f32::max);
        assert!((max - amp).abs() < 1e-6, "largest displacement {max}");
        let slope = std::f32::consts::TAU * amp / wl;
        let tilt = (0..r.triangles.len())
            .map(|t| normal(&r, t).angle_between(Vec3::Z))
            .fold(0.0f32, f32::max);
        assert!(
            tilt > 0.2 * slope && tilt < 3.0 * slope,
            "tilt {tilt} for a slope {slope}"
        );
        assert_eq!(r, m.rippled(amp, wl, 5), "not deterministic");
        assert_eq!(m.rippled(0.0, wl, 5), m, "no ripple moves nothing");
    }
}
