//! Sub-pixel placement of a fitted frame's polygon.
//!
//! The dynamic program maps every source vertex onto a vertex of the frame's traced outline
//! (simplified to a few dozen vertices): positions on a discrete set, up to a pixel or so from
//! where the part's edges are. On flat-coloured parts and thin limbs that pixel is most of
//! the error a frame shows. After the DP, each vertex of the drawn polygon is moved in small
//! steps (a pixel, then half, then a quarter) wherever that lowers the drawn part's squared
//! colour error against the frame's render (the error the bake reports), never turning a
//! triangle inside out. A move only changes the pixels of the triangles around the vertex,
//! so each trial redraws and measures only their box.

use crate::bake::image_cost::PartTile;
use crate::bake::raster::Canvas;

/// Step lengths, in pixels, tried one after another.
const STEPS: [f32; 3] = [1.0, 0.5, 0.25];

/// Passes over the vertices at one step length (a vertex is tried again in a later pass only
/// when it or a vertex it shares a triangle with moved in the one before). One pass per step
/// keeps 0.06–0.2 dB of a second's gain at half its cost (default character, RiggedSimple).
const PASSES: usize = 1;

/// Directions of a move: along the axes, then (only where none of those helps) the diagonals.
const DIRECTIONS: [[f32; 2]; 8] = [
    [1.0, 0.0],
    [-1.0, 0.0],
    [0.0, 1.0],
    [0.0, -1.0],
    [0.7071, 0.7071],
    [-0.7071, 0.7071],
    [0.7071, -0.7071],
    [-0.7071, -0.7071],
];

/// Squared colour error of a pixel against the truth, as [`Canvas::rmse`] sums it.
fn pixel_error(a: &[f32; 4], b: &[f32; 4]) -> f64 {
    let mut s = 0.0f64;
    for c in 0..3 {
        let d = a[c] * a[3] - b[c] * b[3];
        s += (d * d) as f64;
    }
    s
}

fn signed_area(p: [[f32; 2]; 3]) -> f32 {
    (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0])
}

/// Inclusive-exclusive pixel box `[x0, x1) × [y0, y1)`.
type PixelBox = [i64; 4];

fn triangle_box(p: [[f32; 2]; 3]) -> [f32; 4] {
    let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    for q in p {
        b[0] = b[0].min(q[0]);
        b[1] = b[1].min(q[1]);
        b[2] = b[2].max(q[0]);
        b[3] = b[3].max(q[1]);
    }
    b
}

/// The key image for drawing: premultiplied colour and coverage per pixel, with a border of
/// one empty pixel so bilinear taps need no bounds tests.
struct KeyImage {
    stride: usize,
    px: Vec<[f32; 4]>,
}

impl KeyImage {
    fn new(key: &PartTile) -> Self {
        let n = key.size as usize;
        let stride = n + 2;
        let mut px = vec![[0.0f32; 4]; stride * stride];
        for y in 0..n {
            for x in 0..n {
                let p = key.px[y * n + x];
                px[(y + 1) * stride + x + 1] = [p[0], p[1], p[2], p[6]];
            }
        }
        Self { stride, px }
    }

