//! Deterministic random numbers: a PCG32 generator and seed derivation.
//!
//! Every sample in fipt comes from a generator seeded from `(global seed, pixel/point index,
//! pass)`, so results do not depend on thread scheduling.

/// PCG32 (XSH-RR output, 64-bit LCG state), after O'Neill's description.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const MULT: u64 = 6364136223846793005;

impl Pcg32 {
    /// A generator for stream `stream` started from `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// A generator whose seed mixes several keys (e.g. global seed, pixel index, pass).
    pub fn from_keys(keys: &[u64]) -> Self {
        let mut h = 0x9E37_79B9_7F4A_7C15u64;
        for &k in keys {
            h = splitmix64(h ^ k);
        }
        Pcg32::new(h, splitmix64(h ^ 0xDA94_2042_E4DD_58B5))
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1), 24 bits of mantissa (never returns 1.0).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniforms in [0, 1).
    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// Whether pixel `pixel` of view `view` is in a uniform random subset holding `share` of the
/// pixels, decided from (`seed`, view, pixel) alone: the same pixels for the same seed, in
/// any order and on any thread. Used wherever a stage keeps a share of the views' pixels.
#[inline]
pub fn pixel_kept(seed: u64, view: usize, pixel: usize, share: f64) -> bool {
    if share >= 1.0 {
        return true;
    }
    let below = (share.max(0.0) * 4_294_967_296.0) as u64;
    let mut rng = Pcg32::from_keys(&[seed, 0x5E7C, view as u64, pixel as u64]);
    u64::from(rng.next_u32()) < below
}

/// SplitMix64 finaliser: a good 64-bit mixing function.
#[inline]
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_keys_same_stream_and_uniform_mean() {
        let mut a = Pcg32::from_keys(&[1, 2, 3]);
        let mut b = Pcg32::from_keys(&[1, 2, 3]);
        let mut c = Pcg32::from_keys(&[1, 2, 4]);
        let xs: Vec<u32> = (0..16).map(|_| a.next_u32()).collect();
        let ys: Vec<u32> = (0..16).map(|_| b.next_u32()).collect();
        let zs: Vec<u32> = (0..16).map(|_| c.next_u32()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs);
        let n = 200_000;
        let mean: f64 = (0..n).map(|_| a.next_f32() as f64).sum::<f64>() / n as f64;
        // std of the mean = sqrt(1/12/n) ≈ 6.5e-4; 5 sigma.
        assert!((mean - 0.5).abs() < 3.3e-3, "mean {mean}");
        assert!((0..n).all(|_| a.next_f32() < 1.0));
    }
}
