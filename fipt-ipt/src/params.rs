//! The unknowns of the joint optimisation and the optimiser that moves them.
//!
//! Per material group g (a scene part, or a triangle): base colour a ∈ [0, 1]³, roughness
//! σ ∈ [0.02, 1] and metallic m ∈ [0, 1]; per emission slot (each side of a triangle, or
//! one for both sides): emitted radiance Le = exp(u) per channel (log-parametrised: radiance
//! spans decades, and Adam's steps are relative to it).
//! Adam with projection onto the ranges after each step, at a rate that decays exponentially.
use fipt_core::color::Rgb;
use fipt_core::reflectance::MIN_ROUGHNESS;
use glam::Vec3;

/// Parameters per group: a (3), σ, m.
pub const PER_GROUP: usize = 5;

/// The log-radiance range: exp(−20) ≈ 2e−9 is black, exp(16) ≈ 9e6 brighter than any light
/// of a normalised scene.
pub const LOG_LE_RANGE: (f32, f32) = (-20.0, 16.0);

/// All unknowns, flat: groups first, then the log-radiance of every emission slot.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub groups: usize,
    /// Emission slots: two per triangle ([`slot`]).
    pub slots: usize,
    pub x: Vec<f32>,
    /// Both sides of a triangle share slot 2t (the odd slots stay black).
    pub two_sided: bool,
    /// Per slot and channel, the largest log-radiance it may emit (empty: no bound beyond
    /// [`LOG_LE_RANGE`]).
    pub log_emission_bound: Vec<f32>,
}

impl Params {
    /// Every group at `albedo`, `roughness`, metallic 0; both sides of every triangle at
    /// radiance `le`, each its own unknown unless `two_sided`.
    pub fn new(
        groups: usize,
        triangles: usize,
        albedo: f32,
        roughness: f32,
        le: f32,
        two_sided: bool,
    ) -> Self {
        let slots = 2 * triangles;
        let mut x = Vec::with_capacity(groups * PER_GROUP + slots * 3);
        for _ in 0..groups {
            x.extend([albedo, albedo, albedo, roughness, 0.0]);
        }
        let u = le.max(1e-30).ln().clamp(LOG_LE_RANGE.0, LOG_LE_RANGE.1);
        x.extend(std::iter::repeat_n(u, slots * 3));
        Params {
            groups,
            slots,
            x,
            two_sided,
            log_emission_bound: vec![],
        }
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    #[inline]
    pub fn albedo_index(g: u32) -> usize {
        g as usize * PER_GROUP
    }
    #[inline]
    pub fn roughness_index(g: u32) -> usize {
        g as usize * PER_GROUP + 3
    }
    #[inline]
    pub fn metallic_index(g: u32) -> usize {
        g as usize * PER_GROUP + 4
    }
    #[inline]
    pub fn emission_index(&self, slot: u32) -> usize {
        self.groups * PER_GROUP + slot as usize * 3
    }

    /// The emission slot of triangle `t` seen from its `front` (the side its winding normal
    /// faces) or its back.
    #[inline]
    pub fn slot(&self, t: u32, front: bool) -> u32 {
        slot(t, front, self.two_sided)
    }

    #[inline]
    pub fn albedo(&self, g: u32) -> Rgb {
        let i = Self::albedo_index(g);
        Vec3::new(self.x[i], self.x[i + 1], self.x[i + 2])
    }
    #[inline]
    pub fn roughness(&self, g: u32) -> f32 {
        self.x[Self::roughness_index(g)]
    }
    #[inline]
    pub fn metallic(&self, g: u32) -> f32 {
        self.x[Self::metallic_index(g)]
    }
    /// Emitted radiance of emission slot `slot`.
    #[inline]
    pub fn emission(&self, slot: u32) -> Rgb {
        let i = self.emission_index(slot);
        Vec3::new(self.x[i].exp(), self.x[i + 1].exp(), self.x[i + 2].exp())
    }

    /// The range of parameter `i`.
    fn range(&self, i: usize) -> (f32, f32) {
        let first = self.groups * PER_GROUP;
        if i >= first {
            let hi = self.log_emission_bound.get(i - first).copied();
            (
                LOG_LE_RANGE.0,
                hi.map_or(LOG_LE_RANGE.1, |b| b.clamp(LOG_LE_RANGE.0, LOG_LE_RANGE.1)),
            )
        } else {
            match i % PER_GROUP {
                3 => (MIN_ROUGHNESS, 1.0),
                _ => (0.0, 1.0),
            }
        }
    }

    /// Projects every parameter onto its range.
    pub fn project(&mut self) {
        for i in 0..self.x.len() {
            let (lo, hi) = self.range(i);
            self.x[i] = self.x[i].clamp(lo, hi);
        }
    }
}

/// The emission slot of triangle `t` seen from its `front` or back: 2t + (back), or 2t for
/// both when `two_sided`.
#[inline]
pub fn slot(t: u32, front: bool, two_sided: bool) -> u32 {
    2 * t + u32::from(!front && !two_sided)
}

/// Adam (Kingma & Ba 2015) with β = (0.9, 0.999).
#[derive(Clone, Debug, PartialEq)]
pub struct Adam {
    pub m: Vec<f32>,
    pub v: Vec<f32>,
    /// Steps taken.
    pub t: u32,
}

impl Adam {
    pub fn new(n: usize) -> Self {
        Adam {
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
        }
    }

