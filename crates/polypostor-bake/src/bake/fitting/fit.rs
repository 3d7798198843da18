//! Polygon fitting (the paper's section 3.1): map the vertices of a source polygon `S`
//! (n vertices, triangulated without interior vertices) onto the vertices of a target
//! polygon `T` (m vertices) so that the summed per-triangle error is minimal.
//!
//! Exact dynamic program over the triangulation's dual tree, `O(n·m³)`: triangles are peeled
//! in an order where each has one unprocessed neighbour; for the shared "base edge" (a, b)
//! of each, a table over all `(P(a), P(b))` keeps the best `P(c)` of the opposite vertex and
//! the best cost of everything already processed behind that edge. The last triangle closes
//! the tree; backtracking in reverse order recovers `P`. Triangles may degenerate (several
//! source vertices may map to one target vertex), as in the paper.

use std::collections::HashMap;

/// A solved mapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// `mapping[i]` is the target vertex of source vertex `i`.
    pub mapping: Vec<usize>,
    /// The summed error of all triangles.
    pub cost: f64,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FitError {
    #[error("the target polygon has no vertices")]
    EmptyTarget,
    #[error("the source triangulation is empty")]
    NoTriangles,
    #[error("triangle {0} refers to a vertex outside the source polygon")]
    BadVertex(usize),
    #[error("the triangles do not form a tree through shared edges (triangle {0})")]
    NotATree(usize),
    #[error("the fast mode was given no seed to start from")]
    NoSeed,
}

/// The peeling order and base edges of a triangulation, independent of the target.
#[derive(Clone, Debug)]
pub struct Plan {
    n: usize,
    /// Triangles as given.
    triangles: Vec<[usize; 3]>,
    /// Processing order; each entry `(triangle, a, b, c)` with (a, b) the base edge (the
    /// last entry has none and lists its vertices as a, b, c).
    order: Vec<(usize, usize, usize, usize)>,
}

fn key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

