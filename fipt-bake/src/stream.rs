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
                let u = (self.shift.x as f64 + k * R2_A1).fract() as f32;
                let v = (self.shift.y as f64 + k * R2_A2).fract() as f32;
                Vec2::new(u.min(0.999_999_94), v.min(0.999_999_94))
            }
        }
    }
}
