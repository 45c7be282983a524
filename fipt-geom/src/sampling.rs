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
        Some(TriangleSampler {
            tris: tris.to_vec(),
            cdf,
            prob,
            total: acc,
            pdf_area,
            normal,
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

    /// Samples a point of `mesh` (the mesh the sampler was built for) from `u_sel` (triangle choice) and `u` (position), uniforms in [0, 1).
    pub fn sample(&self, mesh: &Mesh, u_sel: f32, u: Vec2) -> SurfaceSample {
        let target = u_sel as f64 * self.total;
        let k = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.tris.len() - 1);
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