impl Plan {
    /// Orders the triangles by repeatedly removing one with a single remaining neighbour.
    pub fn new(n: usize, triangles: &[[usize; 3]]) -> Result<Self, FitError> {
        if triangles.is_empty() {
            return Err(FitError::NoTriangles);
        }
        for (t, tri) in triangles.iter().enumerate() {
            if tri.iter().any(|&v| v >= n) {
                return Err(FitError::BadVertex(t));
            }
        }
        let mut by_edge: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                by_edge.entry(key(tri[k], tri[(k + 1) % 3])).or_default().push(t);
            }
        }
        let neighbours: Vec<Vec<(usize, (usize, usize))>> = triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                (0..3)
                    .flat_map(|k| {
                        let e = key(tri[k], tri[(k + 1) % 3]);
                        by_edge[&e].iter().filter(move |&&u| u != t).map(move |&u| (u, e))
                    })
                    .collect()
            })
            .collect();
        if by_edge.values().any(|v| v.len() > 2) {
            return Err(FitError::NotATree(0));
        }
        let count = triangles.len();
        let mut remaining: Vec<usize> = neighbours.iter().map(|v| v.len()).collect();
        let mut done = vec![false; count];
        let mut order = Vec::with_capacity(count);
        let mut roots = 0;
        // Deterministic: always the lowest-index leaf.
        let mut leaves: std::collections::BTreeSet<usize> = (0..count).filter(|&t| remaining[t] <= 1).collect();
        while let Some(t) = leaves.pop_first() {
            if done[t] {
                continue;
            }
            done[t] = true;
            let tri = triangles[t];
            let open: Vec<&(usize, (usize, usize))> = neighbours[t].iter().filter(|(u, _)| !done[*u]).collect();
            match open.as_slice() {
                [] => {
                    roots += 1;
                    order.push((t, tri[0], tri[1], tri[2]));
                }
                [(u, (e0, e1))] => {
                    // Orient (a, b, c) along the triangle's own vertex order.
                    let k = (0..3)
                        .find(|&k| key(tri[k], tri[(k + 1) % 3]) == (*e0, *e1))
                        .ok_or(FitError::NotATree(t))?;
                    order.push((t, tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]));
                    remaining[*u] -= 1;
                    if remaining[*u] <= 1 {
                        leaves.insert(*u);
                    }
                }
                _ => return Err(FitError::NotATree(t)),
            }
        }
        // A tree peels completely, and only its last triangle has no open neighbour.
        if order.len() != count || roots != 1 {
            return Err(FitError::NotATree(order.first().map_or(0, |o| o.0)));
        }
        Ok(Self {
            n,
            triangles: triangles.to_vec(),
            order,
        })
    }

    /// Vertices of the source polygon.
    pub fn vertex_count(&self) -> usize {
        self.n
    }

    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// For each triangle, the corner (0..3, in the triangle's own vertex order) whose target
    /// the solves vary fastest: for fixed targets of the other two corners, a solve asks for
    /// the costs of every candidate of this one in a row (a cost cache can lay them out
    /// side by side).
    pub fn inner_corners(&self) -> Vec<usize> {
        let mut corners = vec![2; self.triangles.len()];
        for &(t, _, _, c) in &self.order {
            corners[t] = self.triangles[t].iter().position(|&v| v == c).unwrap_or(2);
        }
        corners
    }

    /// Solves the fit exactly. `cost(t, [pa, pb, pc])` is the error of mapping triangle `t`'s
    /// vertices `triangles[t] = [a, b, c]` to target vertices `pa, pb, pc` (in that order).
    pub fn solve(&self, m: usize, cost: impl Fn(usize, [usize; 3]) -> f64) -> Result<Fit, FitError> {
        if m == 0 {
            return Err(FitError::EmptyTarget);
        }
        let all: Vec<usize> = (0..m).collect();
        self.solve_candidates(&vec![all; self.n], cost)
    }

    /// Solves the fit exactly over restricted choices: source vertex `i` may only map to a
    /// target vertex in `candidates[i]`. With every target vertex as a candidate this is
    /// [`Plan::solve`]; with one candidate it pins the vertex. Cost `O(n·k³)` for `k`
    /// candidates per vertex.
    pub fn solve_candidates(
        &self,
        candidates: &[Vec<usize>],
        cost: impl Fn(usize, [usize; 3]) -> f64,
    ) -> Result<Fit, FitError> {
        self.solve_bounded(candidates, |t, p, _| cost(t, p))
    }

    /// [`Plan::solve_candidates`] with a cost that may stop early: `cost.cost(t, p, limit)` must
    /// return the exact error when it is below `limit`, and any value `>= limit` otherwise.
    /// Costs are non-negative, so a choice whose subtrees alone already reach the best found
    /// so far is skipped without evaluating its triangle; the result is still exact.
    pub fn solve_bounded(&self, candidates: &[Vec<usize>], cost: impl TriangleCost) -> Result<Fit, FitError> {
        Ok(self
            .solve_below(candidates, cost, f64::INFINITY)?
            .expect("a finite optimum is below infinity"))
    }

    /// [`Plan::solve_bounded`] looking only for mappings that cost less than `upper` (a
    /// known solution's cost): every partial table entry at or above `upper` is dropped
    /// unevaluated, since costs are non-negative and the rest of the polygon can only add.
    /// The optimum when it is below `upper` (exactly as `solve_bounded` finds it), else `None`.
    pub fn solve_below(
        &self,
        candidates: &[Vec<usize>],
        cost: impl TriangleCost,
        upper: f64,
    ) -> Result<Option<Fit>, FitError> {
        if candidates.len() < self.n || candidates.iter().take(self.n).any(|c| c.is_empty()) {
            return Err(FitError::EmptyTarget);
        }
        // Where each of (a, b, c) sits in triangle t's own vertex order.
        let slots = |t: usize, a: usize, b: usize| -> [usize; 3] {
            self.triangles[t].map(|v| {
                if v == a {
                    0
                } else if v == b {
                    1
                } else {
                    2
                }
            })
        };
        // Solved tables, one per base edge (a, b): best cost behind the edge and the argmin
        // candidate of the opposite vertex, indexed `[ka * |cand b| + kb]`.
        let mut best_of: Vec<Vec<f64>> = Vec::with_capacity(self.order.len());
        let mut arg_of: Vec<Vec<u32>> = Vec::with_capacity(self.order.len());
        let mut by_edge: HashMap<(usize, usize), usize> = HashMap::new();
        // A solved table seen from edge (x, y): value at (kx, ky), or zero where nothing
        // lies behind the edge.
        type View<'t> = Option<(&'t [f64], usize, usize)>;
        fn view<'t>(
            best_of: &'t [Vec<f64>],
            by_edge: &HashMap<(usize, usize), usize>,
            candidates: &[Vec<usize>],
            x: usize,
            y: usize,
        ) -> View<'t> {
            if let Some(&i) = by_edge.get(&(x, y)) {
                Some((i, candidates[y].len(), 1))
            } else {
                by_edge.get(&(y, x)).map(|&i| (i, 1, candidates[x].len()))
            }
            .map(|(i, sx, sy)| (best_of[i].as_slice(), sx, sy))
        }
        let at = |v: View, kx: usize, ky: usize| match v {
            Some((d, sx, sy)) => d[kx * sx + ky * sy],
            None => 0.0,
        };
        let (last, rest) = self.order.split_last().expect("non-empty");
        for &(t, a, b, c) in rest {
            let (ca, cb, cc) = (&candidates[a], &candidates[b], &candidates[c]);
            let slot = slots(t, a, b);
            let mut best = vec![f64::INFINITY; ca.len() * cb.len()];
            let mut arg = vec![0u32; ca.len() * cb.len()];
            {
                let vac = view(&best_of, &by_edge, candidates, a, c);
                let vcb = view(&best_of, &by_edge, candidates, c, b);
                let mut warm = 0usize;
                for (ka, &pa) in ca.iter().enumerate() {
                    for (kb, &pb) in cb.iter().enumerate() {
                        // Start from the previous pair's answer (`warm`): neighbouring pairs
                        // usually share it, and a good first bound prunes the rest. Then the
                        // others in order. One call site, so the cost is compiled inline.
                        let mut bc = upper;
                        let mut bi = warm;
                        for step in 0..cc.len() {
                            let kc = if step == 0 {
                                warm
                            } else if step <= warm {
                                step - 1
                            } else {
                                step
                            };
                            let lb = at(vac, ka, kc) + at(vcb, kc, kb);
                            let v = if lb >= bc {
                                f64::INFINITY
                            } else {
                                let q = [pa, pb, cc[kc]];
                                lb + cost.cost(t, slot.map(|s| q[s]), bc - lb)
                            };
                            if step == 0 {
                                bc = v.min(upper);
                            } else if v < bc || (v == bc && kc < bi) {
                                bc = v;
                                bi = kc;
                            }
                        }
                        warm = bi;
                        best[ka * cb.len() + kb] = if bc < upper { bc } else { f64::INFINITY };
                        arg[ka * cb.len() + kb] = bi as u32;
                    }
                }
            }
            by_edge.insert((a, b), best_of.len());
            best_of.push(best);
            arg_of.push(arg);
        }
        let &(t, a, b, c) = last;
        let slot = slots(t, a, b);
        let (vab, vbc, vca) = (
            view(&best_of, &by_edge, candidates, a, b),
            view(&best_of, &by_edge, candidates, b, c),
            view(&best_of, &by_edge, candidates, c, a),
        );
        let mut best = (upper, 0, 0, 0);
        for (ka, &pa) in candidates[a].iter().enumerate() {
            for (kb, &pb) in candidates[b].iter().enumerate() {
                let lab = at(vab, ka, kb);
                if lab >= best.0 {
                    continue;
                }
                for (kc, &pc) in candidates[c].iter().enumerate() {
                    let lb = lab + at(vbc, kb, kc) + at(vca, kc, ka);
                    if lb >= best.0 {
                        continue;
                    }
                    let q = [pa, pb, pc];
                    let v = lb + cost.cost(t, slot.map(|s| q[s]), best.0 - lb);
                    if v < best.0 {
                        best = (v, ka, kb, kc);
                    }
                }
            }
        }
        if !(best.0 < upper) {
            return Ok(None);
        }
        // Backtrack in candidate indices, then translate.
        let mut k = vec![usize::MAX; self.n];
        k[a] = best.1;
        k[b] = best.2;
        k[c] = best.3;
        for (i, &(_, a, b, c)) in rest.iter().enumerate().rev() {
            k[c] = arg_of[i][k[a] * candidates[b].len() + k[b]] as usize;
        }
        // Vertices in no triangle (cannot happen for a triangulated polygon) take their first candidate.
        let mapping = k
            .iter()
            .enumerate()
            .map(|(i, &ki)| candidates[i][if ki == usize::MAX { 0 } else { ki }])
            .collect();
        Ok(Some(Fit { mapping, cost: best.0 }))
    }
}