    /// What [`Canvas::draw_textured`] writes for a pixel textured at `(u, v)` (the same
    /// bilinear sample of [`PartTile::sample`]); `None` where the texel is not drawn.
    fn texel(&self, u: f32, v: f32) -> Option<[f32; 4]> {
        let (fx, fy) = (u - 0.5, v - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        // Border-shifted indices; taps outside the image read the empty border or nothing.
        let (xi, yi) = (x0 as i64 + 1, y0 as i64 + 1);
        let s = self.stride as i64;
        if xi < 0 || yi < 0 || xi + 1 >= s || yi + 1 >= s {
            return None;
        }
        let i = (yi * s + xi) as usize;
        let (a, b, c, d) = (
            self.px[i],
            self.px[i + 1],
            self.px[i + self.stride],
            self.px[i + self.stride + 1],
        );
        let mut o = [0.0f32; 4];
        for k in 0..4 {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bottom = c[k] + (d[k] - c[k]) * tx;
            o[k] = top + (bottom - top) * ty;
        }
        (o[3] >= crate::bake::raster::ALPHA_CUTOFF).then(|| [o[0] / o[3], o[1] / o[3], o[2] / o[3], 1.0])
    }
}

/// A triangle ready for pixel tests: barycentric weights and texture coordinates as linear
/// functions of the pixel centre (`[constant, per x, per y]`), so a pixel costs a few
/// multiply-adds.
#[derive(Clone, Copy)]
struct Placed {
    pos: [[f32; 2]; 3],
    /// Signed area (twice), as [`signed_area`].
    area: f32,
    w0: [f32; 3],
    w1: [f32; 3],
    u: [f32; 3],
    v: [f32; 3],
}

impl Placed {
    fn new(pos: [[f32; 2]; 3], uv: [[f32; 2]; 3]) -> Self {
        let area = signed_area(pos);
        // w0 = ((p1 - c) × (p2 - c)) / area, w1 = ((p2 - c) × (p0 - c)) / area for centre c.
        let edge = |a: [f32; 2], b: [f32; 2]| -> [f32; 3] {
            if area.abs() < 1e-9 {
                return [-1.0, 0.0, 0.0];
            }
            [
                (a[0] * b[1] - a[1] * b[0]) / area,
                (a[1] - b[1]) / area,
                (b[0] - a[0]) / area,
            ]
        };
        let (w0, w1) = (edge(pos[1], pos[2]), edge(pos[2], pos[0]));
        let w2 = [1.0 - w0[0] - w1[0], -w0[1] - w1[1], -w0[2] - w1[2]];
        let along =
            |k: usize| -> [f32; 3] { std::array::from_fn(|c| w0[c] * uv[0][k] + w1[c] * uv[1][k] + w2[c] * uv[2][k]) };
        Self {
            pos,
            area,
            w0,
            w1,
            u: along(0),
            v: along(1),
        }
    }

