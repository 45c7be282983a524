//! The material cache's table: voxel key → the field's material, in one flat array of slots
//! (open addressing, linear probing, at most half full).
//!
//! A lookup per secondary hit, at random places in a table of about a million voxels (200
//! views of 640 × 480), missed the cache on every probe: `std`'s map touched its control bytes
//! and then the entry, two misses, and 34 % of the refinement's time went there. Here the key
//! and the material share one 32-byte slot aligned to half a cache line, so a lookup is one
//! miss (36-byte slots, as before 2026-12-02, straddled two lines every other slot).
use fipt_core::field::Material;
use fipt_core::hash::{GridBuild, GridMap};
use glam::Vec3;
use std::hash::BuildHasher;

/// A voxel (x, y, z) and the side its surface faces (`field_surfaces::facing`).
pub(crate) type Key = (i32, i32, i32, u8);

/// Bits of a voxel coordinate in a packed key, relative to the table's lowest voxel.
const BITS: u32 = 20;
const SPAN: u32 = 1 << BITS;

/// One cache line holds two slots whole: the key and the material are read with one miss.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct Slot {
    /// The packed key ([`MaterialTable::pack`]), or [`EMPTY`].
    key: u64,
    albedo: [f32; 3],
    roughness: f32,
    metallic: f32,
}

const EMPTY: u64 = u64::MAX;

const VACANT: Slot = Slot {
    key: EMPTY,
    albedo: [0.0; 3],
    roughness: 0.0,
    metallic: 0.0,
};

/// See the module's notes. Keys are packed into 64 bits relative to the lowest voxel held
/// (20 bits an axis, 3 for the side); a table whose voxels span more than 2²⁰ on an axis (a
/// million cells: not a room) keeps them in a map instead.
pub(crate) enum MaterialTable {
    Packed {
        slots: Vec<Slot>,
        mask: usize,
        len: usize,
        /// The lowest voxel held, per axis.
        origin: [i32; 3],
    },
    Wide(GridMap<Key, Material>),
}

impl MaterialTable {
    /// The table of `entries` (distinct keys; a repeated key keeps its first material).
    pub(crate) fn new(entries: impl ExactSizeIterator<Item = (Key, Material)>) -> Self {
        let entries: Vec<(Key, Material)> = entries.collect();
        let (mut lo, mut hi) = ([i32::MAX; 3], [i32::MIN; 3]);
        for (k, _) in &entries {
            for (a, c) in [k.0, k.1, k.2].into_iter().enumerate() {
                (lo[a], hi[a]) = (lo[a].min(c), hi[a].max(c));
            }
        }
        let fits = (0..3).all(|a| (hi[a] as i64 - lo[a] as i64) < SPAN as i64);
        if !fits || entries.iter().any(|(k, _)| k.3 >= 7) {
            let mut map = GridMap::default();
            for (k, m) in entries {
                map.entry(k).or_insert(m);
            }
            return MaterialTable::Wide(map);
        }
        let origin = if entries.is_empty() { [0; 3] } else { lo };
        let n = (2 * entries.len()).max(16).next_power_of_two();
        let (mut slots, mask, mut len) = (vec![VACANT; n], n - 1, 0);
        for (k, m) in entries {
            let key = Self::pack(origin, &k).expect("within the span");
            let mut i = home(key) & mask;
            loop {
                let s = &mut slots[i];
                if s.key == EMPTY {
                    *s = Slot {
                        key,
                        albedo: m.albedo.to_array(),
                        roughness: m.roughness,
                        metallic: m.metallic,
                    };
                    len += 1;
                    break;
                }
                if s.key == key {
                    break;
                }
                i = (i + 1) & mask;
            }
        }
        MaterialTable::Packed {
            slots,
            mask,
            len,
            origin,
        }
    }

    /// `k` packed relative to `origin`; None outside the table's span (no voxel held there)
    /// or for a side the table cannot hold.
    #[inline]
    fn pack(origin: [i32; 3], k: &Key) -> Option<u64> {
        let rel = |c: i32, o: i32| {
            let r = (c as i64 - o as i64) as u64;
            (r < SPAN as u64).then_some(r)
        };
        let (x, y, z) = (
            rel(k.0, origin[0])?,
            rel(k.1, origin[1])?,
            rel(k.2, origin[2])?,
        );
        (k.3 < 7).then(|| (k.3 as u64) << (3 * BITS) | z << (2 * BITS) | y << BITS | x)
    }

    /// The material at voxel `k`, if it holds one.
    #[inline]
    pub(crate) fn get(&self, k: &Key) -> Option<Material> {
        let (slots, mask, origin) = match self {
            MaterialTable::Packed {
                slots,
                mask,
                origin,
                ..
            } => (slots, *mask, *origin),
            MaterialTable::Wide(map) => return map.get(k).copied(),
        };
        let key = Self::pack(origin, k)?;
        let mut i = home(key) & mask;
        loop {
            let s = &slots[i];
            if s.key == key {
                return Some(Material {
                    albedo: Vec3::from_array(s.albedo),
                    roughness: s.roughness,
                    metallic: s.metallic,
                });
            }
            if s.key == EMPTY {
                return None;
            }
            i = (i + 1) & mask;
        }
    }

