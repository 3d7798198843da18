//! Outer-contour tracing of a binary mask (Moore-neighbour tracing with Jacob's stopping
//! criterion). Only the outer boundary of the largest 8-connected component is traced, so
//! holes are filled by construction; [`bridge_pieces`] first joins a part's separate pieces
//! (a foot seen apart from its leg) with thin bridges so one polygon covers them all.
//!
//! Coordinates are pixel centres `(x + 0.5, y + 0.5)` in image space (x right, y down); the
//! contour runs clockwise on screen.

/// A binary image, row-major, `true` = covered.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    pub width: usize,
    pub height: usize,
    pub data: Vec<bool>,
}

impl Mask {
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            data: vec![false; width * height],
        }
    }

    /// From any per-pixel predicate.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> bool) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Self { width, height, data }
    }

    pub fn get(&self, x: i64, y: i64) -> bool {
        x >= 0
            && y >= 0
            && (x as usize) < self.width
            && (y as usize) < self.height
            && self.data[y as usize * self.width + x as usize]
    }

    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }
}

/// Clockwise (on screen) neighbour offsets starting west.
const DIRS: [(i64, i64); 8] = [(-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0), (1, 1), (0, 1), (-1, 1)];

/// Pixels of the largest 8-connected component (ties: the first in raster order), as a mask.
pub fn largest_component(mask: &Mask) -> Mask {
    let (label, sizes) = components(mask);
    let keep = (0..sizes.len()).max_by(|&a, &b| sizes[a].cmp(&sizes[b]).then(b.cmp(&a)));
    Mask {
        width: mask.width,
        height: mask.height,
        data: label.iter().map(|&l| Some(l as usize) == keep).collect(),
    }
}

/// Pieces smaller than this many pixels, or than 1/50 of the largest, are dropped by
/// [`bridge_pieces`] (stray pixels of anti-aliasing or a sliver behind another part).
pub const MIN_PIECE: usize = 8;

/// 8-connected component labels (`u32::MAX` = background) and their sizes.
fn components(mask: &Mask) -> (Vec<u32>, Vec<usize>) {
    let (w, h) = (mask.width, mask.height);
    let mut label = vec![u32::MAX; w * h];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !mask.data[start] || label[start] != u32::MAX {
            continue;
        }
        let id = sizes.len() as u32;
        let mut size = 0usize;
        label[start] = id;
        stack.push(start);
        while let Some(p) = stack.pop() {
            size += 1;
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for (dx, dy) in DIRS {
                let (nx, ny) = (x + dx, y + dy);
                if mask.get(nx, ny) {
                    let q = ny as usize * w + nx as usize;
                    if label[q] == u32::MAX {
                        label[q] = id;
                        stack.push(q);
                    }
                }
            }
        }
        sizes.push(size);
    }
    (label, sizes)
}

