//! Sampling points on sets of triangles.
use crate::mesh::Mesh;
use glam::{Vec2, Vec3};

/// A point sampled on a triangle set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    pub tri: u32,
    pub p: Vec3,
    /// Unit geometric normal of the triangle.
    pub n: Vec3,
    /// Probability of choosing this triangle.
    pub p_tri: f32,
    /// Area density of the point: `p_tri / area`.
    pub pdf_area: f32,
}

/// Samples points on a subset of a mesh's triangles, choosing triangle `i` with probability
/// proportional to `weight[i]` and a point uniformly inside it. With weight = area, the points
/// are uniform in area over the set.
#[derive(Clone, Debug)]
pub struct TriangleSampler {
    tris: Vec<u32>,
    cdf: Vec<f64>,
    prob: Vec<f32>,
    total: f64,
    /// Per entry: area density `prob / area` and unit geometric normal (filled by `bind`).
    pdf_area: Vec<f32>,
    normal: Vec<Vec3>,
    /// A guide to the cdf: `guide[j]` is the first entry whose cdf exceeds `edges[j]`, the
    /// edges splitting [0, total] into as many equal buckets as there are entries, so that a
    /// sample searches the few entries of its bucket instead of the whole cdf (the same entry
    /// as a search of the whole).
    edges: Vec<f64>,
    guide: Vec<u32>,
}

impl TriangleSampler {
    /// Uniform-in-area sampler over `tris`. None when the total area is zero.
    pub fn uniform_area(mesh: &Mesh, tris: &[u32]) -> Option<Self> {
        let w: Vec<f64> = tris.iter().map(|&t| mesh.area(t as usize) as f64).collect();
        Self::weighted(mesh, tris, &w)
    }

    /// Sampler choosing `tris[k]` of `mesh` with probability ∝ `weights[k]`. None when all
    /// weights are 0.
    pub fn weighted(mesh: &Mesh, tris: &[u32], weights: &[f64]) -> Option<Self> {
        assert_eq!(tris.len(), weights.len());
        let mut cdf = Vec::with_capacity(tris.len());
        let mut acc = 0.0f64;
        for &w in weights {
            acc += w.max(0.0);
            cdf.push(acc);
        }
        if !(acc > 0.0) {
            return None;
        }
        let prob: Vec<f32> = weights.iter().map(|&w| (w.max(0.0) / acc) as f32).collect();
        let pdf_area = tris
            .iter()
            .zip(&prob)
            .map(|(&t, &p)| p / mesh.area(t as usize))
            .collect();
        let normal = tris.iter().map(|&t| mesh.face_normal(t as usize)).collect();
        let buckets = tris.len().max(1);
        let edges: Vec<f64> = (0..=buckets)
            .map(|j| j as f64 / buckets as f64 * acc)
            .collect();
        let guide = edges
            .iter()
            .map(|&e| cdf.partition_point(|&c| c <= e) as u32)
            .collect();
        Some(TriangleSampler {
            tris: tris.to_vec(),
            cdf,
            prob,
            total: acc,
            pdf_area,
            normal,
            edges,
            guide,
        })
    }

    pub fn len(&self) -> usize {
        self.tris.len()
    }
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }
    /// Sum of the weights.
    pub fn total_weight(&self) -> f64 {
        self.total
    }
    /// Probability of choosing entry `k`.
    pub fn probability(&self, k: usize) -> f32 {
        self.prob[k]
    }
    /// Area density of points sampled on entry `k`: `probability(k) / area`.
    pub fn pdf_area(&self, k: usize) -> f32 {
        self.pdf_area[k]
    }
    /// Triangle ids in sampler order.
    pub fn triangles(&self) -> &[u32] {
        &self.tris
    }

    /// The first entry whose cdf exceeds `target` (`cdf.partition_point(|c| c <= target)`),
    /// searched within the guide's bucket that holds `target`.
    #[inline]
    fn entry_at(&self, target: f64) -> usize {
        let n = self.edges.len() - 1;
        let mut b = ((target / self.total) * n as f64).clamp(0.0, (n - 1) as f64) as usize;
        // Rounding may put the target in a neighbouring bucket: edges[b] ≤ target ≤ edges[b + 1].
        while b > 0 && self.edges[b] > target {
            b -= 1;
        }
        while b + 1 < n && self.edges[b + 1] < target {
            b += 1;
        }
        if !(self.edges[b] <= target && target <= self.edges[b + 1]) {
            return self.cdf.partition_point(|&c| c <= target); // NaN, or outside [0, total]
        }
        let (lo, hi) = (self.guide[b] as usize, self.guide[b + 1] as usize);
        lo + self.cdf[lo..hi].partition_point(|&c| c <= target)
    }

    /// Samples a point of `mesh` (the mesh the sampler was built for) from `u_sel` (triangle choice) and `u` (position), uniforms in [0, 1).
    pub fn sample(&self, mesh: &Mesh, u_sel: f32, u: Vec2) -> SurfaceSample {
        let target = u_sel as f64 * self.total;
        let k = self.entry_at(target).min(self.tris.len() - 1);
        let tri = self.tris[k];
        let [a, b, c] = mesh.vertices(tri as usize);
        // Uniform barycentrics by the square-root warp.
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        let p = a * b0 + b * b1 + c * (1.0 - b0 - b1);
        SurfaceSample {
            tri,
            p,
            n: self.normal[k],
            p_tri: self.prob[k],
            pdf_area: self.pdf_area[k],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The guided search picks the entry a search of the whole cdf picks, for targets at and
    /// around every cdf value and bucket edge, at 0 and the total, and for weights spanning
    /// twelve decades (most buckets then hold no cdf value; one holds almost all).
    #[test]
    fn the_guide_finds_the_entry_a_whole_search_finds() {
        let mesh = Mesh::from_triangles(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            None,
            vec![[0, 1, 2]; 40],
        );
        let tris: Vec<u32> = (0..40).collect();
        let mut rng = fipt_core::rng::Pcg32::new(1, 2);
        for weights in [
            vec![1.0; 40],
            (0..40).map(|i| 10f64.powi(i % 13 - 6)).collect::<Vec<_>>(),
            (0..40)
                .map(|i| {
                    if i % 7 == 0 {
                        0.0
                    } else {
                        rng.next_f32() as f64
                    }
                })
                .collect(),
        ] {
            let s = TriangleSampler::weighted(&mesh, &tris, &weights).unwrap();
            let mut targets: Vec<f64> = vec![0.0, s.total];
            for &c in s.cdf.iter().chain(&s.edges) {
                targets.extend([c, c.next_down(), c.next_up()]);
            }
            targets.extend((0..2000).map(|_| rng.next_f32() as f64 * s.total));
            for t in targets.into_iter().filter(|t| (0.0..=s.total).contains(t)) {
                assert_eq!(s.entry_at(t), s.cdf.partition_point(|&c| c <= t), "{t}");
            }
        }
    }
}
