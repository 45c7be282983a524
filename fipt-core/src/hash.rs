//! A fast, seedless hasher for the grids' integer keys (voxels, cache cells).
//!
//! `std`'s default hasher (SipHash, randomly seeded) guards maps against keys chosen by an
//! adversary; the voxel and cell keys of a scene are not, and a lookup per secondary hit made
//! SipHash a tenth of the refinement's time. This one is a multiply-rotate per word
//! (Fibonacci hashing) and the same in every process, so a map's order is reproducible too.
use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// Multiplicative hasher for small integer keys; see the module's notes.
#[derive(Default, Clone, Copy)]
pub struct GridHasher(u64);

const K: u64 = 0x9E37_79B9_7F4A_7C15;

impl Hasher for GridHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0.rotate_left(5) ^ b as u64).wrapping_mul(K);
        }
    }
    #[inline]
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0 ^ v).wrapping_mul(K).rotate_left(29);
    }
    #[inline]
    fn write_u32(&mut self, v: u32) {
        self.write_u64(v as u64)
    }
    #[inline]
    fn write_u8(&mut self, v: u8) {
        self.write_u64(v as u64)
    }
    #[inline]
    fn write_i32(&mut self, v: i32) {
        self.write_u64(v as u32 as u64)
    }
    #[inline]
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64)
    }
}

/// The hasher's builder.
pub type GridBuild = BuildHasherDefault<GridHasher>;
/// A map keyed by grid cells.
pub type GridMap<K, V> = HashMap<K, V, GridBuild>;
/// A set of grid cells.
pub type GridSet<K> = HashSet<K, GridBuild>;

/// `x.floor() as i32`, the grid cell of a coordinate in cells, for every `x` (NaN to 0, the
/// ends saturating), without `floorf`: an x86-64 build without SSE4.1 makes `f32::floor` a
/// library call, a visible share of a voxel lookup per path vertex.
#[inline(always)]
pub fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    t.saturating_sub(i32::from(x < t as f32))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::hash::BuildHasher;

    #[test]
    fn floor_i32_is_floor_then_cast_everywhere() {
        let mut xs = vec![
            0.0f32,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            2147483648.0,
            -2147483648.0,
            -2147483904.0,
            8388608.5,
        ];
        for i in -3000..3000 {
            let x = i as f32 * 0.37;
            xs.extend([
                x,
                x.next_up(),
                x.next_down(),
                i as f32,
                (i as f32).next_down(),
            ]);
        }
        let mut bits = 0x1234_5678u32;
        for _ in 0..200_000 {
            bits = bits.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            xs.push(f32::from_bits(bits));
        }
        for x in xs {
            assert_eq!(floor_i32(x), x.floor() as i32, "x = {x:e}");
        }
    }

    #[test]
    fn neighbouring_keys_spread_over_the_buckets() {
        // Keys of a 16³ block of voxels: the low 12 bits of their hashes (what a table of 4096
        // buckets indexes by) take most values, not a handful (a random hash takes 63 %,
        // 2,589 of them; this one 2,494).
        let b = GridBuild::default();
        let mut seen = std::collections::HashSet::new();
        for x in 0..16i32 {
            for y in 0..16i32 {
                for z in 0..16i32 {
                    seen.insert(b.hash_one((x, y, z, 1u8)) & 0xfff);
                }
            }
        }
        assert!(seen.len() > 2300, "{} of 4096 buckets", seen.len());
    }

    #[test]
    fn the_same_key_hashes_the_same_in_every_map() {
        let a = GridBuild::default().hash_one((3i32, -7i32, 11i32, 2u8));
        let b = GridBuild::default().hash_one((3i32, -7i32, 11i32, 2u8));
        assert_eq!(a, b);
        assert_ne!(a, GridBuild::default().hash_one((3i32, -7i32, 12i32, 2u8)));
    }
}
