//! Next-event estimation to the current emitters: emission slots (a side of a triangle)
//! chosen ∝ area × luminance of their current emitted radiance (rebuilt as the optimisation
//! changes it), a point uniform on the triangle, and the area density of that choice on
//! every slot for the MIS weights of BRDF-sampled hits.
use crate::params::Params;
use fipt_core::color::luminance;
use fipt_geom::Mesh;
use glam::{Vec2, Vec3};

/// A point on an emitter.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub slot: u32,
    pub tri: u32,
    pub p: Vec3,
    /// Unit geometric normal (winding).
    pub n: Vec3,
    /// Area density of the point.
    pub pdf_area: f32,
}

/// The emitter sampler of one moment of the optimisation.
pub struct LightSampler<'m> {
    mesh: &'m Mesh,
    /// Emitting slots and their cumulative weights.
    slots: Vec<u32>,
    cdf: Vec<f64>,
    pdf_area: Vec<f32>,
}

impl<'m> LightSampler<'m> {
    /// Slots of `params` chosen ∝ area × luminance(Le).
    pub fn new(mesh: &'m Mesh, params: &Params) -> Self {
        let (mut slots, mut cdf, mut acc) = (vec![], vec![], 0f64);
        let mut weights = vec![0f64; params.slots];
        for s in 0..params.slots as u32 {
            let w =
                mesh.area(s as usize / 2) as f64 * luminance(params.emission(s)).max(0.0) as f64;
            if w > 0.0 && w.is_finite() {
                acc += w;
                slots.push(s);
                cdf.push(acc);
                weights[s as usize] = w;
            }
        }
        let pdf_area = weights
            .iter()
            .enumerate()
            .map(|(s, &w)| {
                let area = mesh.area(s / 2) as f64;
                if w > 0.0 && area > 0.0 {
                    (w / acc / area) as f32
                } else {
                    0.0
                }
            })
            .collect();
        LightSampler {
            mesh,
            slots,
            cdf,
            pdf_area,
        }
    }

    /// A point on an emitter, or None when nothing emits.
    #[inline]
    pub fn sample(&self, u_sel: f32, u: Vec2) -> Option<LightSample> {
        let total = *self.cdf.last()?;
        let k = self
            .cdf
            .partition_point(|&c| c <= u_sel as f64 * total)
            .min(self.slots.len() - 1);
        let slot = self.slots[k];
        let tri = slot / 2;
        let [a, b, c] = self.mesh.vertices(tri as usize);
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        Some(LightSample {
            slot,
            tri,
            p: a * b0 + b * b1 + c * (1.0 - b0 - b1),
            n: self.mesh.face_normal(tri as usize),
            pdf_area: self.pdf_area[slot as usize],
        })
    }

    /// The area density of [`LightSampler::sample`] on emission slot `slot`.
    #[inline]
    pub fn pdf_area(&self, slot: u32) -> f32 {
        self.pdf_area[slot as usize]
    }
}
