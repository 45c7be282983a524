//! The material cache's table: voxel key → the field's material, in one flat array of slots
//! (open addressing, linear probing, at most half full).
//!
//! A lookup per secondary hit, at random places in a table of about a million voxels (200
//! views of 640 × 480), missed the cache on every probe: `std`'s map touched its control bytes
//! and then the entry, two misses, and 34 % of the refinement's time went there. Here the key
//! and the material share one 36-byte slot, so a lookup is about one miss.
use fipt_core::field::Material;
use fipt_core::hash::GridBuild;
use glam::Vec3;
use std::hash::BuildHasher;

/// A voxel (x, y, z) and the side its surface faces (`field_surfaces::facing`).
pub(crate) type Key = (i32, i32, i32, u8);

#[derive(Clone, Copy)]
#[repr(C)]
struct Slot {
    key: [i32; 3],
    /// The side, or [`EMPTY`].
    side: u32,
    albedo: [f32; 3],
    roughness: f32,
    metallic: f32,
}

const EMPTY: u32 = u32::MAX;

const VACANT: Slot = Slot {
    key: [0; 3],
    side: EMPTY,
    albedo: [0.0; 3],
    roughness: 0.0,
    metallic: 0.0,
};

/// See the module's notes.
pub(crate) struct MaterialTable {
    slots: Vec<Slot>,
    mask: usize,
    len: usize,
}

impl MaterialTable {
    /// The table of `entries` (distinct keys; a repeated key keeps its first material).
    pub(crate) fn new(entries: impl ExactSizeIterator<Item = (Key, Material)>) -> Self {
        let n = (2 * entries.len()).max(16).next_power_of_two();
        let mut t = MaterialTable {
            slots: vec![VACANT; n],
            mask: n - 1,
            len: 0,
        };
        for (k, m) in entries {
            let mut i = t.home(&k);
            loop {
                let s = &mut t.slots[i];
                if s.side == EMPTY {
                    *s = Slot {
                        key: [k.0, k.1, k.2],
                        side: k.3 as u32,
                        albedo: m.albedo.to_array(),
                        roughness: m.roughness,
                        metallic: m.metallic,
                    };
                    t.len += 1;
                    break;
                }
                if s.key == [k.0, k.1, k.2] && s.side == k.3 as u32 {
                    break;
                }
                i = (i + 1) & t.mask;
            }
        }
        t
    }

    #[inline]
    fn home(&self, k: &Key) -> usize {
        GridBuild::default().hash_one(k) as usize & self.mask
    }

    /// The material at voxel `k`, if it holds one.
    #[inline]
    pub(crate) fn get(&self, k: &Key) -> Option<Material> {
        let mut i = self.home(k);
        loop {
            let s = &self.slots[i];
            if s.side == EMPTY {
                return None;
            }
            if s.key == [k.0, k.1, k.2] && s.side == k.3 as u32 {
                return Some(Material {
                    albedo: Vec3::from_array(s.albedo),
                    roughness: s.roughness,
                    metallic: s.metallic,
                });
            }
            i = (i + 1) & self.mask;
        }
    }

    /// Voxels held.
    pub(crate) fn len(&self) -> usize {
        self.len
    }
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
        assert!(t.slots.len() >= 2 * keys.len());
        for (i, k) in keys.iter().enumerate() {
            let m = t.get(k).expect("present");
            assert_eq!(m, mat(i as f32 / 3000.0), "{k:?}");
        }
        for k in [
            (0, 0, 0, 6u8),
            (9, 0, 0, 0),
            (-9, 7, -6, 1),
            (i32::MAX, i32::MIN, 0, 2),
        ] {
            assert!(t.get(&k).is_none(), "{k:?}");
        }
        assert!(MaterialTable::new(std::iter::empty())
            .get(&(0, 0, 0, 0))
            .is_none());
    }
}
