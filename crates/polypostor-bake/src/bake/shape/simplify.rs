//! Greedy polygon simplification: repeatedly drop the vertex closest to the chord that skips
//! it, with a penalty on edges much longer than the target spacing so vertices stay evenly
//! spread (the paper's longest/shortest edge-ratio term), never creating self-intersections.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Options of [`simplify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimplifyOptions {
    /// Weight of the uniformity term. Default value: [`DEFAULT_UNIFORMITY`].
    pub uniformity: f64,
}

/// Default weight of the uniformity term.
pub const DEFAULT_UNIFORMITY: f64 = 0.5;

impl Default for SimplifyOptions {
    fn default() -> Self {
        Self {
            uniformity: DEFAULT_UNIFORMITY,
        }
    }
}

/// Distance from `p` to the segment `ab`.
pub(crate) fn dist_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((p[0] - a[0] - t * dx).powi(2) + (p[1] - a[1] - t * dy).powi(2)).sqrt()
}

fn len(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

/// Twice the signed area of triangle abc (positive counter-clockwise for y up).
pub(crate) fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// True if the closed segments ab and cd properly cross or touch.
fn segments_intersect(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (d1, d2, d3, d4) = (orient(c, d, a), orient(c, d, b), orient(a, b, c), orient(a, b, d));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return true;
    }
    let on = |p: [f64; 2], q: [f64; 2], r: [f64; 2], o: f64| {
        o == 0.0 && r[0] >= p[0].min(q[0]) && r[0] <= p[0].max(q[0]) && r[1] >= p[1].min(q[1]) && r[1] <= p[1].max(q[1])
    };
    on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4)
}

#[derive(PartialEq)]
struct Entry {
    cost: f64,
    vertex: usize,
    stamp: u32,
}
impl Eq for Entry {}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on cost; ties by vertex index for determinism.
        other.cost.total_cmp(&self.cost).then(other.vertex.cmp(&self.vertex))
    }
}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Simplifies a closed polygon to `target` vertices (at least 3), returning the indices of
/// the kept vertices in their original order. Never returns a self-intersecting polygon
/// when the input is simple; stops early if no vertex can be removed safely.
pub fn simplify(points: &[[f32; 2]], target: usize, options: &SimplifyOptions) -> Vec<usize> {
    let n = points.len();
    let target = target.max(3);
    if n <= target {
        return (0..n).collect();
    }
    let p: Vec<[f64; 2]> = points.iter().map(|q| [q[0] as f64, q[1] as f64]).collect();
    let perimeter: f64 = (0..n).map(|i| len(p[i], p[(i + 1) % n])).sum();
    let spacing = (perimeter / target as f64).max(1e-9);
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut alive = vec![true; n];
    let mut stamp = vec![0u32; n];
    let cost = |i: usize, prev: &[usize], next: &[usize]| {
        let (a, b) = (p[prev[i]], p[next[i]]);
        let d = dist_to_segment(p[i], a, b);
        let over = (len(a, b) / spacing - 1.0).max(0.0);
        d + options.uniformity * spacing * over * over
    };
    let mut heap = BinaryHeap::new();
    for i in 0..n {
        heap.push(Entry {
            cost: cost(i, &prev, &next),
            vertex: i,
            stamp: 0,
        });
    }
    let mut count = n;
    let mut blocked: Vec<usize> = Vec::new();
    while count > target {
        let Some(e) = heap.pop() else { break };
        let i = e.vertex;
        if !alive[i] || e.stamp != stamp[i] {
            continue;
        }
        // The new chord must not cross any other remaining edge.
        let (a, b) = (prev[i], next[i]);
        let mut crosses = false;
        let mut j = next[b];
        while j != a {
            let k = next[j];
            if k != a && segments_intersect(p[a], p[b], p[j], p[k]) {
                crosses = true;
                break;
            }
            j = k;
        }
        if crosses {
            blocked.push(i);
            continue;
        }
        alive[i] = false;
        next[a] = b;
        prev[b] = a;
        count -= 1;
        for v in [a, b].into_iter().chain(blocked.drain(..)) {
            if alive[v] {
                stamp[v] += 1;
                heap.push(Entry {
                    cost: cost(v, &prev, &next),
                    vertex: v,
                    stamp: stamp[v],
                });
            }
        }
    }
    (0..n).filter(|&i| alive[i]).collect()
}