    /// Starts fetching the slot where a lookup of `k` begins ([`fipt_core::memory::prefetch`]),
    /// so that work between this and [`MaterialTable::get`] hides the miss.
    #[inline]
    pub(crate) fn prefetch(&self, k: &Key) {
        if let MaterialTable::Packed {
            slots,
            mask,
            origin,
            ..
        } = self
        {
            if let Some(key) = Self::pack(*origin, k) {
                fipt_core::memory::prefetch(&slots[home(key) & mask]);
            }
        }
    }

    /// Voxels held.
    pub(crate) fn len(&self) -> usize {
        match self {
            MaterialTable::Packed { len, .. } => *len,
            MaterialTable::Wide(map) => map.len(),
        }
    }
}

#[inline]
fn home(key: u64) -> usize {
    GridBuild::default().hash_one(key) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mat(x: f32) -> Material {
        Material {
            albedo: Vec3::new(x, x * 0.5, 0.25),
            roughness: x.clamp(0.02, 1.0),
            metallic: 1.0 - x,
        }
    }

    /// Every key put in comes back with its material, bit for bit; keys never put in (the
    /// same voxel on another side, a neighbour) are absent; a repeated key keeps its first.
    #[test]
    fn keys_come_back_with_their_materials_and_others_are_absent() {
        let keys: Vec<Key> = (0..3000)
            .map(|i| (i % 17 - 8, (i / 17) % 13 - 6, i / 221 - 5, (i % 3) as u8))
            .collect();
        let entries = keys
            .iter()
            .enumerate()
            .map(|(i, &k)| (k, mat(i as f32 / 3000.0)));
        let t = MaterialTable::new(
            entries
                .chain([(keys[5], mat(0.9))])
                .collect::<Vec<_>>()
                .into_iter(),
        );
        assert_eq!(t.len(), keys.len());
        let MaterialTable::Packed { slots, .. } = &t else {
            panic!("a small table packs its keys")
        };
        assert!(slots.len() >= 2 * keys.len());
        assert_eq!(std::mem::size_of::<Slot>(), 32);
        assert_eq!(slots.as_ptr() as usize % 32, 0);
        // A prefetch (of any key: held, absent, outside the span) is a hint only.
        for (i, k) in keys.iter().enumerate() {
            t.prefetch(k);
            let m = t.get(k).expect("present");
            assert_eq!(m, mat(i as f32 / 3000.0), "{k:?}");
        }
        for k in [
            (0, 0, 0, 6u8),
            (9, 0, 0, 0),
            (-9, 7, -6, 1),
            (i32::MAX, i32::MIN, 0, 2),
        ] {
            t.prefetch(&k);
            assert!(t.get(&k).is_none(), "{k:?}");
        }
        assert!(MaterialTable::new(std::iter::empty())
            .get(&(0, 0, 0, 0))
            .is_none());
    }

    /// Voxels spread over more than 2²⁰ cells on an axis go to the map, and come back the
    /// same; a side the packing cannot hold (7 or more) too.
    #[test]
    fn a_table_too_wide_to_pack_keeps_its_keys_in_a_map() {
        for keys in [
            vec![(0, 0, 0, 0u8), (1 << 20, -3, 5, 1), (-7, 2, 2, 6)],
            vec![(0, 0, 0, 0u8), (1, 1, 1, 7)],
        ] {
            let entries = keys
                .iter()
                .enumerate()
                .map(|(i, &k)| (k, mat(i as f32 * 0.3)));
            let t = MaterialTable::new(entries.collect::<Vec<_>>().into_iter());
            assert!(matches!(t, MaterialTable::Wide(_)));
            assert_eq!(t.len(), keys.len());
            for (i, k) in keys.iter().enumerate() {
                t.prefetch(k);
                assert_eq!(t.get(k), Some(mat(i as f32 * 0.3)), "{k:?}");
            }
            assert!(t.get(&(5, 5, 5, 0)).is_none());
        }
        // One coordinate short of the span still packs.
        let t = MaterialTable::new(
            vec![
                ((0, 0, 0, 0u8), mat(0.1)),
                (((1 << 20) - 1, 0, 0, 0), mat(0.2)),
            ]
            .into_iter(),
        );
        assert!(matches!(t, MaterialTable::Packed { .. }));
        assert_eq!(t.get(&((1 << 20) - 1, 0, 0, 0)), Some(mat(0.2)));
        assert!(t.get(&(1 << 20, 0, 0, 0)).is_none() && t.get(&(-1, 0, 0, 0)).is_none());
    }
}
