//! Two labels over a graph at the least energy: each node's cost of either label, plus a
//! penalty for every edge whose ends differ (a Potts term). The exact minimum is a minimum
//! s–t cut (Greig, Porteous and Seheult 1989), found here by Dinic's maximum flow: the gloss
//! split ([`crate::gloss`]) labels a region's surface cells with it, so that a finish's edge is
//! drawn where the cells' own evidence and the shortest outline agree.

/// A flow network: node 0 is the source, node 1 the sink.
struct Network {
    /// Per edge: its head and remaining capacity; edge `e ^ 1` is its reverse.
    head: Vec<usize>,
    cap: Vec<f64>,
    out: Vec<Vec<usize>>,
}

impl Network {
    fn new(nodes: usize) -> Self {
        Network {
            head: vec![],
            cap: vec![],
            out: vec![vec![]; nodes],
        }
    }

    /// An edge `a → b` of capacity `ab` whose reverse has capacity `ba`.
    fn edge(&mut self, a: usize, b: usize, ab: f64, ba: f64) {
        self.out[a].push(self.head.len());
        self.head.push(b);
        self.cap.push(ab);
        self.out[b].push(self.head.len());
        self.head.push(a);
        self.cap.push(ba);
    }

    /// Each node's distance from the source over edges with capacity left (None: unreached).
    fn levels(&self) -> Vec<Option<u32>> {
        let mut level = vec![None; self.out.len()];
        level[0] = Some(0);
        let mut queue = std::collections::VecDeque::from([0usize]);
        while let Some(v) = queue.pop_front() {
            for &e in &self.out[v] {
                let w = self.head[e];
                if self.cap[e] > 0.0 && level[w].is_none() {
                    level[w] = Some(level[v].unwrap_or(0) + 1);
                    queue.push_back(w);
                }
            }
        }
        level
    }

    /// Pushes flow along one shortest augmenting path from `v` (iterative; `next` keeps each
    /// node's first edge not yet exhausted); the amount pushed, 0 when none is left.
    fn augment(&mut self, level: &[Option<u32>], next: &mut [usize]) -> f64 {
        let mut path: Vec<usize> = vec![];
        let mut v = 0;
        loop {
            if v == 1 {
                let pushed = path
                    .iter()
                    .map(|&e| self.cap[e])
                    .fold(f64::INFINITY, f64::min);
                for &e in &path {
                    self.cap[e] -= pushed;
                    self.cap[e ^ 1] += pushed;
                }
                return pushed;
            }
            let step = (next[v]..self.out[v].len()).find(|&k| {
                let e = self.out[v][k];
                let w = self.head[e];
                self.cap[e] > 0.0 && level[w].is_some() && level[w] == level[v].map(|l| l + 1)
            });
            match step {
                Some(k) => {
                    next[v] = k;
                    let e = self.out[v][k];
                    path.push(e);
                    v = self.head[e];
                }
                None => {
                    // A dead end: never enter it again in this phase, and step back.
                    next[v] = self.out[v].len();
                    let Some(e) = path.pop() else {
                        return 0.0;
                    };
                    v = self.head[e ^ 1];
                    next[v] += 1;
                }
            }
        }
    }

    /// The maximum flow; afterwards the nodes the source still reaches are its side of a
    /// minimum cut.
    fn max_flow(&mut self) {
        loop {
            let level = self.levels();
            if level[1].is_none() {
                return;
            }
            let mut next = vec![0usize; self.out.len()];
            while self.augment(&level, &mut next) > 0.0 {}
        }
    }
}

/// The labels (false / true) of `cost.len()` nodes minimising Σ cost[i][label i] + Σ over
/// `edges` (i, j, w) of w when i and j differ. Costs and weights must be finite, weights ≥ 0.
pub fn two_labels(cost: &[[f64; 2]], edges: &[(usize, usize, f64)]) -> Vec<bool> {
    let n = cost.len();
    let mut net = Network::new(n + 2);
    for (i, c) in cost.iter().enumerate() {
        // Label true is the sink side: cutting source → i pays the cost of true.
        let d = c[1] - c[0];
        if d > 0.0 {
            net.edge(0, i + 2, d, 0.0);
        } else if d < 0.0 {
            net.edge(i + 2, 1, -d, 0.0);
        }
    }
    for &(i, j, w) in edges {
        if i != j && w > 0.0 {
            net.edge(i + 2, j + 2, w, w);
        }
    }
    net.max_flow();
    let reached = net.levels();
    (0..n).map(|i| reached[i + 2].is_none()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_core::rng::Pcg32;

    fn energy(cost: &[[f64; 2]], edges: &[(usize, usize, f64)], x: &[bool]) -> f64 {
        let unary: f64 = cost.iter().zip(x).map(|(c, &l)| c[l as usize]).sum();
        let pair: f64 = (edges.iter())
            .filter(|e| x[e.0] != x[e.1])
            .map(|e| e.2)
            .sum();
        unary + pair
    }

    #[test]
    fn the_cut_is_the_least_energy_of_every_labelling() {
        let mut rng = Pcg32::new(7, 1);
        for trial in 0..200 {
            let n = 1 + trial % 10;
            let cost: Vec<[f64; 2]> = (0..n)
                .map(|_| {
                    [
                        rng.next_f32() as f64 * 4.0 - 1.0,
                        rng.next_f32() as f64 * 4.0 - 1.0,
                    ]
                })
                .collect();
            let mut edges = vec![];
            for i in 0..n {
                for j in i + 1..n {
                    if rng.next_f32() < 0.4 {
                        edges.push((i, j, rng.next_f32() as f64 * 2.0));
                    }
                }
            }
            let got = two_labels(&cost, &edges);
            let best = (0..1u32 << n)
                .map(|m| {
                    let x: Vec<bool> = (0..n).map(|i| m >> i & 1 == 1).collect();
                    energy(&cost, &edges, &x)
                })
                .fold(f64::INFINITY, f64::min);
            let e = energy(&cost, &edges, &got);
            assert!(
                (e - best).abs() < 1e-9,
                "trial {trial}: {e} against the least {best}"
            );
        }
    }

    #[test]
    fn a_strong_neighbourhood_outvotes_one_node_and_a_free_one_does_not() {
        // A chain of five: the ends and the middle prefer true weakly except node 2,
        // which prefers false.
        let cost = vec![[1.0, 0.0], [1.0, 0.0], [0.0, 0.5], [1.0, 0.0], [1.0, 0.0]];
        let chain = |w: f64| (0..4).map(|i| (i, i + 1, w)).collect::<Vec<_>>();
        assert_eq!(two_labels(&cost, &chain(1.0)), vec![true; 5]);
        assert_eq!(
            two_labels(&cost, &chain(0.0)),
            vec![true, true, false, true, true]
        );
    }
}