/// The mask with its pieces joined: every piece of at least [`MIN_PIECE`] pixels (and 1/50
/// of the largest) is connected to the largest by a three-pixel-wide bridge along a
/// shortest path (closest piece first); smaller specks are dropped. A mask with one piece
/// comes back unchanged.
pub fn bridge_pieces(mask: &Mask) -> Mask {
    let (label, sizes) = components(mask);
    let Some(largest) = (0..sizes.len()).max_by(|&a, &b| sizes[a].cmp(&sizes[b]).then(b.cmp(&a))) else {
        return mask.clone();
    };
    let min = MIN_PIECE.max(sizes[largest] / 50);
    let kept: Vec<bool> = sizes.iter().map(|&s| s >= min).collect();
    let (w, h) = (mask.width, mask.height);
    let mut out = Mask {
        width: w,
        height: h,
        data: label.iter().map(|&l| l == largest as u32).collect(),
    };
    let mut joined: Vec<bool> = (0..sizes.len()).map(|c| c == largest).collect();
    let mut parent = vec![usize::MAX; w * h];
    let mut queue = std::collections::VecDeque::new();
    while (0..sizes.len()).any(|c| kept[c] && !joined[c]) {
        // Breadth-first from everything joined so far, to the nearest unjoined piece.
        parent.fill(usize::MAX);
        queue.clear();
        for (i, &on) in out.data.iter().enumerate() {
            if on {
                parent[i] = i;
                queue.push_back(i);
            }
        }
        let mut hit = None;
        while let Some(p) = queue.pop_front() {
            let l = label[p];
            if l != u32::MAX && kept[l as usize] && !joined[l as usize] {
                hit = Some(p);
                break;
            }
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for (dx, dy) in DIRS {
                let (nx, ny) = (x + dx, y + dy);
                if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                    let q = ny as usize * w + nx as usize;
                    if parent[q] == usize::MAX {
                        parent[q] = p;
                        queue.push_back(q);
                    }
                }
            }
        }
        let Some(end) = hit else { break };
        let piece = label[end];
        joined[piece as usize] = true;
        for (i, &l) in label.iter().enumerate() {
            if l == piece {
                out.data[i] = true;
            }
        }
        // The bridge: the path back, widened by one pixel each way.
        let mut at = end;
        loop {
            let (x, y) = ((at % w) as i64, (at / w) as i64);
            for (dx, dy) in [(0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h {
                    out.data[ny as usize * w + nx as usize] = true;
                }
            }
            if parent[at] == at {
                break;
            }
            at = parent[at];
        }
    }
    out
}

/// The outer contour of the largest component, as pixel centres in tracing order (clockwise
/// on screen, starting at the top-left-most pixel). Empty for an empty mask; one point for a
/// single pixel.
pub fn trace_outer(mask: &Mask) -> Vec<[f32; 2]> {
    let comp = largest_component(mask);
    let Some(start) = comp.data.iter().position(|&b| b) else {
        return Vec::new();
    };
    let w = comp.width;
    let s = ((start % w) as i64, (start / w) as i64);
    // Entered from the west (raster order guarantees the west pixel is background).
    let start_dir = 0usize;
    let mut out = vec![s];
    let mut cur = s;
    let mut back = start_dir; // index in DIRS of the background pixel we came from
    let limit = 4 * comp.width * comp.height + 8;
    for _ in 0..limit {
        // Search clockwise from the backtrack direction for the next foreground pixel.
        let mut found = None;
        for k in 1..=8 {
            let d = (back + k) % 8;
            let (nx, ny) = (cur.0 + DIRS[d].0, cur.1 + DIRS[d].1);
            if comp.get(nx, ny) {
                found = Some((d, (nx, ny)));
                break;
            }
        }
        let Some((d, next)) = found else { break }; // isolated pixel
        // The new backtrack: the pixel checked just before `next`, seen from `next`.
        let prev_d = (d + 7) % 8;
        let prev = (cur.0 + DIRS[prev_d].0, cur.1 + DIRS[prev_d].1);
        let back_from_next = DIRS
            .iter()
            .position(|&(dx, dy)| (next.0 + dx, next.1 + dy) == prev)
            .unwrap_or((d + 4) % 8);
        // Jacob's criterion: back at the start, entered the same way as at first.
        if next == s && back_from_next == start_dir {
            break;
        }
        out.push(next);
        cur = next;
        back = back_from_next;
    }
    if out.len() > 1 && out.last() == Some(&s) {
        out.pop();
    }
    out.into_iter().map(|(x, y)| [x as f32 + 0.5, y as f32 + 0.5]).collect()
}

