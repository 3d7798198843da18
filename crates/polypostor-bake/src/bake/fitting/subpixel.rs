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

/// How far past a row's computed span (the zero crossings of the triangle's weights) a pixel
/// centre may lie and still be visited ([`Placed::each_pixel_near`]), besides a bound on what
/// f32 rounding may move a crossing by (tiny on most triangles, tenths of a pixel on a long
/// sliver far from the origin), so no pixel [`Placed::cover`] accepts is missed (tested on
/// random, sliver and near-axis triangles on 300² and 2048² images). A pixel and a half each
/// side before 2026-12-02 (session 63): 58 % of the pixels visited were then outside the
/// triangle.
const SPAN_MARGIN: f32 = 0.25;

/// Squared colour error of a pixel against the truth, as [`Canvas::rmse`] sums it.
fn pixel_error(a: &[f32; 4], b: &[f32; 4]) -> f64 {
    let mut s = 0.0f64;
    for c in 0..3 {
        let d = a[c] * a[3] - b[c] * b[3];
        s += (d * d) as f64;
    }
    let d = a[3] - b[3];
    s + COVERAGE_WEIGHT * (d * d) as f64
}

/// Weight of the coverage difference in a pixel's error, beside the colour's: without it a
/// black part's silhouette costs nothing against the empty background (colour × coverage is 0
/// either way) and its vertices never move onto the render's edge. 0.25: a pixel of black
/// drawn or missed costs what a mid-grey one does by colour (measured on 24 views: three.js's
/// black horse's silhouette agreement 0.962 → 0.971, its white-based copy's being 0.972; the
/// bakes' colour PSNR within −0.02 to +0.05 dB on six characters; 1 cost the default 0.10 dB).
/// The reported PSNR stays colour only, as every figure in the README is measured.
const COVERAGE_WEIGHT: f64 = 0.25;

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
    #[inline(always)]
    fn texel(&self, u: f32, v: f32) -> Option<[f32; 4]> {
        let (fx, fy) = (u - 0.5, v - 0.5);
        let (x0, y0) = (floor(fx), floor(fy));
        let (tx, ty) = (fx - x0, fy - y0);
        // Border-shifted indices; taps outside the image read the empty border or nothing.
        let (xi, yi) = (x0 as i64 + 1, y0 as i64 + 1);
        let s = self.stride as i64;
        if xi < 0 || yi < 0 || xi + 1 >= s || yi + 1 >= s {
            return None;
        }
        let i = (yi * s + xi) as usize;
        texel_of(
            [
                self.px[i],
                self.px[i + 1],
                self.px[i + self.stride],
                self.px[i + self.stride + 1],
            ],
            tx,
            ty,
        )
    }
}

/// Bilinear blend of four premultiplied taps (top left, top right, bottom left, bottom right)
/// at `(tx, ty)` — `top + (bottom - top) ty` with `top = a + (b - a) tx`, `bottom = c + (d -
/// c) tx` — then divided by its coverage: `None` under [`crate::bake::raster::ALPHA_CUTOFF`].
/// On x86_64 every channel in one SSE register: the same operations in the same order as
/// channel by channel, so the same values.
#[inline(always)]
fn texel_of(taps: [[f32; 4]; 4], tx: f32, ty: f32) -> Option<[f32; 4]> {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE is part of x86_64; the loads and the store read and write arrays of four
        // f32s.
        unsafe {
            let [a, b, c, d] = taps.map(|t| _mm_loadu_ps(t.as_ptr()));
            let (vx, vy) = (_mm_set1_ps(tx), _mm_set1_ps(ty));
            let top = _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(b, a), vx));
            let bottom = _mm_add_ps(c, _mm_mul_ps(_mm_sub_ps(d, c), vx));
            let o = _mm_add_ps(top, _mm_mul_ps(_mm_sub_ps(bottom, top), vy));
            let alpha = _mm_cvtss_f32(_mm_shuffle_ps::<0b11_11_11_11>(o, o));
            if !(alpha >= crate::bake::raster::ALPHA_CUTOFF) {
                return None;
            }
            let mut out = [0.0f32; 4];
            _mm_storeu_ps(out.as_mut_ptr(), _mm_div_ps(o, _mm_set1_ps(alpha)));
            out[3] = 1.0;
            Some(out)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let [a, b, c, d] = taps;
        let o: [f32; 4] = std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bottom = c[k] + (d[k] - c[k]) * tx;
            top + (bottom - top) * ty
        });
        let alpha = o[3];
        if !(alpha >= crate::bake::raster::ALPHA_CUTOFF) {
            return None;
        }
        Some([o[0] / alpha, o[1] / alpha, o[2] / alpha, 1.0])
    }
}