    /// Texture coordinates at pixel centre `(px, py)` when the triangle covers it (the rule of
    /// [`Canvas::draw_textured`]: every barycentric weight at least 0; degenerate triangles
    /// cover nothing).
    fn cover(&self, px: f32, py: f32) -> Option<[f32; 2]> {
        let w0 = self.w0[0] + self.w0[1] * px + self.w0[2] * py;
        let w1 = self.w1[0] + self.w1[1] * px + self.w1[2] * py;
        if w0 < 0.0 || w1 < 0.0 || 1.0 - w0 - w1 < 0.0 {
            return None;
        }
        Some([
            self.u[0] + self.u[1] * px + self.u[2] * py,
            self.v[0] + self.v[1] * px + self.v[2] * py,
        ])
    }
}

/// Moves the vertices of `positions` (the drawn polygon at one frame: `triangles` index it,
/// textured from `key` at `uvs`) to lower the drawn error against `truth`; vertices with
/// `fixed[i]` stay. Returns the error before and after (sums of squared colour differences,
/// as [`Canvas::rmse`] counts them, of the drawing as it is kept up to date here: exact while
/// the triangles do not overlap, which a fold-free fit of a simple polygon keeps).
pub fn refine(
    positions: &mut [[f32; 2]],
    uvs: &[[f32; 2]],
    triangles: &[[usize; 3]],
    key: &PartTile,
    truth: &Canvas,
    fixed: &[bool],
) -> (f64, f64) {
    let size = truth.size as i64;
    let mut cur = Canvas::new(truth.size);
    for t in triangles {
        cur.draw_textured(t.map(|i| positions[i]), t.map(|i| uvs[i]), key);
    }
    let before: f64 = cur.px.iter().zip(&truth.px).map(|(a, b)| pixel_error(a, b)).sum();
    let image = KeyImage::new(key);
    // Orientation of each triangle in the key image: a move may flatten a triangle but not
    // turn it over.
    let orient: Vec<f32> = triangles
        .iter()
        .map(|t| signed_area(t.map(|i| uvs[i])).signum())
        .collect();
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); positions.len()];
    for (k, t) in triangles.iter().enumerate() {
        for &i in t {
            around[i].push(k);
        }
    }
    // Vertices sharing a triangle: a vertex is tried again only after one of them (or itself)
    // moved, since nothing else changes what its moves would find.
    let mut linked: Vec<Vec<usize>> = vec![Vec::new(); positions.len()];
    for t in triangles {
        for &a in t {
            for &b in t {
                if !linked[a].contains(&b) {
                    linked[a].push(b);
                }
            }
        }
    }
    // What moving vertex `i`'s triangles from `old` to `new` does to the pixels of box `r`:
    // pixels the old triangles covered and the new ones do not fall back to the background,
    // pixels the new ones cover take their texel. Calls `visit(index, new value)` for each
    // changed pixel and returns the change in error. `scratch` marks pixels (0 untouched, 1
    // uncovered, 2 drawn) and is left all 0.
    let n = size as usize;
    let mut scratch: Vec<(u8, [f32; 4])> = vec![(0, [0.0; 4]); n * n];
    let mut touched: Vec<usize> = Vec::new();
    // The pixels of box `r` that triangles `old` cover, triangle by triangle in scan order
    // (a pixel under two of them twice): the same for every trial move of one vertex.
    let covered = |old: &[Placed], r: PixelBox| -> Vec<usize> {
        let mut out = Vec::new();
        for t in old {
            each_pixel(clip(t, r), size, |at, px, py| {
                if t.cover(px, py).is_some() {
                    out.push(at);
                }
            });
        }
        out
    };
    let mut change =
        |cur: &Canvas, old: &[usize], new: &[Placed], r: PixelBox, visit: &mut dyn FnMut(usize, [f32; 4])| -> f64 {
            for t in new {
                each_pixel(clip(t, r), size, |at, px, py| {
                    if scratch[at].0 == 2 {
                        return;
                    }
                    if let Some(uv) = t.cover(px, py) {
                        if scratch[at].0 == 0 {
                            touched.push(at);
                        }
                        scratch[at] = (2, image.texel(uv[0], uv[1]).unwrap_or([0.0; 4]));
                    }
                });
            }
            for &at in old {
                if scratch[at].0 == 0 {
                    touched.push(at);
                    scratch[at] = (1, [0.0; 4]);
                }
            }
            let mut delta = 0.0;
            for &at in &touched {
                let value = scratch[at].1;
                scratch[at] = (0, [0.0; 4]);
                if value != cur.px[at] {
                    delta += pixel_error(&value, &truth.px[at]) - pixel_error(&cur.px[at], &truth.px[at]);
                    visit(at, value);
                }
            }
            touched.clear();
            delta
        };
    let mut error = before;
    for step in STEPS {
        let mut dirty = vec![true; positions.len()];
        for _ in 0..PASSES {
            let mut moved = false;
            let mut next = vec![false; positions.len()];
            for i in 0..positions.len() {
                if !dirty[i] || fixed.get(i).copied().unwrap_or(false) || around[i].is_empty() {
                    continue;
                }
                let old = positions[i];
                let placed = |at: &[[f32; 2]]| -> Vec<Placed> {
                    around[i]
                        .iter()
                        .map(|&k| Placed::new(triangles[k].map(|j| at[j]), triangles[k].map(|j| uvs[j])))
                        .collect()
                };
                let was = placed(positions);
                // The box the triangles around the vertex cover at the old place or any trial
                // place, in whole pixels.
                let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
                for t in &was {
                    let tb = triangle_box(t.pos);
                    b = [b[0].min(tb[0]), b[1].min(tb[1]), b[2].max(tb[2]), b[3].max(tb[3])];
                }
                let r: PixelBox = [
                    ((b[0].min(old[0] - step)).floor() as i64).max(0),
                    ((b[1].min(old[1] - step)).floor() as i64).max(0),
                    ((b[2].max(old[0] + step)).ceil() as i64 + 1).min(size),
                    ((b[3].max(old[1] + step)).ceil() as i64 + 1).min(size),
                ];
                if r[0] >= r[2] || r[1] >= r[3] {
                    continue;
                }
                let was_cover = covered(&was, r);
                let mut best: Option<([f32; 2], f64)> = None;
                for (n, d) in DIRECTIONS.into_iter().enumerate() {
                    // The diagonals only where no move along the axes helps.
                    if n == 4 && best.is_some() {
                        break;
                    }
                    // Where a step one way helps, the step back the other way is not tried.
                    if (n == 1 || n == 3) && best.is_some_and(|(q, _)| (q[n / 2] - old[n / 2]) > 0.0) {
                        continue;
                    }
                    let q = [old[0] + step * d[0], old[1] + step * d[1]];
                    positions[i] = q;
                    let now = placed(positions);
                    positions[i] = old;
                    if now.iter().zip(&around[i]).any(|(t, &k)| t.area * orient[k] < 0.0) {
                        continue;
                    }
                    let delta = change(&cur, &was_cover, &now, r, &mut |_, _| {});
                    if delta < -1e-9 && best.is_none_or(|(_, bd)| delta < bd) {
                        best = Some((q, delta));
                    }
                }
                if let Some((q, _)) = best {
                    positions[i] = q;
                    let now = placed(positions);
                    let mut changed = Vec::new();
                    error += change(&cur, &was_cover, &now, r, &mut |at, v| changed.push((at, v)));
                    for (at, v) in changed {
                        cur.px[at] = v;
                    }
                    moved = true;
                    for &j in &linked[i] {
                        next[j] = true;
                    }
                }
            }
            if !moved {
                break;
            }
            dirty = next;
        }
    }
    (before, error.max(0.0))
}

