//! The bake's and the refinement's sample streams: points in [0,1)², independent or on a
//! shifted rank-1 lattice.
use fipt_core::rng::Pcg32;
use glam::Vec2;
use serde::{Deserialize, Serialize};

/// How sample directions are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SamplerKind {
    /// Independent uniform random numbers (the reference).
    Independent,
    /// R2 rank-1 lattice with a per-pixel random shift (lower variance).
    Stratified,
}

/// Sample points in [0,1)² for `n` samples.
pub struct SampleStream {
    kind: SamplerKind,
    rng: Pcg32,
    shift: Vec2,
    k: u32,
}

const R2_A1: f64 = 0.754_877_666_246_692_7; // 1/g, g = plastic number
const R2_A2: f64 = 0.569_840_290_998_053_3; // 1/g²

impl SampleStream {
    pub fn new(kind: SamplerKind, keys: &[u64]) -> Self {
        let mut rng = Pcg32::from_keys(keys);
        let shift = rng.next_2d();
        SampleStream {
            kind,
            rng,
            shift,
            k: 0,
        }
    }
    #[inline]
    pub fn next(&mut self) -> Vec2 {
        match self.kind {
            SamplerKind::Independent => self.rng.next_2d(),
            SamplerKind::Stratified => {
                let k = self.k as f64;
                self.k += 1;
                let u = fract_nonneg(self.shift.x as f64 + k * R2_A1) as f32;
                let v = fract_nonneg(self.shift.y as f64 + k * R2_A2) as f32;
                Vec2::new(u.min(0.999_999_94), v.min(0.999_999_94))
            }
        }
    }
}

/// `x.fract()` for +0 ≤ x < 2⁶⁴ (and NaN), bit for bit, without `trunc`: an x86-64 build
/// without SSE4.1 makes `f64::fract` a library call, 1.4 % of the bake's samples. The lattice's
/// values are such (a shift in [0, 1) plus k times a positive constant). Not for −0, ∞ or
/// larger values.
#[inline(always)]
fn fract_nonneg(x: f64) -> f64 {
    x - (x as u64) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fract_nonneg_is_fract_bit_for_bit() {
        let mut rng = Pcg32::new(11, 2);
        let mut xs = vec![
            0.0,
            0.5,
            1.0,
            1.0 - f64::EPSILON,
            2f64.powi(52) + 0.5,
            2f64.powi(53),
            1e18,
        ];
        for k in 0..100_000u32 {
            let shift = rng.next_2d();
            xs.push(shift.x as f64 + k as f64 * R2_A1);
            xs.push(shift.y as f64 + (k as f64) * 1e6 * R2_A2);
        }
        for x in xs {
            assert_eq!(fract_nonneg(x).to_bits(), x.fract().to_bits(), "{x}");
        }
        assert!(fract_nonneg(f64::NAN).is_nan());
    }
}