    /// One step along −`grad` at rate `lr` for the materials and `lr_emission` for the
    /// log-radiances, then the projection onto the ranges.
    pub fn step(&mut self, p: &mut Params, grad: &[f32], lr: f32, lr_emission: f32) {
        let first_emission = p.groups * PER_GROUP;
        const B1: f32 = 0.9;
        const B2: f32 = 0.999;
        const EPS: f32 = 1e-12;
        self.t += 1;
        let c1 = 1.0 - B1.powi(self.t as i32);
        let c2 = 1.0 - B2.powi(self.t as i32);
        for (i, &g) in grad.iter().enumerate() {
            if !g.is_finite() {
                continue;
            }
            self.m[i] = B1 * self.m[i] + (1.0 - B1) * g;
            self.v[i] = B2 * self.v[i] + (1.0 - B2) * g * g;
            let (mh, vh) = (self.m[i] / c1, self.v[i] / c2);
            let rate = if i < first_emission { lr } else { lr_emission };
            p.x[i] -= rate * mh / (vh.sqrt() + EPS);
        }
        p.project();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_ranges_and_a_step() {
        let mut p = Params::new(2, 3, 0.5, 0.5, 1.0, false);
        assert_eq!(p.len(), 2 * PER_GROUP + 18);
        assert_eq!((p.slot(2, true), p.slot(2, false)), (4, 5));
        assert_eq!((slot(2, true, true), slot(2, false, true)), (4, 4));
        assert_eq!(p.albedo(1), Vec3::splat(0.5));
        assert_eq!(p.emission(2), Vec3::ONE);
        let mut adam = Adam::new(p.len());
        // A gradient pushing everything down by a lot: the first step moves each by lr and the
        // projection keeps σ at 0.02 and a, m at 0.
        let g = vec![1.0; p.len()];
        for _ in 0..200 {
            adam.step(&mut p, &g, 0.1, 0.1);
        }
        assert_eq!(p.albedo(0), Vec3::ZERO);
        assert_eq!(p.roughness(1), MIN_ROUGHNESS);
        assert_eq!(p.metallic(0), 0.0);
        assert!(p.emission(0).max_element() < 1e-8);
        // Non-finite gradients are skipped.
        let before = p.clone();
        let nan = vec![f32::NAN; p.len()];
        adam.step(&mut p, &nan, 0.1, 0.1);
        assert_eq!(p, before);
    }
}
