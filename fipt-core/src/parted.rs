//! A grid map split by key into parts that fill in parallel, each key's updates in the order
//! of its items, so the sums come out as a single map filled one item at a time gives them.
//!
//! The passes over every hit pixel of every view (the SLF, the diffuse cache's cells, the
//! material cache's voxels) add each pixel into a hash map. One map takes one thread; on the
//! scene of FIPT's size those passes cost a minute and more of one core while the other sat
//! idle. Here every part scans all of a batch's keys (computed once, in parallel) and updates
//! only its own, so a key's items arrive in their order whatever the number of parts, and
//! each entry remembers the item that created it: [`PartedMap::into_first_seen`] lists the
//! entries in that order, the order a single map would have met them.
use crate::hash::{GridBuild, GridMap};
use rayon::prelude::*;
use std::hash::{BuildHasher, Hash};

/// At most this many items' keys are held at once.
const KEYS_AT_ONCE: usize = 1 << 20;

/// A map of `K` to `V` split into parts by key; see the module's notes.
pub struct PartedMap<K, V> {
    parts: Vec<GridMap<K, (u64, V)>>,
    /// Items added so far: the stamp of the next batch's first item.
    seen: u64,
    /// At most this many items' keys at once ([`KEYS_AT_ONCE`]; less in tests).
    chunk: usize,
}

/// Which of `n` parts `key` falls in: its grid hash mixed again (splitmix64's finaliser), so
/// the keys within a part still spread over the part's buckets.
#[inline]
pub fn part_of<K: Hash>(key: &K, n: usize) -> usize {
    let mut z = GridBuild::default().hash_one(key);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    ((z as u128 * n as u128) >> 64) as usize
}

impl<K: Hash + Eq + Copy + Send + Sync, V: Send + Sync> PartedMap<K, V> {
    /// An empty map of one part per thread of rayon's pool (the results do not depend on it).
    pub fn new() -> Self {
        Self::with_parts(rayon::current_num_threads())
    }

    /// An empty map of `parts` parts (at least one).
    pub fn with_parts(parts: usize) -> Self {
        PartedMap {
            parts: (0..parts.max(1)).map(|_| GridMap::default()).collect(),
            seen: 0,
            chunk: KEYS_AT_ONCE,
        }
    }

    /// Adds the `items` in order: each item whose `key` (given its index in `items` and the
    /// item) is `Some(k)` updates the entry of `k` with `update`, the entry created by `init`
    /// from the first item of its key.
    pub fn add_all<T: Sync>(
        &mut self,
        items: &[T],
        key: impl Fn(usize, &T) -> Option<K> + Sync,
        init: impl Fn(&T) -> V + Sync,
        update: impl Fn(&mut V, usize, &T) + Sync,
    ) {
        // The keys of a bounded run of items at a time (24 bytes an item for the material
        // cache's keys: 1.5 GiB for the 61 M hits of a scene of FIPT's size in one batch).
        let size = self.chunk;
        for (c, chunk) in items.chunks(size).enumerate() {
            let at = c * size;
            self.add_chunk(chunk, at, &key, &init, &update);
        }
    }

    /// [`PartedMap::add_all`] of `items`, the run of a batch from its index `at`.
    fn add_chunk<T: Sync>(
        &mut self,
        items: &[T],
        at: usize,
        key: &(impl Fn(usize, &T) -> Option<K> + Sync),
        init: &(impl Fn(&T) -> V + Sync),
        update: &(impl Fn(&mut V, usize, &T) + Sync),
    ) {
        let n = self.parts.len();
        let keyed: Vec<Option<(K, u32)>> = (items.par_iter().enumerate())
            .map(|(i, t)| key(at + i, t).map(|k| (k, part_of(&k, n) as u32)))
            .collect();
        let first = self.seen;
        self.parts.par_iter_mut().enumerate().for_each(|(s, map)| {
            for (i, (item, kp)) in items.iter().zip(&keyed).enumerate() {
                let Some((k, p)) = kp else { continue };
                if *p as usize == s {
                    let e = map
                        .entry(*k)
                        .or_insert_with(|| (first + i as u64, init(item)));
                    update(&mut e.1, at + i, item);
                }
            }
        });
        self.seen += items.len() as u64;
    }

    /// Adds one item, as [`PartedMap::add_all`] of a batch of one does, without the threads.
    pub fn add_one(
        &mut self,
        key: Option<K>,
        init: impl FnOnce() -> V,
        update: impl FnOnce(&mut V),
    ) {
        if let Some(k) = key {
            let (n, seen) = (self.parts.len(), self.seen);
            let e = self.parts[part_of(&k, n)]
                .entry(k)
                .or_insert_with(|| (seen, init()));
            update(&mut e.1);
        }
        self.seen += 1;
    }