/// The outer contour with no point visited twice: where the plain trace passes a pixel twice
/// (a one-pixel-wide spur or neck, two pieces touching only at a corner), the mask is traced
/// at twice the resolution with its corner-only contacts filled in, so every feature is at
/// least two pixels wide and the outline is a simple polygon; coordinates stay in the
/// original pixel units.
pub fn trace_simple(mask: &Mask) -> Vec<[f32; 2]> {
    let contour = trace_outer(mask);
    let mut seen = std::collections::HashSet::with_capacity(contour.len());
    if contour.iter().all(|p| seen.insert((p[0].to_bits(), p[1].to_bits()))) {
        return contour;
    }
    let comp = largest_component(mask);
    let (w, h) = (2 * mask.width, 2 * mask.height);
    let mut fine = Mask::from_fn(w, h, |x, y| comp.data[(y / 2) * mask.width + x / 2]);
    // Fill corner-only contacts until none is left (each fill only adds pixels).
    let mut changed = true;
    while changed {
        changed = false;
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let (a, b, c, d) = (
                    fine.data[y * w + x],
                    fine.data[y * w + x + 1],
                    fine.data[(y + 1) * w + x],
                    fine.data[(y + 1) * w + x + 1],
                );
                if a && d && !b && !c {
                    fine.data[y * w + x + 1] = true;
                    changed = true;
                } else if b && c && !a && !d {
                    fine.data[y * w + x] = true;
                    changed = true;
                }
            }
        }
    }
    trace_outer(&fine)
        .into_iter()
        .map(|p| [(p[0] - 0.5) / 2.0 + 0.25, (p[1] - 0.5) / 2.0 + 0.25])
        .collect()
}

/// Twice the signed area (shoelace); positive for clockwise-on-screen (y down) order.
pub fn signed_area2(poly: &[[f32; 2]]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] as f64 * b[1] as f64 - b[0] as f64 * a[1] as f64
        })
        .sum()
}

/// A convex polygon of at most `max_vertices` vertices (at least 3) that holds every covered
/// pixel of `mask` whole, inside the mask's rectangle, clockwise on screen like the traced
/// contours; `None` when nothing is covered or no such polygon was found.
///
/// For a part whose every frame shows the key image itself (a prop at rest, a clip of one
/// frame), the alpha test, not the polygon, has to draw the outline: a polygon simplified
/// from the traced contour cuts the corners of the pixel staircase (one or two pixels missing
/// or added along every edge, the whole error of such a part), while this one leaves every
/// covered texel in and the alpha test trims the rest exactly.
///
/// The convex hull of the covered pixels' corners, then greedily (least added area first) two
/// neighbouring vertices replaced by the meeting point of the edges either side, which only
/// ever grows the polygon.
pub fn covering_polygon(mask: &Mask, max_vertices: usize) -> Option<Vec<[f32; 2]>> {
    let (w, h) = (mask.width, mask.height);
    let mut points: Vec<[f64; 2]> = Vec::new();
    for y in 0..h {
        let row = &mask.data[y * w..(y + 1) * w];
        let (Some(x0), Some(x1)) = (row.iter().position(|&b| b), row.iter().rposition(|&b| b)) else {
            continue;
        };
        for (x, yy) in [(x0, y), (x0, y + 1), (x1 + 1, y), (x1 + 1, y + 1)] {
            points.push([x as f64, yy as f64]);
        }
    }
    let mut hull = convex_hull(points);
    if hull.len() < 3 {
        return None;
    }
    use crate::bake::simplify::orient as cross;
    let (wf, hf) = (w as f64, h as f64);
    // Room for the four vertices that clipping to the tile can add (a part touching the
    // tile's edges grows past them on the way).
    let most = max_vertices.max(3);
    let budget = most.saturating_sub(4).max(3);
    while hull.len() > budget {
        let n = hull.len();
        if n < 4 {
            return None;
        }
        // Replacing vertices i and i + 1 by X, where the edges (i - 1, i) and (i + 1, i + 2)
        // carried on meet: the polygon gains the triangle (i, X, i + 1).
        let mut best: Option<(f64, usize, [f64; 2])> = None;
        for i in 0..n {
            let (p, a, b, q) = (hull[(i + n - 1) % n], hull[i], hull[(i + 1) % n], hull[(i + 2) % n]);
            let (d1, d2) = ([a[0] - p[0], a[1] - p[1]], [b[0] - q[0], b[1] - q[1]]);
            let den = d1[0] * d2[1] - d1[1] * d2[0];
            if den.abs() < 1e-12 {
                continue;
            }
            // a + t d1 = b + u d2
            let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
            let t = (ex * d2[1] - ey * d2[0]) / den;
            let u = (ex * d1[1] - ey * d1[0]) / den;
            if t < 0.0 || u < 0.0 {
                continue;
            }
            let x = [a[0] + t * d1[0], a[1] + t * d1[1]];
            let added = 0.5 * cross(a, x, b).abs();
            if best.is_none_or(|(c, _, _)| added < c) {
                best = Some((added, i, x));
            }
        }
        let (_, i, x) = best?;
        if i + 1 < n {
            hull[i] = x;
            hull.remove(i + 1);
        } else {
            // The pair wraps round: vertices n - 1 and 0.
            hull[0] = x;
            hull.pop();
        }
    }
    let hull = clip_to_rect(&hull, wf, hf);
    if hull.len() < 3 || hull.len() > most {
        return None;
    }
    let mut out: Vec<[f32; 2]> = hull.iter().map(|p| [p[0] as f32, p[1] as f32]).collect();
    if signed_area2(&out) < 0.0 {
        out.reverse();
    }
    Some(out)
}