/// The error of mapping a triangle onto target vertices, as the solves ask for it:
/// `cost(t, p, limit)` is the error of triangle `t` mapped onto `p`, exact when below `limit`
/// and any value `>= limit` otherwise. Every such closure is one; a type of its own (the fast
/// mode's cost cache) has its look-up compiled into the solve's inner loop, where a closure
/// called through a reference was not inlined and passed its corners through memory.
pub trait TriangleCost {
    fn cost(&self, t: usize, p: [usize; 3], limit: f64) -> f64;
}

impl<F: Fn(usize, [usize; 3], f64) -> f64> TriangleCost for F {
    #[inline(always)]
    fn cost(&self, t: usize, p: [usize; 3], limit: f64) -> f64 {
        self(t, p, limit)
    }
}

/// Total cost of a given mapping (the objective the fit minimises).
pub fn mapping_cost(triangles: &[[usize; 3]], mapping: &[usize], cost: impl Fn(usize, [usize; 3]) -> f64) -> f64 {
    triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| cost(t, tri.map(|v| mapping[v])))
        .sum()
}

/// Exhaustive search over all `m^n` mappings (tests and tiny cases only).
pub fn brute_force(n: usize, triangles: &[[usize; 3]], m: usize, cost: impl Fn(usize, [usize; 3]) -> f64) -> Fit {
    let mut mapping = vec![0usize; n];
    let mut best = Fit {
        mapping: mapping.clone(),
        cost: f64::INFINITY,
    };
    loop {
        let c = mapping_cost(triangles, &mapping, &cost);
        if c < best.cost {
            best = Fit {
                mapping: mapping.clone(),
                cost: c,
            };
        }
        // Next mapping in odometer order.
        let mut i = 0;
        loop {
            if i == n {
                return best;
            }
            mapping[i] += 1;
            if mapping[i] < m {
                break;
            }
            mapping[i] = 0;
            i += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::triangulate::triangulate;

    fn hash_cost(seed: u64) -> impl Fn(usize, [usize; 3]) -> f64 {
        move |t, p| {
            let mut h = seed ^ (t as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            for x in p {
                h = (h ^ x as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                h ^= h >> 31;
            }
            (h % 1000) as f64 / 10.0
        }
    }

    fn polygon(n: usize, seed: u32) -> Vec<[f32; 2]> {
        (0..n)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / n as f32;
                let r = 5.0 + ((i as u32 * 7 + seed) % 5) as f32;
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    }

    #[test]
    fn dynamic_program_equals_brute_force_on_small_cases() {
        for n in 3..=6 {
            for m in 1..=5 {
                for seed in 0..4u32 {
                    let poly = polygon(n, seed);
                    let tris = triangulate(&poly).unwrap();
                    let cost = hash_cost(seed as u64 * 31 + n as u64 * 7 + m as u64);
                    let dp = Plan::new(n, &tris).unwrap().solve(m, &cost).unwrap();
                    let bf = brute_force(n, &tris, m, &cost);
                    assert!(
                        (dp.cost - bf.cost).abs() < 1e-9,
                        "n {n} m {m} seed {seed}: dp {} bf {}",
                        dp.cost,
                        bf.cost
                    );
                    // The returned mapping really has the returned cost.
                    assert!((mapping_cost(&tris, &dp.mapping, &cost) - dp.cost).abs() < 1e-9);
                    // A cost that gives up above its limit (returning some larger value)
                    // leaves the optimum unchanged.
                    let all = vec![(0..m).collect::<Vec<_>>(); n];
                    let bounded = Plan::new(n, &tris)
                        .unwrap()
                        .solve_bounded(&all, |t, p, limit| {
                            let c = cost(t, p);
                            if c >= limit { limit + 7.0 } else { c }
                        })
                        .unwrap();
                    assert!(
                        (bounded.cost - bf.cost).abs() < 1e-9,
                        "bounded {} bf {}",
                        bounded.cost,
                        bf.cost
                    );
                    assert!((mapping_cost(&tris, &bounded.mapping, &cost) - bf.cost).abs() < 1e-9);
                }
            }
        }
    }

    #[test]
    fn geometric_cost_recovers_a_known_correspondence() {
        // A cost that is zero only for one known correspondence (source vertex i to target
        // vertex i·m/n + 3): the fit must find it exactly.
        let n = 8;
        let src = polygon(n, 1);
        let m = 12;
        let want: Vec<usize> = (0..n).map(|i| (i * m / n + 3) % m).collect();
        let tris = triangulate(&src).unwrap();
        let cost = |t: usize, p: [usize; 3]| {
            tris[t]
                .iter()
                .zip(p)
                .map(|(&v, pj)| if want[v] == pj { 0.0 } else { 1.0 })
                .sum::<f64>()
        };
        let fit = Plan::new(n, &tris).unwrap().solve(m, cost).unwrap();
        assert_eq!(fit.mapping, want);
        assert_eq!(fit.cost, 0.0);
    }

    #[test]
    fn result_does_not_depend_on_vertex_numbering_start() {
        // Relabel the source polygon cyclically: the optimal cost is unchanged.
        let n = 6;
        let m = 4;
        let poly = polygon(n, 2);
        let tris = triangulate(&poly).unwrap();
        let base_cost = |t_tri: [usize; 3], p: [usize; 3]| -> f64 {
            // Cost defined on geometry (vertex ids), not triangle order.
            let mut s = 0.0;
            for k in 0..3 {
                s += ((t_tri[k] * 3 + p[k] * 5) % 7) as f64;
            }
            s
        };
        let a = Plan::new(n, &tris)
            .unwrap()
            .solve(m, |t, p| base_cost(tris[t], p))
            .unwrap();
        let shift = 2;
        let rel: Vec<[usize; 3]> = tris.iter().map(|t| t.map(|v| (v + shift) % n)).collect();
        let b = Plan::new(n, &rel)
            .unwrap()
            .solve(m, |t, p| base_cost(rel[t].map(|v| (v + n - shift) % n), p))
            .unwrap();
        assert!((a.cost - b.cost).abs() < 1e-9);
    }

    #[test]
    fn candidate_restriction_equals_brute_force_over_the_same_choices() {
        for seed in 0..6u64 {
            let n = 6;
            let m = 5;
            let poly = polygon(n, seed as u32);
            let tris = triangulate(&poly).unwrap();
            let cost = hash_cost(seed * 13 + 5);
            // Each vertex may take 2 or 3 of the targets; vertex 0 is pinned.
            let cands: Vec<Vec<usize>> = (0..n)
                .map(|i| {
                    if i == 0 {
                        vec![3]
                    } else {
                        (0..m).filter(|j| (i + j + seed as usize) % 3 != 0).collect()
                    }
                })
                .collect();
            let dp = Plan::new(n, &tris).unwrap().solve_candidates(&cands, &cost).unwrap();
            let bf = brute_force(n, &tris, m, |t, p| {
                let ok = tris[t].iter().zip(p).all(|(&v, pj)| cands[v].contains(&pj));
                if ok { cost(t, p) } else { 1e12 }
            });
            assert!(
                (dp.cost - bf.cost).abs() < 1e-9,
                "seed {seed}: {} vs {}",
                dp.cost,
                bf.cost
            );
            assert_eq!(dp.mapping[0], 3);
            assert!(dp.mapping.iter().enumerate().all(|(i, p)| cands[i].contains(p)));
        }
    }

    #[test]
    fn searching_below_a_bound_finds_the_optimum_only_when_it_is_below() {
        for seed in 0..6u64 {
            let (n, m) = (7, 4);
            let tris = triangulate(&polygon(n, seed as u32)).unwrap();
            let cost = hash_cost(seed * 7 + 1);
            let bf = brute_force(n, &tris, m, &cost);
            let plan = Plan::new(n, &tris).unwrap();
            let all = vec![(0..m).collect::<Vec<_>>(); n];
            // A cost that gives up above its limit, as the image cost does.
            let bounded = |t: usize, p: [usize; 3], limit: f64| {
                let c = cost(t, p);
                if c < limit { c } else { limit + 1.0 }
            };
            let above = plan.solve_below(&all, bounded, bf.cost * 1.5 + 1.0).unwrap().unwrap();
            assert!((above.cost - bf.cost).abs() < 1e-9, "seed {seed}");
            assert!((mapping_cost(&tris, &above.mapping, &cost) - bf.cost).abs() < 1e-9);
            // Just below the optimum nothing is cheaper (the DP and the brute force sum in
            // different orders, so not exactly at it).
            assert!(
                plan.solve_below(&all, bounded, bf.cost - 1e-9).unwrap().is_none(),
                "seed {seed}"
            );
            assert!(plan.solve_below(&all, bounded, bf.cost * 0.5).unwrap().is_none());
        }
    }

    #[test]
    fn rejects_invalid_input() {
        assert!(matches!(Plan::new(3, &[]), Err(FitError::NoTriangles)));
        assert!(matches!(Plan::new(3, &[[0, 1, 5]]), Err(FitError::BadVertex(0))));
        let plan = Plan::new(3, &[[0, 1, 2]]).unwrap();
        assert!(matches!(plan.solve(0, |_, _| 0.0), Err(FitError::EmptyTarget)));
        // Two triangles that share no edge are not a tree.
        assert!(Plan::new(6, &[[0, 1, 2], [3, 4, 5]]).is_err());
    }
}
