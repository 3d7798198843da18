//! Visibility order of body parts for one view (the paper's section 3.2).
//!
//! The occlusion graph has an edge A → B weighted by how many of B's pixels A hides
//! (averaged over frames). Parts are drawn back to front (painter's algorithm), so B should
//! come before A. If the graph is acyclic a topological order satisfies every edge;
//! otherwise the order drops the edge set of least total weight — a minimum feedback arc
//! set — found exactly by dynamic programming over subsets, `O(2^k·k²)` for `k` parts.

/// Most parts [`draw_order`] accepts (2^k table entries).
pub use crate::limits::MAX_PARTS;

/// The drawing order (first drawn first) and the total weight of occlusions it gets wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct Order {
    pub order: Vec<usize>,
    /// Sum of `hidden[a][b]` over pairs where the occluder `a` is drawn before `b`.
    pub violated_weight: f64,
}

/// Weight of occlusions an order gets wrong.
pub fn violated_weight(hidden: &[Vec<f64>], order: &[usize]) -> f64 {
    let mut w = 0.0;
    for (i, &a) in order.iter().enumerate() {
        for &b in &order[i + 1..] {
            // `a` is drawn before `b`: wrong if `a` occludes `b`.
            w += hidden[a][b];
        }
    }
    w
}

/// The exact best drawing order. `hidden[a][b]` = pixels of part `b` hidden by part `a`.
/// Ties are broken towards the lowest part index first, so the result is deterministic.
pub fn draw_order(hidden: &[Vec<f64>]) -> Order {
    let k = hidden.len().min(MAX_PARTS);
    if k == 0 {
        return Order {
            order: Vec::new(),
            violated_weight: 0.0,
        };
    }
    let full = (1usize << k) - 1;
    let mut best = vec![f64::INFINITY; 1 << k];
    let mut choice = vec![u8::MAX; 1 << k];
    best[0] = 0.0;
    for set in 0..full {
        let base = best[set];
        if !base.is_finite() {
            continue;
        }
        for v in 0..k {
            if set & (1 << v) != 0 {
                continue;
            }
            // Drawing `v` after everything in `set`: wrong for every a in set hiding v.
            let mut add = 0.0;
            for a in 0..k {
                if set & (1 << a) != 0 {
                    add += hidden[a][v];
                }
            }
            let next = set | (1 << v);
            if base + add < best[next] {
                best[next] = base + add;
                choice[next] = v as u8;
            }
        }
    }
    let mut order = Vec::with_capacity(k);
    let mut set = full;
    while set != 0 {
        let v = choice[set] as usize;
        order.push(v);
        set &= !(1 << v);
    }
    order.reverse();
    Order {
        violated_weight: best[full],
        order,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn permutations(k: usize) -> Vec<Vec<usize>> {
        if k == 0 {
            return vec![vec![]];
        }
        let mut out = Vec::new();
        for p in permutations(k - 1) {
            for i in 0..=p.len() {
                let mut q = p.clone();
                q.insert(i, k - 1);
                out.push(q);
            }
        }
        out
    }

    fn random_graph(k: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut s = seed;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 33) as f64 / (1u64 << 31) as f64
        };
        (0..k)
            .map(|a| {
                (0..k)
                    .map(|b| {
                        if a != b && rnd() < 0.5 {
                            (rnd() * 100.0).round()
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn exact_against_all_orders() {
        for k in 1..=7 {
            for seed in 0..12 {
                let g = random_graph(k, seed * 100 + k as u64);
                let got = draw_order(&g);
                let brute = permutations(k)
                    .iter()
                    .map(|p| violated_weight(&g, p))
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(got.violated_weight, brute, "k {k} seed {seed}");
                assert_eq!(violated_weight(&g, &got.order), got.violated_weight);
                let mut sorted = got.order.clone();
                sorted.sort();
                assert_eq!(sorted, (0..k).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn acyclic_graph_gives_a_topological_order() {
        // Torso (0) hides the far arm (1) and far leg (2); the near arm (3) hides the torso.
        let mut g = vec![vec![0.0; 4]; 4];
        g[0][1] = 50.0;
        g[0][2] = 20.0;
        g[3][0] = 30.0;
        let o = draw_order(&g);
        assert_eq!(o.violated_weight, 0.0);
        let pos = |p: usize| o.order.iter().position(|&x| x == p).unwrap();
        assert!(pos(1) < pos(0) && pos(2) < pos(0) && pos(0) < pos(3));
    }

    #[test]
    fn a_cycle_drops_its_lightest_edge() {
        let mut g = vec![vec![0.0; 3]; 3];
        g[0][1] = 10.0;
        g[1][2] = 10.0;
        g[2][0] = 1.0;
        let o = draw_order(&g);
        assert_eq!(o.violated_weight, 1.0);
    }
}