/// `x.floor()` without the library call (the build targets CPUs without SSE4.1's rounding
/// instruction): exact for |x| < 2²³, which texture coordinates of a tile are; NaN gives 0,
/// whose taps then read NaN weights and draw nothing, as `floor` would.
#[inline(always)]
fn floor(x: f32) -> f32 {
    let i = x as i32 as f32;
    if i > x { i - 1.0 } else { i }
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

    /// Calls `f(index, x, y)` for the pixels of box `c` (index into a `size`-wide image, x
    /// and y the pixel's centre) within a pixel of the triangle's span on each row: every
    /// pixel [`Placed::cover`] accepts, and few others (a long thin triangle's box is mostly
    /// empty). The span comes from each weight's zero crossing along the row; a weight that
    /// barely changes along the row does not narrow it.
    #[inline(always)]
    fn each_pixel_near(&self, c: PixelBox, size: i64, mut f: impl FnMut(usize, f32, f32)) {
        let w2 = [
            1.0 - self.w0[0] - self.w1[0],
            -self.w0[1] - self.w1[1],
            -self.w0[2] - self.w1[2],
        ];
        let x_far = (c[0].unsigned_abs().max(c[2].unsigned_abs())) as f32;
        for y in c[1]..c[3] {
            let py = y as f32 + 0.5;
            let (mut lo, mut hi) = (c[0] as f32, c[2] as f32);
            for w in [&self.w0, &self.w1, &w2] {
                // w(x) = w[0] + w[1] x + w[2] py >= 0.
                if w[1].abs() < 1e-3 {
                    continue;
                }
                let at = -(w[0] + w[2] * py) / w[1];
                // What f32 rounding may move the crossing by, here and in `covers` (a few
                // ulps of the terms summed, over the slope): far from the origin on a
                // sliver's nearly level edge it reaches tenths of a pixel.
                let slack = SPAN_MARGIN + 1e-6 * (w[0].abs() + w[1].abs() * x_far + w[2].abs() * py) / w[1].abs();
                if w[1] > 0.0 {
                    lo = lo.max(at - slack);
                } else {
                    hi = hi.min(at + slack);
                }
            }
            // Pixel x has its centre at x + 0.5: the pixels whose centres lie in [lo, hi].
            let x0 = (floor(lo - 0.5) as i64 + 1).max(c[0]);
            let x1 = (floor(hi - 0.5) as i64 + 1).min(c[2]);
            let row = (y * size) as usize;
            for x in x0..x1 {
                f(row + x as usize, x as f32 + 0.5, py);
            }
        }
    }

    /// Whether the triangle covers pixel centre `(px, py)` (as [`Placed::cover`]).
    #[inline(always)]
    fn covers(&self, px: f32, py: f32) -> bool {
        let w0 = self.w0[0] + self.w0[1] * px + self.w0[2] * py;
        let w1 = self.w1[0] + self.w1[1] * px + self.w1[2] * py;
        !(w0 < 0.0 || w1 < 0.0 || 1.0 - w0 - w1 < 0.0)
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
    Refiner::new(key).refine(positions, uvs, triangles, truth, fixed)
}

/// [`refine`] for many frames drawn from one key image, prepared once.
pub struct Refiner<'k> {
    key: &'k PartTile,
    image: KeyImage,
}

impl<'k> Refiner<'k> {
    pub fn new(key: &'k PartTile) -> Self {
        Self {
            key,
            image: KeyImage::new(key),
        }
    }