/// Convex polygon `poly` cut to the rectangle `[0, w] × [0, h]` (Sutherland–Hodgman), with
/// repeated points left out.
fn clip_to_rect(poly: &[[f64; 2]], w: f64, h: f64) -> Vec<[f64; 2]> {
    let mut out = poly.to_vec();
    // Each side as (axis, limit, keep below the limit?).
    for (axis, limit, below) in [(0, 0.0, false), (0, w, true), (1, 0.0, false), (1, h, true)] {
        let inside = |p: &[f64; 2]| if below { p[axis] <= limit } else { p[axis] >= limit };
        let input = std::mem::take(&mut out);
        let n = input.len();
        for i in 0..n {
            let (a, b) = (input[i], input[(i + 1) % n]);
            if inside(&a) {
                out.push(a);
            }
            if inside(&a) != inside(&b) {
                let t = (limit - a[axis]) / (b[axis] - a[axis]);
                let mut x = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                x[axis] = limit;
                out.push(x);
            }
        }
    }
    let mut clean: Vec<[f64; 2]> = Vec::with_capacity(out.len());
    for p in out {
        if clean
            .last()
            .is_none_or(|q| (q[0] - p[0]).abs() + (q[1] - p[1]).abs() > 1e-9)
        {
            clean.push(p);
        }
    }
    while clean.len() > 1 && {
        let (a, b) = (clean[0], clean[clean.len() - 1]);
        (a[0] - b[0]).abs() + (a[1] - b[1]).abs() <= 1e-9
    } {
        clean.pop();
    }
    clean
}

