//! Next-event estimation to the current emitters: triangles chosen ∝ area × luminance of their
//! current emitted radiance (rebuilt as the optimisation changes it), and the area density
//! of that choice on every triangle for the MIS weights of BRDF-sampled hits.
use crate::params::Params;
use fipt_core::color::luminance;
use fipt_geom::{Mesh, SurfaceSample, TriangleSampler};
use glam::Vec2;

/// The emitter sampler of one moment of the optimisation.
pub struct LightSampler<'m> {
    mesh: &'m Mesh,
    sampler: Option<TriangleSampler>,
    pdf_area: Vec<f32>,
}

impl<'m> LightSampler<'m> {
    /// Triangles of `mesh` chosen ∝ area × luminance(Le) of `params`.
    pub fn new(mesh: &'m Mesh, params: &Params) -> Self {
        let n = mesh.triangles.len();
        let tris: Vec<u32> = (0..n as u32).collect();
        let weights: Vec<f64> = tris
            .iter()
            .map(|&t| mesh.area(t as usize) as f64 * luminance(params.emission(t)).max(0.0) as f64)
            .collect();
        let sampler = TriangleSampler::weighted(mesh, &tris, &weights);
        let mut pdf_area = vec![0.0; n];
        if let Some(s) = &sampler {
            for (k, &t) in s.triangles().iter().enumerate() {
                pdf_area[t as usize] = s.pdf_area(k);
            }
        }
        LightSampler {
            mesh,
            sampler,
            pdf_area,
        }
    }

    /// A point on an emitter, or None when nothing emits.
    #[inline]
    pub fn sample(&self, u_sel: f32, u: Vec2) -> Option<SurfaceSample> {
        self.sampler.as_ref().map(|s| s.sample(self.mesh, u_sel, u))
    }

    /// The area density of [`LightSampler::sample`] on triangle `t`.
    #[inline]
    pub fn pdf_area(&self, t: u32) -> f32 {
        self.pdf_area[t as usize]
    }
}
