//! Disjoint sets (union–find) over `0..n`: the grouping the emitter extraction (triangles into
//! lights), the mesh's smooth patches and the exposure fit (views linked by shared cells) need.
//!
//! A union keeps the smaller root as the root of both, so a set's root is its smallest member
//! and the grouping does not depend on the order of the unions: callers number their groups
//! by root and get the same numbers on every run.

/// Disjoint sets over `0..n` with path halving.
#[derive(Clone, Debug)]
pub struct DisjointSets {
    parent: Vec<u32>,
}

impl DisjointSets {
    /// `n` singletons.
    ///
    /// # Panics
    /// When `n` exceeds `u32::MAX` elements.
    pub fn new(n: usize) -> Self {
        let n = u32::try_from(n).expect("at most u32::MAX elements");
        DisjointSets {
            parent: (0..n).collect(),
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// True without elements.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The root of `i`'s set: its smallest member.
    #[inline]
    pub fn find(&mut self, i: usize) -> usize {
        let mut i = i as u32;
        while self.parent[i as usize] != i {
            let up = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = up;
            i = up;
        }
        i as usize
    }

    /// Joins the sets of `a` and `b`; returns the root of the joined set.
    #[inline]
    pub fn union(&mut self, a: usize, b: usize) -> usize {
        let (ra, rb) = (self.find(a), self.find(b));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        self.parent[hi] = lo as u32;
        lo
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// The sets after random unions are the connected components of the union graph (found
    /// by a flood fill), each rooted at its smallest member, in any order of the unions.
    #[test]
    fn sets_are_the_components_of_the_unions_rooted_at_their_smallest_member() {
        let mut rng = Pcg32::new(7, 11);
        for n in [1usize, 2, 17, 300] {
            let pairs: Vec<(usize, usize)> = (0..n / 2 + 1)
                .map(|_| {
                    let a = (rng.next_u32() as usize) % n;
                    let b = (rng.next_u32() as usize) % n;
                    (a, b)
                })
                .collect();
            // Components by flood fill over the pairs.
            let mut comp = vec![usize::MAX; n];
            for s in 0..n {
                if comp[s] != usize::MAX {
                    continue;
                }
                let mut stack = vec![s];
                comp[s] = s;
                while let Some(v) = stack.pop() {
                    for &(a, b) in &pairs {
                        for (x, y) in [(a, b), (b, a)] {
                            if x == v && comp[y] == usize::MAX {
                                comp[y] = s;
                                stack.push(y);
                            }
                        }
                    }
                }
            }
            for order in [false, true] {
                let mut sets = DisjointSets::new(n);
                let mut it: Vec<_> = pairs.clone();
                if order {
                    it.reverse();
                }
                for (a, b) in it {
                    let r = sets.union(a, b);
                    assert_eq!(r, sets.find(a));
                    assert_eq!(r, sets.find(b));
                }
                for (v, &c) in comp.iter().enumerate() {
                    // The flood fill starts each component at its smallest member.
                    assert_eq!(sets.find(v), c, "n {n}, element {v}");
                }
            }
        }
    }
}