/// Convex hull of `points` (Andrew's monotone chain), collinear points left out; in the
/// order of increasing angle for y up (counter-clockwise), clockwise on screen.
fn convex_hull(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    use crate::bake::simplify::orient as cross;
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// `poly` (a simple polygon, either orientation) grown outwards by `d`: every vertex moves
/// along the bisector of its two edges' outward normals so that both edges move by `d`
/// (mitred, the move limited to `2 d` at sharp spikes).
///
/// Traced contours run through the centres of the boundary pixels, so a polygon drawn from
/// them leaves out the outer half of every boundary pixel: on a limb four pixels wide, a
/// quarter of its width. Grown by half a pixel, the polygon covers the pixels it was traced
/// from.
pub fn offset_outward(poly: &[[f32; 2]], d: f32) -> Vec<[f32; 2]> {
    let n = poly.len();
    if n < 3 || d == 0.0 {
        return poly.to_vec();
    }
    let sign = if signed_area2(poly) >= 0.0 { 1.0f32 } else { -1.0 };
    // Outward unit normal of edge i (from vertex i to i + 1).
    let normal = |i: usize| -> Option<[f32; 2]> {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = (dx * dx + dy * dy).sqrt();
        (len > 1e-6).then(|| [sign * dy / len, -sign * dx / len])
    };
    (0..n)
        .map(|i| {
            let p = poly[i];
            let (Some(n0), Some(n1)) = (normal((i + n - 1) % n), normal(i)) else {
                return p;
            };
            let (mx, my) = (n0[0] + n1[0], n0[1] + n1[1]);
            let len = (mx * mx + my * my).sqrt();
            let (ox, oy) = if len < 1e-3 {
                // A spike back on itself: push along the incoming edge's normal.
                (n0[0] * d, n0[1] * d)
            } else {
                let (ux, uy) = (mx / len, my / len);
                let cos = (ux * n1[0] + uy * n1[1]).max(0.5);
                (ux * d / cos, uy * d / cos)
            };
            [p[0] + ox, p[1] + oy]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    /// The covering polygon holds every corner of every covered pixel (brute force over
    /// random blobs, several islands, and one-pixel masks at the tile's edges), stays convex,
    /// inside the tile, clockwise on screen and within its vertex budget, and adds little:
    /// a square's is the square itself.
    #[test]
    fn the_covering_polygon_holds_every_covered_pixel() {
        let inside = |poly: &[[f32; 2]], p: [f32; 2]| {
            let n = poly.len();
            (0..n).all(|i| {
                let (a, b) = (poly[i], poly[(i + 1) % n]);
                // Clockwise on screen: every point inside is on the right of each edge.
                let c = (b[0] - a[0]) as f64 * (p[1] - a[1]) as f64 - (b[1] - a[1]) as f64 * (p[0] - a[0]) as f64;
                c >= -1e-3
            })
        };
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as f32 / (1u64 << 31) as f32
        };
        for case in 0..200 {
            let (w, h) = (8 + (rnd() * 60.0) as usize, 8 + (rnd() * 60.0) as usize);
            let blobs: Vec<[f32; 3]> = (0..1 + case % 4)
                .map(|_| [rnd() * w as f32, rnd() * h as f32, 1.0 + rnd() * 12.0])
                .collect();
            let m = Mask::from_fn(w, h, |x, y| {
                blobs.iter().any(|b| {
                    let (dx, dy) = (x as f32 + 0.5 - b[0], (y as f32 + 0.5 - b[1]) * 1.7);
                    dx * dx + dy * dy <= b[2] * b[2]
                })
            });
            let most = [8, 10, 16, 40][case % 4];
            let Some(poly) = covering_polygon(&m, most) else {
                assert!(m.data.iter().all(|&b| !b), "case {case}: no polygon for a covered mask");
                continue;
            };
            assert!(
                poly.len() >= 3 && poly.len() <= most,
                "case {case}: {} vertices",
                poly.len()
            );
            assert!(signed_area2(&poly) > 0.0, "case {case}: clockwise on screen");
            for i in 0..poly.len() {
                let (a, b, c) = (poly[i], poly[(i + 1) % poly.len()], poly[(i + 2) % poly.len()]);
                let turn = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
                assert!(turn >= -1e-3, "case {case}: not convex at {i}");
                assert!(
                    (0.0..=w as f32).contains(&a[0]) && (0.0..=h as f32).contains(&a[1]),
                    "case {case}: {a:?} outside"
                );
            }
            for y in 0..h {
                for x in 0..w {
                    if m.data[y * w + x] {
                        for c in [[x, y], [x + 1, y], [x, y + 1], [x + 1, y + 1]] {
                            assert!(
                                inside(&poly, [c[0] as f32, c[1] as f32]),
                                "case {case}: pixel ({x}, {y}) left out"
                            );
                        }
                    }
                }
            }
        }
        let square = Mask::from_fn(20, 20, |x, y| (3..9).contains(&x) && (5..15).contains(&y));
        let poly = covering_polygon(&square, 40).unwrap();
        assert_eq!(poly.len(), 4);
        assert!((signed_area2(&poly) / 2.0 - 60.0).abs() < 1e-9);
        for corner in [
            Mask::from_fn(5, 5, |x, y| x == 0 && y == 0),
            Mask::from_fn(5, 5, |x, y| x == 4 && y == 4),
        ] {
            let poly = covering_polygon(&corner, 8).unwrap();
            assert!(poly.len() <= 4 && signed_area2(&poly) > 0.0);
        }
        assert!(covering_polygon(&Mask::from_fn(5, 5, |_, _| false), 40).is_none());
        // A part filling its tile to the edges (the grown polygon is cut back to the tile).
        let full = covering_polygon(&Mask::from_fn(12, 9, |_, _| true), 40).unwrap();
        assert_eq!(full.len(), 4);
        assert!((signed_area2(&full) / 2.0 - 108.0).abs() < 1e-9);
        let disc = Mask::from_fn(30, 30, |x, y| {
            let (dx, dy) = (x as f32 - 14.5, y as f32 - 14.5);
            dx * dx + dy * dy <= 20.0 * 20.0
        });
        let poly = covering_polygon(&disc, 40).expect("a disc cut by every side of its tile");
        assert!(poly.len() <= 40);
    }

    #[test]
    fn offsetting_pixel_centres_by_half_a_pixel_reaches_the_pixel_edges() {
        // The 3 × 2 block of pixels at (2..5, 4..6): centres (2.5..4.5, 4.5..5.5).
        let centres = [[2.5, 4.5], [4.5, 4.5], [4.5, 5.5], [2.5, 5.5]];
        for poly in [centres.to_vec(), centres.iter().rev().copied().collect()] {
            let grown = offset_outward(&poly, 0.5);
            let mut got: Vec<[f32; 2]> = grown.clone();
            got.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let mut want = vec![[2.0, 4.0], [5.0, 4.0], [5.0, 6.0], [2.0, 6.0]];
            want.sort_by(|a, b| a.partial_cmp(b).unwrap());
            for (g, w) in got.iter().zip(&want) {
                assert!((g[0] - w[0]).abs() < 1e-5 && (g[1] - w[1]).abs() < 1e-5, "{got:?}");
            }
            assert!((signed_area2(&grown).abs() - 12.0).abs() < 1e-4);
        }
        // Rotation and translation invariance: the grown polygon of a moved polygon is the
        // moved grown polygon.
        let poly = vec![[0.0f32, 0.0], [10.0, 1.0], [12.0, 8.0], [5.0, 5.0], [-1.0, 9.0]];
        let (c, s) = (0.6f32, 0.8f32);
        let mv = |p: [f32; 2]| [c * p[0] - s * p[1] + 3.0, s * p[0] + c * p[1] - 7.0];
        let a: Vec<[f32; 2]> = offset_outward(&poly, 0.5).into_iter().map(mv).collect();
        let b = offset_outward(&poly.iter().copied().map(mv).collect::<Vec<_>>(), 0.5);
        for (p, q) in a.iter().zip(&b) {
            assert!((p[0] - q[0]).abs() < 1e-4 && (p[1] - q[1]).abs() < 1e-4);
        }
        // Grown means larger, and every edge moved out by d (area grows by about d × perimeter).
        assert!(signed_area2(&offset_outward(&poly, 0.5)).abs() > signed_area2(&poly).abs());
    }

    fn pixels(c: &[[f32; 2]]) -> HashSet<(i64, i64)> {
        c.iter().map(|p| ((p[0] - 0.5) as i64, (p[1] - 0.5) as i64)).collect()
    }

    /// Independent answer: foreground pixels next to the background that touches the border
    /// (flood fill from outside, 4-connected background).
    fn outer_boundary(mask: &Mask, eight: bool) -> HashSet<(i64, i64)> {
        let (w, h) = (mask.width as i64, mask.height as i64);
        let mut outside = HashSet::new();
        let mut stack = vec![(-1i64, -1i64)];
        outside.insert((-1, -1));
        while let Some((x, y)) = stack.pop() {
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < -1 || ny < -1 || nx > w || ny > h || mask.get(nx, ny) || outside.contains(&(nx, ny)) {
                    continue;
                }
                outside.insert((nx, ny));
                stack.push((nx, ny));
            }
        }
        let mut out = HashSet::new();
        for y in 0..h {
            for x in 0..w {
                if !mask.get(x, y) {
                    continue;
                }
                let near = |dx: i64, dy: i64| outside.contains(&(x + dx, y + dy));
                let four = near(1, 0) || near(-1, 0) || near(0, 1) || near(0, -1);
                let diag = near(1, 1) || near(-1, 1) || near(1, -1) || near(-1, -1);
                if four || (eight && diag) {
                    out.insert((x, y));
                }
            }
        }
        out
    }

    #[test]
    fn rectangle_contour_is_its_perimeter_in_order() {
        let m = Mask::from_fn(10, 8, |x, y| (2..7).contains(&x) && (1..5).contains(&y));
        let c = trace_outer(&m);
        assert_eq!(c.len(), 2 * (5 + 4) - 4);
        assert_eq!(c[0], [2.5, 1.5]);
        // Consecutive points are 8-neighbours, and the loop closes.
        for i in 0..c.len() {
            let (a, b) = (c[i], c[(i + 1) % c.len()]);
            assert!((a[0] - b[0]).abs() <= 1.0 && (a[1] - b[1]).abs() <= 1.0 && a != b);
        }
        assert!(signed_area2(&c) > 0.0, "clockwise on screen");
    }

    #[test]
    fn holes_are_filled_and_only_the_largest_component_is_traced() {
        // A ring (hole in the middle) plus a small separate blob.
        let m = Mask::from_fn(20, 20, |x, y| {
            let (dx, dy) = (x as f32 - 8.0, y as f32 - 8.0);
            let r = (dx * dx + dy * dy).sqrt();
            (3.0..7.0).contains(&r) || (x >= 17 && y >= 17)
        });
        let c = trace_outer(&m);
        let got = pixels(&c);
        assert!(got.iter().all(|&(x, y)| x < 16 && y < 16), "traced the small blob");
        let lo = outer_boundary(&largest_component(&m), false);
        let hi = outer_boundary(&largest_component(&m), true);
        assert!(lo.is_subset(&got), "missed outer boundary pixels");
        assert!(
            got.is_subset(&hi),
            "traced pixels off the outer boundary (e.g. the hole)"
        );
    }

    #[test]
    fn random_blobs_match_the_flood_fill_boundary_and_transpose_invariance() {
        let mut s = 7u32;
        for case in 0..40 {
            let mut rnd = || {
                s = s.wrapping_mul(1103515245).wrapping_add(12345);
                (s >> 16) & 0x7fff
            };
            let (w, h) = (8 + (rnd() % 20) as usize, 8 + (rnd() % 20) as usize);
            let blobs: Vec<(f32, f32, f32)> = (0..4)
                .map(|_| {
                    (
                        (rnd() % w as u32) as f32,
                        (rnd() % h as u32) as f32,
                        1.5 + (rnd() % 5) as f32,
                    )
                })
                .collect();
            let inside = |x: usize, y: usize| {
                blobs
                    .iter()
                    .any(|b| ((x as f32 - b.0).powi(2) + (y as f32 - b.1).powi(2)).sqrt() < b.2)
            };
            let m = Mask::from_fn(w, h, inside);
            let c = trace_outer(&m);
            if m.count() == 0 {
                assert!(c.is_empty());
                continue;
            }
            let comp = largest_component(&m);
            let got = pixels(&c);
            assert!(outer_boundary(&comp, false).is_subset(&got), "case {case}");
            assert!(got.is_subset(&outer_boundary(&comp, true)), "case {case}");
            // Transposing the mask transposes the traced pixel set.
            let t = Mask::from_fn(h, w, |x, y| inside(y, x));
            let tc: HashSet<(i64, i64)> = pixels(&trace_outer(&t)).into_iter().map(|(x, y)| (y, x)).collect();
            if largest_component(&t).count() == comp.count() {
                assert_eq!(tc, got, "case {case}");
            }
        }
    }

    #[test]
    fn separate_pieces_are_bridged_into_one_simple_outline_and_specks_dropped() {
        // A leg, a foot below it with a gap, and a two-pixel speck far away.
        let m = Mask::from_fn(40, 40, |x, y| {
            ((10..16).contains(&x) && (3..25).contains(&y))
                || ((8..20).contains(&x) && (29..34).contains(&y))
                || ((35..37).contains(&x) && y == 2)
        });
        let b = bridge_pieces(&m);
        assert_eq!(largest_component(&b).count(), b.count(), "one piece");
        for y in 0..40 {
            for x in 0..40 {
                let (leg_or_foot, speck) = (m.get(x, y) && x < 30, m.get(x, y) && x >= 30);
                assert!(!leg_or_foot || b.get(x, y), "lost ({x}, {y})");
                assert!(!speck || !b.get(x, y), "kept the speck");
            }
        }
        // The bridge is short (the gap is 4 rows) and thin.
        assert!(b.count() - (m.count() - 2) <= 3 * 6, "{} extra", b.count() - m.count());
        let c = trace_outer(&b);
        assert!(crate::bake::simplify::is_simple(&c));
        // Already one piece: unchanged.
        let one = largest_component(&m);
        assert_eq!(bridge_pieces(&one), one);
        assert_eq!(bridge_pieces(&Mask::new(5, 5)), Mask::new(5, 5));
    }

    #[test]
    fn spurs_necks_and_corner_contacts_still_trace_a_simple_outline() {
        // A blob with a one-pixel spur, a one-pixel neck to a second blob, and a pixel that
        // touches the blob only at a corner.
        let m = Mask::from_fn(30, 20, |x, y| {
            ((2..10).contains(&x) && (2..10).contains(&y))
                || ((10..16).contains(&x) && y == 5)
                || ((16..24).contains(&x) && (2..10).contains(&y))
                || (x == 5 && (10..16).contains(&y))
                || (x == 10 && y == 10)
        });
        let plain = trace_outer(&m);
        let unique: HashSet<_> = plain.iter().map(|p| (p[0].to_bits(), p[1].to_bits())).collect();
        assert!(unique.len() < plain.len(), "the plain trace revisits pixels here");
        let c = trace_simple(&m);
        let unique: HashSet<_> = c.iter().map(|p| (p[0].to_bits(), p[1].to_bits())).collect();
        assert_eq!(unique.len(), c.len());
        assert!(crate::bake::simplify::is_simple(&c));
        // Within a pixel of every mask pixel, inside the mask's bounds.
        for y in 0..20 {
            for x in 0..30 {
                if m.get(x, y) {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let near = c.iter().any(|p| (p[0] - px).abs() <= 1.0 && (p[1] - py).abs() <= 1.0);
                    assert!(near || inside(&c, [px, py]), "({x}, {y}) lost");
                }
            }
        }
        assert!(c.iter().all(|p| p[0] > 1.0 && p[0] < 25.0 && p[1] > 1.0 && p[1] < 17.0));
        // A clean mask traces exactly as before.
        let clean = Mask::from_fn(10, 8, |x, y| (2..7).contains(&x) && (1..5).contains(&y));
        assert_eq!(trace_simple(&clean), trace_outer(&clean));
    }

    fn inside(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
        let mut c = false;
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            if (a[1] > p[1]) != (b[1] > p[1]) && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0] {
                c = !c;
            }
        }
        c
    }

    #[test]
    fn degenerate_masks() {
        assert!(trace_outer(&Mask::new(5, 5)).is_empty());
        let one = Mask::from_fn(5, 5, |x, y| x == 2 && y == 3);
        assert_eq!(trace_outer(&one), vec![[2.5, 3.5]]);
        let line = Mask::from_fn(6, 3, |_, y| y == 1);
        let c = trace_outer(&line);
        // A one-pixel-wide line is walked out and back.
        assert_eq!(pixels(&c).len(), 6);
    }
}
