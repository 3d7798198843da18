//! Triangulation of a simple polygon without interior vertices: a constrained Delaunay
//! triangulation (spade) of the polygon's vertices and edges, keeping the triangles inside.
//! A simple polygon of `n` vertices always gives `n - 2` triangles.

use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation as _};

/// Why a polygon could not be triangulated. Vertex and edge numbers are positions in the
/// input (edge `i` runs from vertex `i` to vertex `i + 1`, wrapping).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TriangulateError {
    /// Fewer than three vertices (how many were given).
    #[error("a polygon needs at least 3 vertices, got {0}")]
    TooFewVertices(usize),
    /// A vertex is NaN or infinite, or outside the range the triangulation accepts (its number).
    #[error("polygon vertex {0} is not a finite point")]
    NotFinite(usize),
    /// Two vertices are the same point (the earlier number, then the later).
    #[error("polygon vertices {0} and {1} coincide")]
    DuplicateVertex(usize, usize),
    /// Edges cross, or an edge runs through a vertex: the first edge found crossing (0 when
    /// the crossing shows only once every edge is in).
    #[error("the polygon is not simple (edge {0} crosses another edge)")]
    NotSimple(usize),
    /// The triangles kept inside the polygon are not `n - 2` (a nearly degenerate polygon).
    #[error("triangulation gave {got} triangles instead of {want}")]
    WrongCount {
        /// Triangles kept.
        got: usize,
        /// Triangles a simple polygon of this many vertices has (`n - 2`).
        want: usize,
    },
}

fn area2(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Even-odd point-in-polygon test.
fn inside(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut c = false;
    let n = poly.len();
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0] {
            c = !c;
        }
        j = i;
    }
    c
}