/// The whole pixels of triangle `t`'s bounding box inside box `r`.
fn clip(t: &Placed, r: PixelBox) -> PixelBox {
    let b = triangle_box(t.pos);
    [
        (b[0].floor() as i64).max(r[0]),
        (b[1].floor() as i64).max(r[1]),
        (b[2].ceil() as i64).min(r[2]),
        (b[3].ceil() as i64).min(r[3]),
    ]
}

/// Calls `f(index, x, y)` for every pixel of box `c` (index into a `size`-wide image, x and y
/// the pixel's centre).
#[inline(always)]
fn each_pixel(c: PixelBox, size: i64, mut f: impl FnMut(usize, f32, f32)) {
    for y in c[1]..c[3] {
        let py = y as f32 + 0.5;
        let row = (y * size) as usize;
        for x in c[0]..c[2] {
            f(row + x as usize, x as f32 + 0.5, py);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::raster::tile_canvas;

    /// A flat-coloured rectangle with a stripe, `size`² pixels.
    fn rect_tile(size: u32, x0: f32, y0: f32, x1: f32, y1: f32) -> PartTile {
        PartTile {
            size,
            px: (0..size * size)
                .map(|i| {
                    let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
                    if x >= x0 && x < x1 && y >= y0 && y < y1 {
                        let g = if y < 0.5 * (y0 + y1) { 0.9 } else { 0.3 };
                        [g, 0.5, 0.2, 0.5, 0.5, 1.0, 1.0]
                    } else {
                        [0.0; 7]
                    }
                })
                .collect(),
        }
    }

    #[test]
    fn a_polygon_under_a_pixel_off_moves_onto_the_part_and_the_error_falls() {
        let key = rect_tile(48, 10.0, 10.0, 30.0, 40.0);
        let truth = tile_canvas(&rect_tile(48, 12.0, 9.0, 32.0, 39.0));
        let uvs = vec![[10.0, 10.0], [30.0, 10.0], [30.0, 40.0], [10.0, 40.0]];
        let triangles = vec![[0, 1, 2], [0, 2, 3]];
        // Placed three quarters of a pixel short of the truth to the right and half a pixel
        // low (the DP leaves vertices within about a pixel).
        let mut pos: Vec<[f32; 2]> = uvs.iter().map(|p| [p[0] + 1.25, p[1] - 0.5]).collect();
        let (before, after) = refine(&mut pos, &uvs, &triangles, &key, &truth, &[false; 4]);
        let mut drawn = Canvas::new(48);
        for t in &triangles {
            drawn.draw_textured(t.map(|i| pos[i]), t.map(|i| uvs[i]), &key);
        }
        let measured: f64 = drawn.px.iter().zip(&truth.px).map(|(a, b)| pixel_error(a, b)).sum();
        assert!(after < 0.2 * before, "{before} -> {after}");
        assert!(
            (measured - after).abs() < 1e-6 * before.max(1.0),
            "{measured} vs {after}"
        );
        for (p, u) in pos.iter().zip(&uvs) {
            assert!(
                (p[0] - u[0] - 2.0).abs() <= 0.5 && (p[1] - u[1] + 1.0).abs() <= 0.5,
                "{p:?} from {u:?}"
            );
        }
    }

    #[test]
    fn fixed_vertices_stay_and_no_triangle_turns_over() {
        let key = rect_tile(40, 8.0, 8.0, 24.0, 30.0);
        // The truth is a thin sliver: the best drawing would flatten or flip triangles.
        let truth = tile_canvas(&rect_tile(40, 8.0, 8.0, 10.0, 30.0));
        let uvs = vec![[8.0, 8.0], [24.0, 8.0], [24.0, 30.0], [8.0, 30.0]];
        let triangles = vec![[0, 1, 2], [0, 2, 3]];
        let mut pos = uvs.clone();
        let fixed = [true, false, false, true];
        let (before, after) = refine(&mut pos, &uvs, &triangles, &key, &truth, &fixed);
        assert!(after <= before);
        assert_eq!(pos[0], uvs[0]);
        assert_eq!(pos[3], uvs[3]);
        for t in &triangles {
            let a = signed_area(t.map(|i| pos[i]));
            assert!(a * signed_area(t.map(|i| uvs[i])) >= 0.0, "{a}");
        }
    }

    /// A textured ellipse (a colour gradient across it) centred at `c` with radii `r`.
    fn ellipse_tile(size: u32, c: [f32; 2], r: [f32; 2]) -> PartTile {
        PartTile {
            size,
            px: (0..size * size)
                .map(|i| {
                    let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
                    let (u, v) = ((x - c[0]) / r[0], (y - c[1]) / r[1]);
                    if u * u + v * v < 1.0 {
                        [0.5 + 0.4 * u, 0.5 + 0.4 * v, 0.3, 0.5, 0.5, 1.0, 1.0]
                    } else {
                        [0.0; 7]
                    }
                })
                .collect(),
        }
    }

    /// The error the refinement reports is the error of drawing its result from scratch (an
    /// independent answer: the canvas rasteriser over the whole image), on a textured part
    /// of many triangles, and it never rises.
    #[test]
    fn the_tracked_error_is_the_redrawn_error() {
        let size = 64;
        let key = ellipse_tile(size, [30.0, 32.0], [14.0, 20.0]);
        let truth = tile_canvas(&ellipse_tile(size, [31.3, 31.4], [15.2, 19.1]));
        let n = 18;
        let uvs: Vec<[f32; 2]> = (0..n)
            .map(|k| {
                let a = k as f32 / n as f32 * std::f32::consts::TAU;
                [30.0 + 14.5 * a.cos(), 32.0 + 20.5 * a.sin()]
            })
            .collect();
        let triangles = crate::bake::triangulate::triangulate(&uvs).unwrap();
        let mut pos = uvs.clone();
        let (before, after) = refine(&mut pos, &uvs, &triangles, &key, &truth, &vec![false; n]);
        let mut drawn = Canvas::new(size);
        for t in &triangles {
            drawn.draw_textured(t.map(|i| pos[i]), t.map(|i| uvs[i]), &key);
        }
        let redrawn: f64 = drawn.px.iter().zip(&truth.px).map(|(a, b)| pixel_error(a, b)).sum();
        assert!(after < 0.7 * before, "{before} -> {after}");
        assert!(
            (redrawn - after).abs() < 1e-4 * before,
            "tracked {after}, redrawn {redrawn}"
        );
    }

    #[test]
    fn a_perfect_drawing_is_left_alone() {
        let key = rect_tile(32, 6.0, 6.0, 20.0, 26.0);
        let truth = tile_canvas(&key);
        let uvs = vec![[6.0, 6.0], [20.0, 6.0], [20.0, 26.0], [6.0, 26.0]];
        let mut pos = uvs.clone();
        let (before, after) = refine(&mut pos, &uvs, &[[0, 1, 2], [0, 2, 3]], &key, &truth, &[false; 4]);
        assert!(before < 1e-6 && after < 1e-6);
        assert_eq!(pos, uvs);
    }
}