    /// [`refine`] with this key image.
    pub fn refine(
        &self,
        positions: &mut [[f32; 2]],
        uvs: &[[f32; 2]],
        triangles: &[[usize; 3]],
        truth: &Canvas,
        fixed: &[bool],
    ) -> (f64, f64) {
        let steps = Steps {
            lengths: &STEPS,
            passes: PASSES,
        };
        self.refine_steps(positions, uvs, triangles, truth, fixed, steps)
    }

    /// [`Refiner::refine`] with other step lengths and passes.
    pub fn refine_steps(
        &self,
        positions: &mut [[f32; 2]],
        uvs: &[[f32; 2]],
        triangles: &[[usize; 3]],
        truth: &Canvas,
        fixed: &[bool],
        steps: Steps,
    ) -> (f64, f64) {
        refine_with(positions, uvs, triangles, self.key, &self.image, truth, fixed, steps)
    }
}

/// The moves [`Refiner::refine_steps`] tries.
#[derive(Clone, Copy, Debug)]
pub struct Steps<'a> {
    /// Step lengths, pixels, one after another.
    pub lengths: &'a [f32],
    /// Most passes over the vertices at each length (a vertex is tried again only after it or
    /// a vertex it shares a triangle with moved).
    pub passes: usize,
}

#[allow(clippy::too_many_arguments)]
fn refine_with(
    positions: &mut [[f32; 2]],
    uvs: &[[f32; 2]],
    triangles: &[[usize; 3]],
    key: &PartTile,
    image: &KeyImage,
    truth: &Canvas,
    fixed: &[bool],
    steps: Steps,
) -> (f64, f64) {
    let size = truth.size as i64;
    let mut cur = Canvas::new(truth.size);
    for t in triangles {
        cur.draw_textured(t.map(|i| positions[i]), t.map(|i| uvs[i]), key);
    }
    let mut drawing = Drawing::new(cur, truth, image);
    let before: f64 = drawing.err.iter().sum();
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
    let mut was: Vec<Placed> = Vec::new();
    let mut now: Vec<Placed> = Vec::new();
    let mut was_cover: Vec<usize> = Vec::new();
    let (mut best_changed, mut trial_changed): (Vec<Changed>, Vec<Changed>) = (Vec::new(), Vec::new());
    let place = |out: &mut Vec<Placed>, around: &[usize], at: &[[f32; 2]]| {
        out.clear();
        out.extend(
            around
                .iter()
                .map(|&k| Placed::new(triangles[k].map(|j| at[j]), triangles[k].map(|j| uvs[j]))),
        );
    };
    let mut error = before;
    for &step in steps.lengths {
        let mut dirty = vec![true; positions.len()];
        for _ in 0..steps.passes {
            let mut moved = false;
            let mut next = vec![false; positions.len()];
            for i in 0..positions.len() {
                if !dirty[i] || fixed.get(i).copied().unwrap_or(false) || around[i].is_empty() {
                    continue;
                }
                let old = positions[i];
                place(&mut was, &around[i], positions);
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
                // The pixels of box `r` the old triangles cover, triangle by triangle in scan
                // order (a pixel under two of them twice): the same for every trial move.
                was_cover.clear();
                for t in &was {
                    t.each_pixel_near(clip(t, r), size, |at, px, py| {
                        if t.covers(px, py) {
                            was_cover.push(at);
                        }
                    });
                }
                let mut best: Option<([f32; 2], f64)> = None;
                // The pixels the best move so far changes (made, not measured again, when
                // it is taken), and the trial's.
                best_changed.clear();
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
                    place(&mut now, &around[i], positions);
                    positions[i] = old;
                    if now.iter().zip(&around[i]).any(|(t, &k)| t.area * orient[k] < 0.0) {
                        continue;
                    }
                    let delta = drawing.change(&was_cover, &now, r, &mut trial_changed);
                    if delta < -1e-9 && best.is_none_or(|(_, bd)| delta < bd) {
                        best = Some((q, delta));
                        std::mem::swap(&mut best_changed, &mut trial_changed);
                    }
                }
                if let Some((q, delta)) = best {
                    positions[i] = q;
                    drawing.apply(&best_changed);
                    error += delta;
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

/// A pixel a trial move changes: its index, new value and new error.
struct Changed {
    at: usize,
    value: [f32; 4],
    error: f64,
}

/// The drawing as the refinement keeps it up to date, with what a trial move needs at hand:
/// each pixel's error against the truth, and what it would be left empty.
struct Drawing<'a> {
    cur: Canvas,
    truth: &'a Canvas,
    image: &'a KeyImage,
    /// Each pixel's error now ([`pixel_error`] of `cur` against the truth).
    err: Vec<f64>,
    /// Each pixel's error if nothing covered it.
    empty: Vec<f64>,
    /// `mark[i] == stamp`: pixel `i` already counted in the current [`Drawing::change`].
    mark: Vec<u32>,
    stamp: u32,
}

impl<'a> Drawing<'a> {
    fn new(cur: Canvas, truth: &'a Canvas, image: &'a KeyImage) -> Self {
        let err = cur.px.iter().zip(&truth.px).map(|(a, b)| pixel_error(a, b)).collect();
        let empty = truth.px.iter().map(|b| pixel_error(&[0.0; 4], b)).collect();
        let mark = vec![0; cur.px.len()];
        Self {
            cur,
            truth,
            image,
            err,
            empty,
            mark,
            stamp: 0,
        }
    }

    /// What moving a vertex's triangles from `old` (the pixels they covered, as listed for
    /// the move) to `new` does to the pixels of box `r`: pixels the new triangles cover take
    /// their texel (the first triangle's where two cover one), pixels only the old ones
    /// covered fall back to the background. Returns the change in error and lists in `changed`
    /// (cleared first) every pixel that changes, with its new value and error, for
    /// [`Drawing::apply`]: each pixel is looked at once, so applying the list is the move.
    fn change(&mut self, old: &[usize], new: &[Placed], r: PixelBox, changed: &mut Vec<Changed>) -> f64 {
        changed.clear();
        if self.stamp == u32::MAX {
            self.mark.fill(0);
            self.stamp = 0;
        }
        self.stamp += 1;
        let stamp = self.stamp;
        let size = self.truth.size as i64;
        let mut delta = 0.0;
        let (cur, truth, image) = (&self.cur, self.truth, self.image);
        let (err, empty, mark) = (&self.err, &self.empty, &mut self.mark);
        for t in new {
            t.each_pixel_near(clip(t, r), size, |at, px, py| {
                if mark[at] == stamp {
                    return;
                }
                if let Some(uv) = t.cover(px, py) {
                    mark[at] = stamp;
                    let value = image.texel(uv[0], uv[1]).unwrap_or([0.0; 4]);
                    if value != cur.px[at] {
                        let e = pixel_error(&value, &truth.px[at]);
                        delta += e - err[at];
                        changed.push(Changed { at, value, error: e });
                    }
                }
            });
        }
        for &at in old {
            if mark[at] != stamp {
                mark[at] = stamp;
                if cur.px[at] != [0.0; 4] {
                    delta += empty[at] - err[at];
                    changed.push(Changed {
                        at,
                        value: [0.0; 4],
                        error: empty[at],
                    });
                }
            }
        }
        delta
    }

    /// Makes the move [`Drawing::change`] listed.
    fn apply(&mut self, changed: &[Changed]) {
        for c in changed {
            self.cur.px[c.at] = c.value;
            self.err[c.at] = c.error;
        }
    }
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

    /// Visits the pixels of triangle `p`'s box on a `size`² image as [`Placed::each_pixel_near`]
    /// does and asserts every pixel [`Placed::covers`] accepts (brute force over the box) is
    /// among them; returns how many it covers and how many visited pixels it does not.
    fn check_spans(p: [[f32; 2]; 3], size: i64) -> (usize, usize) {
        let t = Placed::new(p, p);
        let b = triangle_box(p);
        let c: PixelBox = [
            (b[0].floor() as i64).max(0),
            (b[1].floor() as i64).max(0),
            (b[2].ceil() as i64).min(size),
            (b[3].ceil() as i64).min(size),
        ];
        let (mut covered, mut outside) = (0, 0);
        let mut seen = std::collections::HashSet::new();
        t.each_pixel_near(c, size, |at, px, py| {
            assert_eq!(
                (at as i64 % size, at as i64 / size),
                ((px - 0.5) as i64, (py - 0.5) as i64)
            );
            seen.insert(at);
            if !t.covers(px, py) {
                outside += 1;
            }
        });
        for y in c[1]..c[3] {
            for x in c[0]..c[2] {
                if t.covers(x as f32 + 0.5, y as f32 + 0.5) {
                    covered += 1;
                    assert!(seen.contains(&((y * size + x) as usize)), "{p:?}: pixel {x}, {y}");
                }
            }
        }
        (covered, outside)
    }

    /// The rows' spans visit every pixel a triangle covers (brute force over its box): random
    /// triangles, thin slivers, near-horizontal and near-vertical edges, large coordinates.
    #[test]
    fn each_pixel_near_visits_every_covered_pixel() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let size = 300i64;
        let (mut covered, mut visited_outside) = (0usize, 0usize);
        for k in 0..20_000 {
            let s = if k % 4 == 0 { 290.0 } else { 24.0 };
            let o = [next() * (290.0 - s), next() * (290.0 - s)];
            let mut p = [[0.0f32; 2]; 3];
            for q in &mut p {
                *q = [o[0] + next() * s, o[1] + next() * s];
            }
            match k % 5 {
                // A sliver: the third corner near the first edge.
                1 => {
                    let t = next();
                    p[2] = [
                        p[0][0] + t * (p[1][0] - p[0][0]) + 0.3 * (next() - 0.5),
                        p[0][1] + t * (p[1][1] - p[0][1]) + 0.3 * (next() - 0.5),
                    ];
                }
                // Nearly horizontal and nearly vertical edges.
                2 => p[1][1] = p[0][1] + 1e-3 * (next() - 0.5),
                3 => p[1][0] = p[0][0] + 1e-3 * (next() - 0.5),
                _ => {}
            }
            let (c, o) = check_spans(p, size);
            covered += c;
            visited_outside += o;
        }
        // Long slivers with a nearly level edge far from the origin of a 2048² image, where
        // f32 rounding moves the crossings most.
        let size2 = 2048i64;
        for k in 0..3000 {
            let (x, y) = (10.0 + next() * 30.0, 1900.0 + next() * 140.0);
            let long = 1500.0 + next() * 500.0;
            let rise = (next() - 0.5) * 3.0;
            let p = [
                [x, y],
                [x + long, y + rise],
                [
                    x + next() * long,
                    y + rise * next() + (next() - 0.5) * if k % 2 == 0 { 0.4 } else { 2.0 },
                ],
            ];
            let (c, o) = check_spans(p, size2);
            covered += c;
            visited_outside += o;
        }
        assert!(covered > 1_000_000, "{covered}");
        // The spans are tight: most pixels visited are covered.
        assert!(
            visited_outside < covered / 2,
            "{visited_outside} visited outside, {covered} covered"
        );
    }

    #[test]
    fn a_polygon_under_a_pixel_off_moves_onto_the_part_and_the_error_falls() {
        moves_onto_the_part(&|t| t, true);
    }

    /// A black part: colour × coverage is 0 inside and out, so only the coverage term of the
    /// error sees its edge; the polygon still moves onto the render.
    #[test]
    fn a_black_part_s_polygon_moves_onto_its_silhouette() {
        moves_onto_the_part(
            &|mut t| {
                for p in &mut t.px {
                    p[..3].fill(0.0);
                }
                t
            },
            false,
        );
    }

    /// A rectangle's polygon placed under a pixel off its render (`paint` colours both tiles)
    /// ends within half a pixel of it, its redrawn error under a fifth of what it was and, with
    /// `exact`, the tracked error the redrawn one (a black part's edges may end on pixel centres
    /// exactly, which the tracked drawing and the canvas may round apart).
    fn moves_onto_the_part(paint: &dyn Fn(PartTile) -> PartTile, exact: bool) {
        let key = paint(rect_tile(48, 10.0, 10.0, 30.0, 40.0));
        let truth = tile_canvas(&paint(rect_tile(48, 12.0, 9.0, 32.0, 39.0)));
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
        assert!(before > 0.0 && measured < 0.2 * before, "{before} -> {measured}");
        assert!(
            !exact || (measured - after).abs() < 1e-6 * before.max(1.0),
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

    /// A small deterministic generator (no dependency for three tests).
    fn lcg(state: &mut u64) -> f32 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    /// The row spans visit every pixel the per-pixel test covers (brute force over the
    /// whole box), on random triangles: long and thin ones, nearly horizontal and vertical
    /// edges, tiny and degenerate ones.
    #[test]
    fn row_spans_miss_no_covered_pixel() {
        let size = 64i64;
        let mut state = 7u64;
        for n in 0..4000 {
            let mut p = [[0.0f32; 2]; 3];
            for q in &mut p {
                *q = [lcg(&mut state) * 70.0 - 3.0, lcg(&mut state) * 70.0 - 3.0];
            }
            match n % 5 {
                // Nearly horizontal edge.
                1 => p[1][1] = p[0][1] + 1e-4 * lcg(&mut state),
                // Nearly vertical edge.
                2 => p[1][0] = p[0][0] + 1e-4 * lcg(&mut state),
                // A sliver.
                3 => {
                    p[2] = [
                        p[0][0] + 0.3 * (p[1][0] - p[0][0]),
                        p[0][1] + 0.3 * (p[1][1] - p[0][1]) + 0.05,
                    ]
                }
                // Degenerate.
                4 if n % 10 == 4 => p[2] = p[1],
                _ => {}
            }
            let t = Placed::new(p, p);
            let r: PixelBox = [0, 0, size, size];
            let c = clip(&t, r);
            let mut brute = Vec::new();
            for y in c[1].max(0)..c[3] {
                for x in c[0].max(0)..c[2] {
                    if t.cover(x as f32 + 0.5, y as f32 + 0.5).is_some() {
                        brute.push((y * size + x) as usize);
                    }
                }
            }
            let mut spans = Vec::new();
            t.each_pixel_near(c, size, |at, px, py| {
                if t.covers(px, py) {
                    spans.push(at);
                }
            });
            assert_eq!(spans, brute, "triangle {p:?}");
        }
    }

    /// The SSE texel is the channel-by-channel bilinear blend and division, bit for bit, and
    /// the floor without the library call is `f32::floor`.
    #[test]
    fn the_texel_is_the_scalar_blend_and_floor_is_floor() {
        let mut state = 11u64;
        for _ in 0..20000 {
            let taps: [[f32; 4]; 4] = std::array::from_fn(|_| {
                let a = lcg(&mut state);
                [lcg(&mut state) * a, lcg(&mut state) * a, lcg(&mut state) * a, a]
            });
            let (tx, ty) = (lcg(&mut state), lcg(&mut state));
            let [a, b, c, d] = taps;
            let o: [f32; 4] = std::array::from_fn(|k| {
                let top = a[k] + (b[k] - a[k]) * tx;
                let bottom = c[k] + (d[k] - c[k]) * tx;
                top + (bottom - top) * ty
            });
            let want =
                (o[3] >= crate::bake::raster::ALPHA_CUTOFF).then(|| [o[0] / o[3], o[1] / o[3], o[2] / o[3], 1.0]);
            let got = texel_of(taps, tx, ty);
            assert_eq!(
                got.map(|v| v.map(f32::to_bits)),
                want.map(|v| v.map(f32::to_bits)),
                "{taps:?} at {tx} {ty}"
            );
            let x = (lcg(&mut state) - 0.5) * 600.0;
            assert_eq!(floor(x), x.floor(), "{x}");
        }
        for x in [-1.0f32, -0.5, -0.0, 0.0, 0.5, 1.0, 127.999, -127.999, 1e7, -1e7] {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
        assert!(floor(f32::NAN) == 0.0);
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