    /// The entry of `key`.
    pub fn get(&self, key: &K) -> Option<&V> {
        self.parts[part_of(key, self.parts.len())]
            .get(key)
            .map(|(_, v)| v)
    }

    /// Whether `key` has an entry.
    pub fn contains(&self, key: &K) -> bool {
        self.get(key).is_some()
    }

    /// The number of entries.
    pub fn len(&self) -> usize {
        self.parts.iter().map(|p| p.len()).sum()
    }

    /// Whether no item has made an entry.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every entry, in no particular order.
    pub fn iter(&self) -> impl Iterator<Item = (&K, &V)> {
        self.parts
            .iter()
            .flat_map(|p| p.iter().map(|(k, (_, v))| (k, v)))
    }

    /// The entries in the order of the items that created them.
    pub fn into_first_seen(self) -> Vec<(K, V)> {
        let mut all: Vec<(u64, K, V)> = (self.parts.into_iter())
            .flat_map(|p| p.into_iter().map(|(k, (s, v))| (s, k, v)))
            .collect();
        all.sort_unstable_by_key(|e| e.0);
        all.into_iter().map(|(_, k, v)| (k, v)).collect()
    }
}

impl<K: Hash + Eq + Copy + Send + Sync, V: Send + Sync> Default for PartedMap<K, V> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A single map filled one item at a time: the reference the parts must match.
    fn one_map(batches: &[Vec<(i64, f32)>]) -> Vec<(i64, (f32, u32))> {
        let mut order = vec![];
        let mut m: GridMap<i64, (f32, u32)> = GridMap::default();
        for b in batches {
            for &(k, x) in b.iter().filter(|(k, _)| k % 7 != 3) {
                let e = m.entry(k).or_insert_with(|| {
                    order.push(k);
                    (0.0, 0)
                });
                e.0 += x;
                e.1 += 1;
            }
        }
        order.into_iter().map(|k| (k, m[&k])).collect()
    }

    fn batches() -> Vec<Vec<(i64, f32)>> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        (0..5)
            .map(|b| {
                (0..1000 + 300 * b)
                    .map(|_| {
                        let k = (next() % 500) as i64 - 250;
                        // Values of every magnitude, so that another order would round otherwise.
                        let x = f32::from_bits((next() % 0x4000_0000) as u32 + 0x3000_0000);
                        (k, x)
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn any_number_of_parts_sums_as_one_map_in_the_same_order() {
        let b = batches();
        let want = one_map(&b);
        for (parts, chunk) in [
            (1, KEYS_AT_ONCE),
            (2, KEYS_AT_ONCE),
            (3, 97),
            (7, 1),
            (64, 500),
        ] {
            let mut m = PartedMap::with_parts(parts);
            m.chunk = chunk;
            for (bi, batch) in b.iter().enumerate() {
                if bi % 2 == 1 {
                    // Every other batch one item at a time.
                    for &(k, x) in batch {
                        m.add_one(
                            (k % 7 != 3).then_some(k),
                            || (0.0f32, 0u32, k),
                            |e| {
                                e.0 += x;
                                e.1 += 1;
                            },
                        );
                    }
                    continue;
                }
                m.add_all(
                    batch,
                    |i, t| {
                        assert!(std::ptr::eq(&batch[i], t), "the key's index");
                        (t.0 % 7 != 3).then_some(t.0)
                    },
                    // The entry remembers the key of the item that made it.
                    |&(k, _)| (0.0f32, 0u32, k),
                    |e, i, t @ (_, x)| {
                        assert!(std::ptr::eq(&batch[i], t), "the update's index");
                        e.0 += x;
                        e.1 += 1;
                    },
                );
            }
            assert_eq!(m.len(), want.len(), "{parts} parts");
            for (k, v) in &want {
                assert_eq!(
                    m.get(k).map(|v| (v.0.to_bits(), v.1, v.2)),
                    Some((v.0.to_bits(), v.1, *k))
                );
            }
            assert!(!m.contains(&3) && !m.contains(&1000));
            let got: Vec<(i64, u32, u32)> = (m.into_first_seen().into_iter())
                .map(|(k, (x, n, _))| (k, x.to_bits(), n))
                .collect();
            let want: Vec<(i64, u32, u32)> = (want.iter())
                .map(|(k, (x, n))| (*k, x.to_bits(), *n))
                .collect();
            assert_eq!(got, want, "{parts} parts");
        }
    }

    #[test]
    fn parts_split_keys_evenly() {
        let n = 4;
        let mut counts = [0usize; 4];
        for x in 0..64u64 {
            for y in 0..64u64 {
                counts[part_of(&(y * 4096 + x), n)] += 1;
            }
        }
        for c in counts {
            assert!((900..1150).contains(&c), "{counts:?}");
        }
    }
}
