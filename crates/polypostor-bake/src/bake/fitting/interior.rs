//! Interior vertices of a fitted part's polygon.
//!
//! A polygon with vertices on its outline alone warps its key image by the affine map of each
//! triangle of the outline's triangulation: the image inside can only follow the outline. A
//! head that turns in place keeps nearly the same outline while its face slides across it,
//! and a limb that bends keeps its texture stretched along the chords of the triangulation.
//! Here the polygon gets a few vertices inside: each added at the centroid of the largest
//! triangle (in the key image), the mesh then made Delaunay in the key image by edge flips
//! that keep every frame's drawing fold-free. At every frame an interior vertex starts where
//! the outline's warp puts it (the drawing is exactly the outline-only polygon's), and is then
//! moved, in steps of a few pixels down to a quarter, wherever that lowers the drawn error
//! against the frame's render ([`crate::bake::subpixel`]) without turning a triangle over.

/// Twice the signed area of `a b c`.
pub fn area2(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// `d` strictly inside the circumcircle of the counter-clockwise (in the sense `sign`)
/// triangle `a b c`.
fn in_circle(a: [f32; 2], b: [f32; 2], c: [f32; 2], d: [f32; 2], sign: f32) -> bool {
    let (ax, ay) = ((a[0] - d[0]) as f64, (a[1] - d[1]) as f64);
    let (bx, by) = ((b[0] - d[0]) as f64, (b[1] - d[1]) as f64);
    let (cx, cy) = ((c[0] - d[0]) as f64, (c[1] - d[1]) as f64);
    let det = (ax * ax + ay * ay) * (bx * cy - cx * by) - (bx * bx + by * by) * (ax * cy - cx * ay)
        + (cx * cx + cy * cy) * (ax * by - bx * ay);
    det * sign as f64 > 1e-9
}

/// A polygon's mesh with interior vertices, at the key image and at every frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Interior {
    /// The added vertices in the key image (pixels of the key tile), numbered after the
    /// outline's.
    pub uvs: Vec<[f32; 2]>,
    /// Triangles over the outline's vertices then the added ones.
    pub triangles: Vec<[usize; 3]>,
    /// Per frame, the added vertices' positions where the outline's warp puts them (empty for
    /// a frame given none).
    pub positions: Vec<Vec<[f32; 2]>>,
}

/// Adds up to `most` interior vertices to the polygon `outline` (vertices in the key image,
/// triangulated by `triangles` with the polygon's orientation), each in a triangle of at least
/// `min_area` pixels. `frames[f]`: the outline's positions at frame `f` (`None` for a frame
/// not drawn). The added vertices' positions at each frame are where the outline-only
/// polygon's piecewise affine warp puts them. Without `flip` each added vertex splits the
/// triangle it is in, so the drawing is exactly the outline-only polygon's; with it, the mesh
/// is made Delaunay in the key image after each split by edge flips that keep every frame's
/// triangles turned the polygon's way (or flat), which changes the drawing a little.
pub fn add_interior(
    outline: &[[f32; 2]],
    triangles: &[[usize; 3]],
    frames: &[Option<Vec<[f32; 2]>>],
    most: usize,
    min_area: f32,
    flip: bool,
) -> Interior {
    let n = outline.len();
    let mut uv: Vec<[f32; 2]> = outline.to_vec();
    let mut pos: Vec<Option<Vec<[f32; 2]>>> = frames.to_vec();
    let mut tris: Vec<[usize; 3]> = triangles.to_vec();
    let sign = tris
        .iter()
        .map(|t| area2(uv[t[0]], uv[t[1]], uv[t[2]]))
        .sum::<f32>()
        .signum();
    let turned_right = |p: &[[f32; 2]], t: [usize; 3]| area2(p[t[0]], p[t[1]], p[t[2]]) * sign >= 0.0;
    for _ in 0..most {
        // The largest triangle whose split keeps every frame's drawing fold-free.
        let mut order: Vec<(usize, f32)> = tris
            .iter()
            .enumerate()
            .map(|(k, t)| (k, (area2(uv[t[0]], uv[t[1]], uv[t[2]]) * sign).max(0.0) / 2.0))
            .filter(|&(_, area)| area >= min_area)
            .collect();
        order.sort_by(|a, b| b.1.total_cmp(&a.1));
        let v = uv.len();
        let split = order.into_iter().find_map(|(k, _)| {
            let [a, b, c] = tris[k];
            let q = [
                (uv[a][0] + uv[b][0] + uv[c][0]) / 3.0,
                (uv[a][1] + uv[b][1] + uv[c][1]) / 3.0,
            ];
            let at: Vec<Option<[f32; 2]>> = pos
                .iter()
                .map(|p| p.as_ref().map(|p| warp(outline, triangles, &p[..n], q)))
                .collect();
            let fold_free = pos.iter().zip(&at).all(|(p, w)| match (p, w) {
                (Some(p), Some(w)) => {
                    let mut p = p.clone();
                    p.push(*w);
                    [[a, b, v], [b, c, v], [c, a, v]]
                        .into_iter()
                        .all(|t| turned_right(&p, t))
                }
                _ => true,
            });
            fold_free.then_some((k, q, at))
        });
        let Some((k, q, at)) = split else {
            break;
        };
        let [a, b, c] = tris[k];
        uv.push(q);
        for (p, w) in pos.iter_mut().zip(at) {
            if let (Some(p), Some(w)) = (p, w) {
                p.push(w);
            }
        }
        tris[k] = [a, b, v];
        tris.push([b, c, v]);
        tris.push([c, a, v]);
        if flip {
            flip_to_delaunay(&uv, &pos, &mut tris, n, sign);
        }
    }
    Interior {
        uvs: uv[n..].to_vec(),
        triangles: tris,
        positions: pos
            .into_iter()
            .map(|p| p.map_or(Vec::new(), |p| p[n..].to_vec()))
            .collect(),
    }
}