/// Vertices of a part's outline: those on an edge of one triangle only, when they are the
/// block's first `m` vertices (the bake's order: outline, then interior vertices); else all
/// `vc` (a block the run time cannot read so, thinned as before). What the Polypostor
/// renderer thins ([`thinned`]) and the bake's atlas keeps texels for.
pub fn outline_len(indices: &[u16], vc: usize) -> usize {
    let mut edges: std::collections::HashMap<(u16, u16), u32> = std::collections::HashMap::new();
    for t in indices.chunks_exact(3) {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut on = vec![false; vc];
    for (&(a, b), &n) in &edges {
        if n == 1 {
            for v in [a, b] {
                if let Some(o) = on.get_mut(usize::from(v)) {
                    *o = true;
                }
            }
        }
    }
    let m = on.iter().take_while(|&&o| o).count();
    if m >= 3 && on[m..].iter().all(|&o| !o) { m } else { vc }
}

/// The crowd's thinned level of a polygon outline: triangles over every `step`-th vertex
/// (indices into `outline`), `None` when the outline has fewer than `4 · step` vertices or the
/// thinned polygon is not simple. What the Polypostor renderer draws for characters small on
/// screen, and what the bake's atlas keeps texels for (`pack::atlas` in the studio).
pub fn thinned(outline: &[[f32; 2]], step: usize) -> Option<Vec<[usize; 3]>> {
    let step = step.max(1);
    if outline.len() < 4 * step {
        return None;
    }
    let keep: Vec<usize> = (0..outline.len()).step_by(step).collect();
    let points: Vec<[f32; 2]> = keep.iter().map(|&k| outline[k]).collect();
    let tris = triangulate(&points).ok()?;
    Some(tris.iter().map(|t| t.map(|i| keep[i])).collect())
}

/// Triangles `[a, b, c]` (polygon vertex indices) covering the polygon, each with the same
/// orientation as the polygon's vertex order.
pub fn triangulate(points: &[[f32; 2]]) -> Result<Vec<[usize; 3]>, TriangulateError> {
    let n = points.len();
    if n < 3 {
        return Err(TriangulateError::TooFewVertices(n));
    }
    let p: Vec<[f64; 2]> = points.iter().map(|q| [q[0] as f64, q[1] as f64]).collect();
    if let Some(i) = p.iter().position(|q| !q[0].is_finite() || !q[1].is_finite()) {
        return Err(TriangulateError::NotFinite(i));
    }
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
    let mut handles = Vec::with_capacity(n);
    let mut index_of = std::collections::HashMap::new();
    for (i, q) in p.iter().enumerate() {
        let h = cdt
            .insert(Point2::new(q[0], q[1]))
            .map_err(|_| TriangulateError::NotFinite(i))?;
        if let Some(&j) = index_of.get(&h) {
            return Err(TriangulateError::DuplicateVertex(j, i));
        }
        index_of.insert(h, i);
        handles.push(h);
    }
    for i in 0..n {
        let (a, b) = (handles[i], handles[(i + 1) % n]);
        if !cdt.can_add_constraint(a, b) {
            return Err(TriangulateError::NotSimple(i));
        }
        cdt.add_constraint(a, b);
    }
    // A constraint through another vertex is split by spade: then the polygon is not simple.
    if cdt.num_constraints() != n {
        return Err(TriangulateError::NotSimple(0));
    }
    let polygon_sign = (0..n)
        .map(|i| area2([0.0, 0.0], p[i], p[(i + 1) % n]))
        .sum::<f64>()
        .signum();
    let mut tris = Vec::with_capacity(n - 2);
    for face in cdt.inner_faces() {
        let v = face.vertices().map(|h| index_of[&h.fix()]);
        let c = [
            (p[v[0]][0] + p[v[1]][0] + p[v[2]][0]) / 3.0,
            (p[v[0]][1] + p[v[1]][1] + p[v[2]][1]) / 3.0,
        ];
        if !inside(&p, c) {
            continue;
        }
        let t = if area2(p[v[0]], p[v[1]], p[v[2]]).signum() == polygon_sign {
            v
        } else {
            [v[0], v[2], v[1]]
        };
        tris.push(t);
    }
    if tris.len() != n - 2 {
        return Err(TriangulateError::WrongCount {
            got: tris.len(),
            want: n - 2,
        });
    }
    tris.sort();
    Ok(tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[[f32; 2]], t: [usize; 3]) -> f64 {
        let p = |i: usize| [points[i][0] as f64, points[i][1] as f64];
        area2(p(t[0]), p(t[1]), p(t[2])) / 2.0
    }

    fn polygon_area(points: &[[f32; 2]]) -> f64 {
        let n = points.len();
        (0..n)
            .map(|i| {
                (points[i][0] as f64 * points[(i + 1) % n][1] as f64
                    - points[(i + 1) % n][0] as f64 * points[i][1] as f64)
                    / 2.0
            })
            .sum()
    }

    fn star(n: usize, phase: f32) -> Vec<[f32; 2]> {
        (0..n)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / n as f32 + phase;
                let r = if i % 2 == 0 { 10.0 } else { 4.0 + (i % 3) as f32 };
                [r * a.cos(), r * a.sin()]
            })
            .collect()
    }

    #[test]
    fn triangles_tile_the_polygon_with_its_orientation() {
        for n in [3usize, 4, 8, 20, 40, 50] {
            for reverse in [false, true] {
                let mut poly = star(n, 0.3);
                if reverse {
                    poly.reverse();
                }
                let t = triangulate(&poly).unwrap();
                assert_eq!(t.len(), n - 2);
                let total: f64 = t.iter().map(|&t| area(&poly, t)).sum();
                assert!(
                    (total - polygon_area(&poly)).abs() < 1e-6 * polygon_area(&poly).abs().max(1.0),
                    "n {n}"
                );
                let sign = polygon_area(&poly).signum();
                assert!(t.iter().all(|&t| area(&poly, t).signum() == sign));
                // Every polygon edge belongs to exactly one triangle; every diagonal to two.
                let mut edges = std::collections::HashMap::new();
                for tri in &t {
                    for k in 0..3 {
                        let (a, b) = (tri[k], tri[(k + 1) % 3]);
                        *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                    }
                }
                for i in 0..n {
                    let (a, b) = (i, (i + 1) % n);
                    assert_eq!(edges[&(a.min(b), a.max(b))], 1);
                }
                assert!(edges.values().all(|&c| c == 1 || c == 2));
            }
        }
    }

    #[test]
    fn rejects_bad_polygons() {
        assert!(matches!(
            triangulate(&[[0.0, 0.0], [1.0, 0.0]]),
            Err(TriangulateError::TooFewVertices(2))
        ));
        let bowtie = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(matches!(triangulate(&bowtie), Err(TriangulateError::NotSimple(_))));
        let dup = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(matches!(
            triangulate(&dup),
            Err(TriangulateError::DuplicateVertex(1, 2))
        ));
        assert!(matches!(
            triangulate(&[[0.0, 0.0], [f32::NAN, 0.0], [0.0, 1.0]]),
            Err(TriangulateError::NotFinite(1))
        ));
    }

    #[test]
    fn invariant_under_translation_and_rotation() {
        // Irregular radii: no four points on a circle, so the Delaunay triangulation is unique.
        let poly: Vec<[f32; 2]> = star(24, 0.1)
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let k = 1.0 + 0.013 * ((i * 37 % 11) as f32);
                [p[0] * k, p[1] * k]
            })
            .collect();
        let base = triangulate(&poly).unwrap();
        let moved: Vec<[f32; 2]> = poly.iter().map(|p| [p[0] + 100.0, p[1] - 50.0]).collect();
        assert_eq!(triangulate(&moved).unwrap(), base);
        // A quarter turn (exact in floating point) keeps the same Delaunay triangles.
        let turned: Vec<[f32; 2]> = poly.iter().map(|p| [-p[1], p[0]]).collect();
        assert_eq!(triangulate(&turned).unwrap(), base);
    }
}