/// True if the closed polygon has no two non-adjacent edges that intersect.
pub fn is_simple(points: &[[f32; 2]]) -> bool {
    let n = points.len();
    let p: Vec<[f64; 2]> = points.iter().map(|q| [q[0] as f64, q[1] as f64]).collect();
    for i in 0..n {
        for j in i + 1..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            if adjacent {
                continue;
            }
            if segments_intersect(p[i], p[(i + 1) % n], p[j], p[(j + 1) % n]) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::contour::{Mask, trace_outer};

    fn blob(seed: u32) -> Vec<[f32; 2]> {
        let mut s = seed;
        let mut rnd = || {
            s = s.wrapping_mul(1103515245).wrapping_add(12345);
            ((s >> 16) & 0x7fff) as f32 / 32768.0
        };
        let lobes: Vec<(f32, f32, f32)> = (0..4)
            .map(|_| (30.0 + rnd() * 60.0, 30.0 + rnd() * 60.0, 10.0 + rnd() * 20.0))
            .collect();
        let m = Mask::from_fn(128, 128, |x, y| {
            lobes
                .iter()
                .any(|l| ((x as f32 - l.0).powi(2) + (y as f32 - l.1).powi(2)).sqrt() < l.2)
        });
        trace_outer(&m)
    }

    #[test]
    fn reaches_the_target_keeps_order_and_stays_simple() {
        for seed in 1..15 {
            let c = blob(seed);
            for target in [50, 40, 20] {
                let kept = simplify(&c, target, &SimplifyOptions::default());
                assert!(
                    kept.len() <= target.max(3) + 2,
                    "seed {seed}: {} > {target}",
                    kept.len()
                );
                assert!(kept.windows(2).all(|w| w[0] < w[1]));
                let poly: Vec<[f32; 2]> = kept.iter().map(|&i| c[i]).collect();
                assert!(is_simple(&poly), "seed {seed} target {target}: self-intersecting");
            }
        }
    }

    #[test]
    fn square_keeps_its_corners() {
        let mut sq = Vec::new();
        for i in 0..10 {
            sq.push([i as f32, 0.0]);
        }
        for i in 0..10 {
            sq.push([10.0, i as f32]);
        }
        for i in 0..10 {
            sq.push([10.0 - i as f32, 10.0]);
        }
        for i in 0..10 {
            sq.push([0.0, 10.0 - i as f32]);
        }
        let kept = simplify(&sq, 4, &SimplifyOptions { uniformity: 0.0 });
        let pts: Vec<[f32; 2]> = kept.iter().map(|&i| sq[i]).collect();
        assert_eq!(pts, vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]]);
    }

    #[test]
    fn uniformity_spreads_vertices() {
        let c = blob(3);
        let ratio = |u: f64| {
            let kept = simplify(&c, 40, &SimplifyOptions { uniformity: u });
            let n = kept.len();
            let lens: Vec<f32> = (0..n)
                .map(|k| {
                    let (a, b) = (c[kept[k]], c[kept[(k + 1) % n]]);
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
                })
                .collect();
            lens.iter().cloned().fold(0.0, f32::max) / lens.iter().cloned().fold(f32::MAX, f32::min)
        };
        assert!(
            ratio(2.0) < ratio(0.0),
            "uniformity term does not even out edge lengths"
        );
    }

    #[test]
    fn translation_invariance() {
        let c = blob(5);
        let moved: Vec<[f32; 2]> = c.iter().map(|p| [p[0] + 64.0, p[1] - 32.0]).collect();
        assert_eq!(
            simplify(&c, 40, &Default::default()),
            simplify(&moved, 40, &Default::default())
        );
    }
}