/// Where the outline-only polygon's warp puts the key-image point `q`: the affine map of the
/// triangle of `triangles` (over `outline`, the key image) holding it onto the same triangle
/// at `frame` (the outline's positions there). A point in no triangle (on an edge, within
/// rounding) takes the nearest triangle's map.
fn warp(outline: &[[f32; 2]], triangles: &[[usize; 3]], frame: &[[f32; 2]], q: [f32; 2]) -> [f32; 2] {
    let weights = |t: &[usize; 3]| {
        let (a, b, c) = (outline[t[0]], outline[t[1]], outline[t[2]]);
        let whole = area2(a, b, c);
        if whole.abs() < 1e-12 {
            return None;
        }
        Some([area2(b, c, q) / whole, area2(c, a, q) / whole, area2(a, b, q) / whole])
    };
    let best = triangles
        .iter()
        .filter_map(|t| weights(t).map(|w| (t, w)))
        .max_by(|x, y| {
            let m = |w: [f32; 3]| w[0].min(w[1]).min(w[2]);
            m(x.1).total_cmp(&m(y.1))
        });
    match best {
        Some((t, w)) => [0, 1].map(|c| (0..3).map(|i| w[i] * frame[t[i]][c]).sum()),
        None => q,
    }
}

/// Flips interior edges whose opposite vertex lies inside the other triangle's circumcircle
/// (in the key image) where both new triangles keep the polygon's orientation in the key image
/// and at every frame. Edges of the outline (`i`, `i + 1` for `i < n`) never flip.
fn flip_to_delaunay(uv: &[[f32; 2]], pos: &[Option<Vec<[f32; 2]>>], tris: &mut [[usize; 3]], n: usize, sign: f32) {
    let outline_edge = |a: usize, b: usize| a < n && b < n && ((a + 1) % n == b || (b + 1) % n == a);
    let turned = |p: &[[f32; 2]], t: [usize; 3], strict: bool| {
        let s = area2(p[t[0]], p[t[1]], p[t[2]]) * sign;
        if strict { s > 1e-6 } else { s >= 0.0 }
    };
    // Bounded: each flip makes the mesh more Delaunay, but floats can cycle.
    for _ in 0..4 * tris.len() {
        let mut flipped = false;
        // Each directed edge's triangle and the vertex opposite it.
        let mut across = std::collections::HashMap::with_capacity(3 * tris.len());
        for (j, t) in tris.iter().enumerate() {
            for f in 0..3 {
                across.insert((t[f], t[(f + 1) % 3]), (j, t[(f + 2) % 3]));
            }
        }
        'search: for i in 0..tris.len() {
            for e in 0..3 {
                let (a, b) = (tris[i][e], tris[i][(e + 1) % 3]);
                if outline_edge(a, b) {
                    continue;
                }
                let c = tris[i][(e + 2) % 3];
                // The triangle across a→b runs b→a.
                let Some(&(j, d)) = across.get(&(b, a)) else {
                    continue;
                };
                if !in_circle(uv[a], uv[b], uv[c], uv[d], sign) {
                    continue;
                }
                let (t1, t2) = ([c, a, d], [d, b, c]);
                if !turned(uv, t1, true) || !turned(uv, t2, true) {
                    continue;
                }
                if pos
                    .iter()
                    .flatten()
                    .any(|p| !turned(p, t1, false) || !turned(p, t2, false))
                {
                    continue;
                }
                tris[i] = t1;
                tris[j] = t2;
                flipped = true;
                break 'search;
            }
        }
        if !flipped {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::triangulate::triangulate;

    fn area(p: &[[f32; 2]], t: &[[usize; 3]]) -> f32 {
        t.iter().map(|t| area2(p[t[0]], p[t[1]], p[t[2]]) / 2.0).sum()
    }

    fn polygon() -> Vec<[f32; 2]> {
        // An L-shaped outline, counter-clockwise.
        vec![
            [0.0, 0.0],
            [20.0, 0.0],
            [20.0, 6.0],
            [6.0, 6.0],
            [6.0, 24.0],
            [0.0, 24.0],
        ]
    }

    /// The mesh with interior vertices covers the polygon exactly once (the same area, every
    /// triangle turned the polygon's way) in the key image and at every frame, and its
    /// added vertices lie where the outline's warp puts them: the affine map of a triangle of
    /// the outline-only mesh.
    #[test]
    fn interior_vertices_cover_the_polygon_once_and_follow_the_outline_warp() {
        let key = polygon();
        let tris = triangulate(&key).unwrap();
        // A frame: the polygon sheared and scaled (an affine map), another: bent at a vertex.
        let sheared: Vec<[f32; 2]> = key
            .iter()
            .map(|p| [1.5 * p[0] + 0.3 * p[1] + 2.0, 0.8 * p[1] - 1.0])
            .collect();
        let mut bent = key.clone();
        bent[2] = [22.0, 9.0];
        let frames = vec![Some(sheared.clone()), None, Some(bent.clone())];
        for flip in [false, true] {
            let mesh = add_interior(&key, &tris, &frames, 5, 4.0, flip);
            assert_eq!(mesh.uvs.len(), 5);
            assert_eq!(mesh.triangles.len(), key.len() - 2 + 2 * mesh.uvs.len());
            let all_uv: Vec<[f32; 2]> = key.iter().chain(&mesh.uvs).copied().collect();
            assert!((area(&all_uv, &mesh.triangles) - area(&key, &tris)).abs() < 1e-3);
            for t in &mesh.triangles {
                assert!(area2(all_uv[t[0]], all_uv[t[1]], all_uv[t[2]]) > 0.0, "{t:?}");
            }
            // Every vertex inside is used, every edge of the outline is a triangle's edge.
            for v in 0..all_uv.len() {
                assert!(mesh.triangles.iter().any(|t| t.contains(&v)), "vertex {v} unused");
            }
            assert!(mesh.positions[1].is_empty());
            for (f, outline) in [(0, &sheared), (2, &bent)] {
                let all: Vec<[f32; 2]> = outline.iter().chain(&mesh.positions[f]).copied().collect();
                assert!(
                    (area(&all, &mesh.triangles) - area(outline, &tris)).abs() < 1e-2,
                    "frame {f}"
                );
                for t in &mesh.triangles {
                    assert!(
                        area2(all[t[0]], all[t[1]], all[t[2]]) >= 0.0,
                        "frame {f}: {t:?} turned over"
                    );
                }
                // Each added vertex: the affine map of the outline triangle holding it.
                for (k, q) in mesh.uvs.iter().enumerate() {
                    let t = tris
                        .iter()
                        .find(|t| {
                            let (a, b, c) = (key[t[0]], key[t[1]], key[t[2]]);
                            area2(a, b, *q) >= -1e-4 && area2(b, c, *q) >= -1e-4 && area2(c, a, *q) >= -1e-4
                        })
                        .expect("inside the polygon");
                    let whole = area2(key[t[0]], key[t[1]], key[t[2]]);
                    let w = [
                        area2(key[t[1]], key[t[2]], *q) / whole,
                        area2(key[t[2]], key[t[0]], *q) / whole,
                        area2(key[t[0]], key[t[1]], *q) / whole,
                    ];
                    let want = [0, 1].map(|c| (0..3).map(|i| w[i] * outline[t[i]][c]).sum::<f32>());
                    let got = mesh.positions[f][k];
                    assert!(
                        (got[0] - want[0]).abs() < 1e-3 && (got[1] - want[1]).abs() < 1e-3,
                        "frame {f} vertex {k}: {got:?} against {want:?}"
                    );
                }
            }

            if !flip {
                // Split only: every triangle lies inside one of the outline-only mesh's, so
                // the drawing is exactly its drawing.
                let inside = |q: [f32; 2], t: &[usize; 3]| {
                    let (a, b, c) = (key[t[0]], key[t[1]], key[t[2]]);
                    area2(a, b, q) >= -1e-4 && area2(b, c, q) >= -1e-4 && area2(c, a, q) >= -1e-4
                };
                for t in &mesh.triangles {
                    assert!(tris.iter().any(|o| t.iter().all(|&i| inside(all_uv[i], o))), "{t:?}");
                }
            }
        }
    }

    /// No triangle smaller than the limit is split, and a polygon with none adds nothing.
    #[test]
    fn small_triangles_get_no_interior_vertex() {
        let key = polygon();
        let tris = triangulate(&key).unwrap();
        let largest = tris
            .iter()
            .map(|t| area2(key[t[0]], key[t[1]], key[t[2]]) / 2.0)
            .fold(0.0f32, f32::max);
        let mesh = add_interior(&key, &tris, &[Some(key.clone())], 8, largest + 1.0, true);
        assert!(mesh.uvs.is_empty());
        assert_eq!(mesh.triangles, tris);
        assert_eq!(mesh.positions, vec![Vec::<[f32; 2]>::new()]);
    }
}
