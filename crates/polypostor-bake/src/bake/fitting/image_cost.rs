//! The fitting error: SSD between the source texture (colour + normal + coverage), sampled at
//! fixed barycentric points of each source triangle, and the target image at the affinely
//! mapped points.

/// One image of a part at one frame: colour, normal and coverage per pixel, as floats.
#[derive(Clone, Debug)]
pub struct PartTile {
    pub size: u32,
    /// Per pixel: r, g, b (sRGB-encoded 0..1), normal x, y, z (encoded 0..1), coverage.
    pub px: Vec<[f32; 7]>,
}

/// Channels' weights in the SSD (coverage counts most: mapping a triangle onto the
/// background is the worst error).
pub const CHANNEL_WEIGHTS: [f32; 7] = [1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 2.0];

impl PartTile {
    /// From a colour and a normal image of the same size (normal alpha = coverage).
    pub fn from_images(color: &image::RgbaImage, normal: &image::RgbaImage) -> Self {
        let size = color.width();
        let px = color
            .pixels()
            .zip(normal.pixels())
            .map(|(c, n)| {
                let a = n[3] as f32 / 255.0;
                [
                    c[0] as f32 / 255.0 * a,
                    c[1] as f32 / 255.0 * a,
                    c[2] as f32 / 255.0 * a,
                    n[0] as f32 / 255.0 * a,
                    n[1] as f32 / 255.0 * a,
                    n[2] as f32 / 255.0 * a,
                    a,
                ]
            })
            .collect();
        Self { size, px }
    }

    /// The coverage mask.
    pub fn mask(&self) -> crate::bake::contour::Mask {
        crate::bake::contour::Mask {
            width: self.size as usize,
            height: self.size as usize,
            data: self.px.iter().map(|p| p[6] > 0.5).collect(),
        }
    }

    /// Bilinear sample at pixel coordinates (pixel centres at `i + 0.5`); zero outside.
    pub fn sample(&self, x: f32, y: f32) -> [f32; 7] {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let s = self.size as i64;
        let get = |x: i64, y: i64| -> [f32; 7] {
            if x < 0 || y < 0 || x >= s || y >= s {
                [0.0; 7]
            } else {
                self.px[(y * s + x) as usize]
            }
        };
        let (a, b, c, d) = (get(x0, y0), get(x0 + 1, y0), get(x0, y0 + 1), get(x0 + 1, y0 + 1));
        let mut out = [0.0; 7];
        for k in 0..7 {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bottom = c[k] + (d[k] - c[k]) * tx;
            out[k] = top + (bottom - top) * ty;
        }
        out
    }
}

/// The fixed barycentric sample points of a triangle.
pub const SAMPLES: [[f32; 3]; 10] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.6, 0.2, 0.2],
    [0.2, 0.6, 0.2],
    [0.2, 0.2, 0.6],
    [0.45, 0.45, 0.1],
    [0.1, 0.45, 0.45],
    [0.45, 0.1, 0.45],
    [0.8, 0.1, 0.1],
    [0.1, 0.8, 0.1],
    [0.1, 0.1, 0.8],
];

/// A target tile laid out for fast sampling: a one-pixel zero border (so bilinear
/// taps need no bounds tests), channels pre-scaled by the square roots of
/// [`CHANNEL_WEIGHTS`] (so the weighted SSD is a plain sum of squares) and padded to 8 lanes.
pub struct TargetGrid {
    stride: usize,
    px: Vec<[Vec4; 2]>,
    /// The target outline's missed-coverage table, when the objective charges it.
    missed: Option<MissedCoverage>,
}

use glam::Vec4;

fn lanes(p: [f32; 8]) -> [Vec4; 2] {
    [Vec4::new(p[0], p[1], p[2], p[3]), Vec4::new(p[4], p[5], p[6], p[7])]
}

fn weighted(p: [f32; 7]) -> [f32; 8] {
    let mut o = [0.0; 8];
    for c in 0..7 {
        o[c] = p[c] * CHANNEL_WEIGHTS[c].sqrt();
    }
    o
}

impl TargetGrid {
    pub fn new(tile: &PartTile) -> Self {
        let s = tile.size as usize;
        let stride = s + 2;
        let mut px = vec![[Vec4::ZERO; 2]; stride * stride];
        for y in 0..s {
            for x in 0..s {
                px[(y + 1) * stride + x + 1] = lanes(weighted(tile.px[y * s + x]));
            }
        }
        Self {
            stride,
            px,
            missed: None,
        }
    }

    /// The grid of a target whose outline is `outline` (the polygon the fit maps onto), with
    /// the table that charges target coverage the mapped polygon leaves out
    /// ([`MissedCoverage`]).
    pub fn with_outline(tile: &PartTile, outline: &[[f32; 2]]) -> Self {
        let mut g = Self::new(tile);
        g.missed = Some(MissedCoverage::new(tile, outline));
        g
    }

    /// Bilinear sample at pixel coordinates of the tile (as [`PartTile::sample`], weighted).
    pub fn sample(&self, x: f32, y: f32) -> [f32; 8] {
        let [a, b] = self.sample_lanes(x, y);
        let (a, b) = (a.to_array(), b.to_array());
        [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
    }

    #[inline]
    fn sample_lanes(&self, x: f32, y: f32) -> [Vec4; 2] {
        // Padded coordinates: pixel i of the tile is cell i + 1, its centre at i + 1.5.
        // Far outside, the clamp lands on the zero border exactly (t = 0 or 1).
        let max = (self.stride - 1) as f32;
        let fx = (x + 0.5).clamp(0.0, max);
        let fy = (y + 0.5).clamp(0.0, max);
        let (x0, y0) = ((fx as usize).min(self.stride - 2), (fy as usize).min(self.stride - 2));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let i = y0 * self.stride + x0;
        let rows = &self.px[i..i + self.stride + 2];
        let (a, b, c, d) = (rows[0], rows[1], rows[self.stride], rows[self.stride + 1]);
        let mut out = [Vec4::ZERO; 2];
        for k in 0..2 {
            let top = a[k] + (b[k] - a[k]) * tx;
            let bottom = c[k] + (d[k] - c[k]) * tx;
            out[k] = top + (bottom - top) * ty;
        }
        out
    }
}

/// How far (in square pixels) a target triangle may turn inside out and still count as
/// degenerate rather than folded.
pub const FOLD_TOLERANCE: f32 = 0.5;

/// Cost of a folded triangle when folds are forbidden: larger than any sum of real errors
/// (those are at most a few units per square pixel of the tile), finite so that a candidate
/// set with no fold-free choice still has a solution.
pub const FOLD_COST: f64 = 1e12;

/// Source texture values at the sample points of every source triangle, and the weight of
/// each triangle (its area in pixels, so the error is an integral over the source).
pub struct SourceSamples {
    values: Vec<[[Vec4; 2]; SAMPLES.len()]>,
    weights: Vec<f64>,
    /// Sign of each source triangle's signed area (+1, -1, or 0 when degenerate).
    orientation: Vec<f32>,
    /// Per triangle: its edges on the source polygon's outline, as pairs of corner slots
    /// (0..3) in outline order (from vertex `i` to vertex `i + 1`).
    outline_edges: Vec<Vec<(usize, usize)>>,
}

impl SourceSamples {
    /// `fold_free`: a mapping that turns a triangle inside out (its target has the opposite
    /// orientation beyond [`FOLD_TOLERANCE`]) costs [`FOLD_COST`]; degenerate targets are
    /// still allowed, as in the paper.
    pub fn new(key: &PartTile, vertices: &[[f32; 2]], triangles: &[[usize; 3]], fold_free: bool) -> Self {
        let mut values = Vec::with_capacity(triangles.len());
        let mut weights = Vec::with_capacity(triangles.len());
        let mut orientation = Vec::with_capacity(triangles.len());
        let n = vertices.len();
        let outline_edges = triangles
            .iter()
            .map(|t| {
                let mut e = Vec::new();
                for (u, v) in [(0, 1), (1, 2), (2, 0), (1, 0), (2, 1), (0, 2)] {
                    if n >= 3 && t[v] == (t[u] + 1) % n {
                        e.push((u, v));
                    }
                }
                e
            })
            .collect();
        for t in triangles {
            let [a, b, c] = t.map(|i| vertices[i]);
            let mut v = [[Vec4::ZERO; 2]; SAMPLES.len()];
            for (k, w) in SAMPLES.iter().enumerate() {
                let x = w[0] * a[0] + w[1] * b[0] + w[2] * c[0];
                let y = w[0] * a[1] + w[1] * b[1] + w[2] * c[1];
                v[k] = lanes(weighted(key.sample(x, y)));
            }
            values.push(v);
            let signed = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
            orientation.push(if !fold_free || signed == 0.0 {
                0.0
            } else {
                signed.signum()
            });
            weights.push((signed.abs() as f64).max(0.5));
        }
        Self {
            values,
            weights,
            orientation,
            outline_edges,
        }
    }

    /// Area of the source polygon in pixels (the sum of the triangle weights).
    pub fn area(&self) -> f64 {
        self.weights.iter().sum()
    }

    /// Error of mapping source triangle `t` onto the target vertices `p` of `outline` (the
    /// target polygon `target` was made for): [`SourceSamples::cost_bounded`] plus, when the
    /// grid has a [`MissedCoverage`] table, the target coverage cut off by the triangle's
    /// outline edges. Gives up (infinity) once the sum reaches `limit`.
    #[inline]
    pub fn cost_indexed(&self, t: usize, target: &TargetGrid, outline: &[[f32; 2]], p: [usize; 3], limit: f64) -> f64 {
        let mut missed = 0.0;
        if let Some(table) = &target.missed {
            for &(u, v) in &self.outline_edges[t] {
                missed += table.get(p[u], p[v]);
            }
            if missed >= limit {
                return f64::INFINITY;
            }
        }
        let c = self.cost_bounded(t, target, p.map(|j| outline[j]), limit - missed);
        if c.is_finite() { c + missed } else { c }
    }

    /// Whether mapping source triangle `t` onto target vertices `p` of `outline` turns it
    /// inside out (costs [`FOLD_COST`] when folds are forbidden): a few multiplications, no
    /// sampling.
    #[inline]
    pub fn folds(&self, t: usize, outline: &[[f32; 2]], p: [usize; 3]) -> bool {
        let [a, b, c] = p.map(|j| outline[j]);
        let signed = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]));
        signed * self.orientation[t] < -FOLD_TOLERANCE
    }

    /// Error of mapping source triangle `t` onto the target triangle with corners `p`.
    pub fn cost(&self, t: usize, target: &TargetGrid, p: [[f32; 2]; 3]) -> f64 {
        self.cost_bounded(t, target, p, f64::INFINITY)
    }

    /// [`SourceSamples::cost`], giving up (returning infinity) as soon as the partial sum
    /// reaches `limit`; exact whenever the result is below `limit`.
    #[inline]
    pub fn cost_bounded(&self, t: usize, target: &TargetGrid, p: [[f32; 2]; 3], limit: f64) -> f64 {
        // Orientation: 0 when folds are allowed, so this never fires.
        let signed = 0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]));
        if signed * self.orientation[t] < -FOLD_TOLERANCE {
            return if FOLD_COST < limit { FOLD_COST } else { f64::INFINITY };
        }
        let scale = self.weights[t] / SAMPLES.len() as f64;
        let ssd_limit = (limit / scale) as f32;
        let ssd = self.ssd(t, target, p, ssd_limit);
        if ssd >= ssd_limit {
            f64::INFINITY
        } else {
            scale * ssd as f64
        }
    }

    /// The weighted sum of squared differences of triangle `t`'s samples mapped onto `p`, or
    /// any value `>= ssd_limit` once it reaches that: with AVX where the CPU has it, else
    /// portable; both give the same bits.
    #[inline]
    fn ssd(&self, t: usize, target: &TargetGrid, p: [[f32; 2]; 3], ssd_limit: f32) -> f32 {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above).
            return unsafe { self.ssd_avx(t, target, p, ssd_limit) };
        }
        self.ssd_portable(t, target, p, ssd_limit)
    }

    fn ssd_portable(&self, t: usize, target: &TargetGrid, p: [[f32; 2]; 3], ssd_limit: f32) -> f32 {
        let mut acc = Vec4::ZERO;
        let mut ssd = 0.0f32;
        for (k, w) in SAMPLES.iter().enumerate() {
            let x = w[0] * p[0][0] + w[1] * p[1][0] + w[2] * p[2][0];
            let y = w[0] * p[0][1] + w[1] * p[1][1] + w[2] * p[2][1];
            let [s0, s1] = target.sample_lanes(x, y);
            let [v0, v1] = self.values[t][k];
            let (d0, d1) = (s0 - v0, s1 - v1);
            acc += d0 * d0 + d1 * d1;
            ssd = acc.element_sum();
            if ssd >= ssd_limit {
                return ssd;
            }
        }
        ssd
    }
}

impl SourceSamples {
    /// The sum of squares of [`SourceSamples::cost_bounded`] with 8-lane AVX arithmetic: the
    /// same operations lane by lane in the same order (no fused multiply-add; the two halves
    /// folded before accumulating, the horizontal sum as glam's), so the result is
    /// bit-identical to the portable path. Returns a value `>= ssd_limit` as soon as the
    /// partial sum reaches it (checked every few samples: the partial sums only grow).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn ssd_avx(&self, t: usize, target: &TargetGrid, p: [[f32; 2]; 3], ssd_limit: f32) -> f32 {
        use std::arch::x86_64::*;
        let hsum = |v: __m128| -> f32 {
            let v = _mm_add_ps(v, _mm_shuffle_ps(v, v, 0b00_11_00_01));
            let v = _mm_add_ps(v, _mm_shuffle_ps(v, v, 0b00_00_00_10));
            _mm_cvtss_f32(v)
        };
        let values = &self.values[t];
        let stride = target.stride;
        let max = (stride - 1) as f32;
        let px = target.px.as_ptr() as *const f32;
        let mut acc = _mm_setzero_ps();
        for (k, w) in SAMPLES.iter().enumerate() {
            let x = w[0] * p[0][0] + w[1] * p[1][0] + w[2] * p[2][0];
            let y = w[0] * p[0][1] + w[1] * p[1][1] + w[2] * p[2][1];
            // As `TargetGrid::sample_lanes`.
            let fx = (x + 0.5).clamp(0.0, max);
            let fy = (y + 0.5).clamp(0.0, max);
            let (x0, y0) = ((fx as usize).min(stride - 2), (fy as usize).min(stride - 2));
            let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
            let i = y0 * stride + x0;
            debug_assert!(i + stride + 1 < target.px.len());
            // SAFETY: x0, y0 <= stride - 2, so cells i, i + 1, i + stride and i + stride + 1
            // lie in the stride × stride grid; each cell is 8 contiguous f32.
            let (a, b, c, d) = unsafe {
                (
                    _mm256_loadu_ps(px.add(i * 8)),
                    _mm256_loadu_ps(px.add((i + 1) * 8)),
                    _mm256_loadu_ps(px.add((i + stride) * 8)),
                    _mm256_loadu_ps(px.add((i + stride + 1) * 8)),
                )
            };
            let (txv, tyv) = (_mm256_set1_ps(tx), _mm256_set1_ps(ty));
            let top = _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), txv));
            let bottom = _mm256_add_ps(c, _mm256_mul_ps(_mm256_sub_ps(d, c), txv));
            let s = _mm256_add_ps(top, _mm256_mul_ps(_mm256_sub_ps(bottom, top), tyv));
            // SAFETY: values[k] is two Vec4s, 8 contiguous f32.
            let v = unsafe { _mm256_loadu_ps(values[k].as_ptr() as *const f32) };
            let dd = _mm256_sub_ps(s, v);
            let sq = _mm256_mul_ps(dd, dd);
            acc = _mm_add_ps(
                acc,
                _mm_add_ps(_mm256_castps256_ps128(sq), _mm256_extractf128_ps::<1>(sq)),
            );
            if k % 3 == 2 {
                let ssd = hsum(acc);
                if ssd >= ssd_limit {
                    return ssd;
                }
            }
        }
        hsum(acc)
    }
}

/// What the fit's colour + normal + coverage SSD, sampled on the source, cannot see: target
/// coverage the mapped polygon leaves out.
///
/// The fit maps every source vertex onto a target outline vertex, so the mapped polygon's
/// outline is a chain of chords of the target outline. A source outline edge mapped from
/// target vertex `j` to `k` cuts off the piece of the target between the chord and the
/// outline from `j` forward to `k`; where that piece lies inside the target, its pixels are
/// left uncovered. `get(j, k)` is the target's energy in that piece (the sum over its pixels
/// of the squared, channel-weighted target value: what drawing nothing there costs in the
/// same units as the SSD), 0 where the piece lies outside. The pieces of all outline edges
/// of a fit that goes once round the outline, forwards, are disjoint and together make up
/// what it leaves out, so the table turns "target coverage missed" into a sum over source
/// outline edges: per triangle, and the DP stays exact.
///
/// Integrals are by the trapezoid rule over pixel columns of a per-column prefix sum, so a
/// piece costs O(its width); the table is `m²` entries.
#[derive(Clone, Debug)]
pub struct MissedCoverage {
    m: usize,
    table: Vec<f32>,
}

impl MissedCoverage {
    pub fn new(tile: &PartTile, outline: &[[f32; 2]]) -> Self {
        let m = outline.len();
        let s = tile.size as usize;
        // prefix[x * (s + 1) + y]: energy of column x above row y.
        let mut prefix = vec![0.0f64; s * (s + 1)];
        for x in 0..s {
            for y in 0..s {
                let p = tile.px[y * s + x];
                let e: f64 = (0..7).map(|c| (CHANNEL_WEIGHTS[c] * p[c] * p[c]) as f64).sum();
                prefix[x * (s + 1) + y + 1] = prefix[x * (s + 1) + y] + e;
            }
        }
        // Energy of column x above the continuous height y (pixel y spans [y, y + 1)).
        let above = |x: usize, y: f32| -> f64 {
            let y = y.clamp(0.0, s as f32);
            let yi = (y.floor() as usize).min(s);
            let base = prefix[x * (s + 1) + yi];
            if yi >= s {
                return base;
            }
            let next = prefix[x * (s + 1) + yi + 1];
            base + (next - base) * (y - yi as f32) as f64
        };
        // Signed integral for the edge a -> b: the energy above the edge over the columns
        // whose centres it spans, + going right, − going left. Summed round a closed
        // polygon, it is ± the energy inside.
        let edge = |a: [f32; 2], b: [f32; 2]| -> f64 {
            let (x0, x1) = (a[0].min(b[0]), a[0].max(b[0]));
            if x1 - x0 < 1e-6 {
                return 0.0;
            }
            let first = (x0 - 0.5).ceil().max(0.0) as i64;
            let last = ((x1 - 0.5).ceil() as i64 - 1).min(s as i64 - 1);
            let mut sum = 0.0;
            for x in first..=last {
                let cx = x as f32 + 0.5;
                let t = (cx - a[0]) / (b[0] - a[0]);
                sum += above(x as usize, a[1] + t * (b[1] - a[1]));
            }
            if b[0] > a[0] { sum } else { -sum }
        };
        // Orientation: the whole outline's signed integral with energy ≡ area has the sign
        // a piece inside the target gets (`signed_area2` is positive clockwise on screen;
        // this integral of "height above" is then negative).
        let sign = if crate::bake::contour::signed_area2(outline) >= 0.0 {
            -1.0
        } else {
            1.0
        };
        // Running sums of the outline edges from vertex 0.
        let mut along = vec![0.0f64; m + 1];
        for i in 0..m {
            along[i + 1] = along[i] + edge(outline[i], outline[(i + 1) % m]);
        }
        let mut table = vec![0.0f32; m * m];
        for j in 0..m {
            for k in 0..m {
                if j == k {
                    continue;
                }
                let chain = if k > j {
                    along[k] - along[j]
                } else {
                    along[m] - along[j] + along[k]
                };
                let piece = sign * (chain + edge(outline[k], outline[j]));
                table[j * m + k] = piece.max(0.0) as f32;
            }
        }
        Self { m, table }
    }

    /// Target energy cut off by a source outline edge mapped from target vertex `j` to `k`.
    #[inline]
    pub fn get(&self, j: usize, k: usize) -> f64 {
        self.table[j * self.m + k] as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A brute-force answer: the target energy inside the polygon, each pixel's energy
    /// weighted by the share of its 8 × 8 sub-samples inside (even-odd rule).
    fn energy_inside(tile: &PartTile, poly: &[[f32; 2]]) -> f64 {
        let s = tile.size as usize;
        let mut sum = 0.0;
        for y in 0..s {
            for x in 0..s {
                let p = tile.px[y * s + x];
                let e = (0..7).map(|c| (CHANNEL_WEIGHTS[c] * p[c] * p[c]) as f64).sum::<f64>();
                if e == 0.0 {
                    continue;
                }
                let mut hits = 0;
                for sy in 0..8 {
                    for sx in 0..8 {
                        let (px, py) = (x as f32 + (sx as f32 + 0.5) / 8.0, y as f32 + (sy as f32 + 0.5) / 8.0);
                        let mut inside = false;
                        for i in 0..poly.len() {
                            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                            if (a[1] > py) != (b[1] > py) && px < a[0] + (py - a[1]) / (b[1] - a[1]) * (b[0] - a[0]) {
                                inside = !inside;
                            }
                        }
                        hits += inside as u32;
                    }
                }
                sum += e * hits as f64 / 64.0;
            }
        }
        sum
    }

    #[test]
    fn missed_coverage_is_the_energy_of_the_cut_off_piece() {
        // A textured disc (radius 26 in a 64-pixel tile); its outline clockwise on screen,
        // then reversed.
        let size = 64u32;
        let t = PartTile {
            size,
            px: (0..size * size)
                .map(|i| {
                    let (dx, dy) = ((i % size) as f32 + 0.5 - 32.0, (i / size) as f32 + 0.5 - 32.0);
                    if dx * dx + dy * dy < 26.0 * 26.0 {
                        [0.3 + dx / 80.0, 0.5, 0.2, 0.5, 0.5, 1.0, 1.0]
                    } else {
                        [0.0; 7]
                    }
                })
                .collect(),
        };
        let ring: Vec<[f32; 2]> = (0..12)
            .map(|i| {
                let a = i as f32 / 12.0 * std::f32::consts::TAU;
                [32.0 + 26.0 * a.cos(), 32.0 + 26.0 * a.sin()]
            })
            .collect();
        for outline in [ring.clone(), ring.iter().rev().copied().collect::<Vec<_>>()] {
            let table = MissedCoverage::new(&t, &outline);
            let m = outline.len();
            for (j, k) in [(0, 3), (2, 7), (10, 1), (5, 6), (11, 5)] {
                // The piece: outline from j forward to k, closed by the chord.
                let mut piece = Vec::new();
                let mut i = j;
                loop {
                    piece.push(outline[i]);
                    if i == k {
                        break;
                    }
                    i = (i + 1) % m;
                }
                let want = energy_inside(&t, &piece);
                let got = table.get(j, k);
                assert!(
                    (got - want).abs() <= 0.02 * want.max(1.0) + 2.0,
                    "({j}, {k}): {got} vs {want}"
                );
            }
            // A chord between neighbours cuts off (almost) nothing; going all the way round
            // but one step cuts off (almost) everything.
            assert!(table.get(0, 1) < 0.02 * energy_inside(&t, &outline));
            let all = energy_inside(&t, &outline);
            assert!(table.get(1, 0) > 0.8 * all, "{} vs {all}", table.get(1, 0));
        }
    }

    #[test]
    fn the_indexed_cost_adds_the_cut_off_coverage_of_outline_edges_only() {
        let t = tile(|x, y| [x as f32 / 16.0, y as f32 / 16.0, 0.5, 0.5, 0.5, 1.0, 1.0]);
        // Source: a quad split into two triangles; outline edges 0-1, 1-2 (triangle 0) and
        // 2-3, 3-0 (triangle 1); the diagonal 0-2 is inside.
        let verts = [[2.0, 2.0], [14.0, 2.0], [14.0, 14.0], [2.0, 14.0]];
        let tris = [[0, 1, 2], [0, 2, 3]];
        let s = SourceSamples::new(&t, &verts, &tris, false);
        assert_eq!(s.outline_edges[0].len(), 2);
        assert_eq!(s.outline_edges[1].len(), 2);
        let target: Vec<[f32; 2]> = vec![[2.0, 2.0], [8.0, 1.0], [14.0, 2.0], [14.0, 14.0], [2.0, 14.0]];
        let plain = TargetGrid::new(&t);
        let charged = TargetGrid::with_outline(&t, &target);
        // Triangle 0 mapped to target vertices 0, 2, 3: the edge 0 -> 2 skips vertex 1.
        let p = [0, 2, 3];
        let base = s.cost_indexed(0, &plain, &target, p, f64::INFINITY);
        let with = s.cost_indexed(0, &charged, &target, p, f64::INFINITY);
        let table = MissedCoverage::new(&t, &target);
        let expect = table.get(0, 2) + table.get(2, 3);
        assert!(expect > 0.0);
        assert!(
            (with - base - expect).abs() < 1e-6 * with.max(1.0),
            "{with} {base} {expect}"
        );
        // Bounded: gives up below the missed part alone.
        assert_eq!(s.cost_indexed(0, &charged, &target, p, expect * 0.5), f64::INFINITY);
    }

    fn tile(f: impl Fn(u32, u32) -> [f32; 7]) -> PartTile {
        let size = 16;
        PartTile {
            size,
            px: (0..size * size).map(|i| f(i % size, i / size)).collect(),
        }
    }

    #[test]
    fn identity_mapping_costs_nothing_and_a_shift_costs_something() {
        let t = tile(|x, y| [x as f32 / 16.0, y as f32 / 16.0, 0.5, 0.5, 0.5, 1.0, 1.0]);
        let verts = [[3.0, 3.0], [12.0, 4.0], [6.0, 12.0]];
        let s = SourceSamples::new(&t, &verts, &[[0, 1, 2]], false);
        let g = TargetGrid::new(&t);
        assert!(s.cost(0, &g, verts) < 1e-9);
        let shifted = verts.map(|p| [p[0] + 2.0, p[1]]);
        assert!(s.cost(0, &g, shifted) > 1e-3);
        // Off the image entirely: coverage mismatch dominates.
        let away = verts.map(|p| [p[0] + 40.0, p[1]]);
        assert!(s.cost(0, &g, away) > s.cost(0, &g, shifted));
        // The bounded cost is exact below its limit and gives up above it.
        let c = s.cost(0, &g, shifted);
        assert_eq!(s.cost_bounded(0, &g, shifted, c * 1.01), c);
        assert!(s.cost_bounded(0, &g, shifted, c * 0.99) >= c * 0.99);
    }

    #[test]
    fn a_folded_target_costs_the_fold_penalty_only_when_folds_are_forbidden() {
        let t = tile(|x, y| [x as f32 / 16.0, y as f32 / 16.0, 0.5, 0.5, 0.5, 1.0, 1.0]);
        let verts = [[3.0, 3.0], [12.0, 4.0], [6.0, 12.0]];
        let g = TargetGrid::new(&t);
        let strict = SourceSamples::new(&t, &verts, &[[0, 1, 2]], true);
        let loose = SourceSamples::new(&t, &verts, &[[0, 1, 2]], false);
        // Mirrored across the vertical line x = 8: same shape, opposite orientation.
        let mirrored = verts.map(|p| [16.0 - p[0], p[1]]);
        assert_eq!(strict.cost(0, &g, mirrored), FOLD_COST);
        assert!(loose.cost(0, &g, mirrored) < 1e3);
        // Above the limit the penalty gives up like any other cost.
        assert_eq!(strict.cost_bounded(0, &g, mirrored, 1.0), f64::INFINITY);
        // Same orientation, or degenerate (a point, a segment): the ordinary error.
        let shifted = verts.map(|p| [p[0] + 1.0, p[1]]);
        assert_eq!(strict.cost(0, &g, shifted), loose.cost(0, &g, shifted));
        for degenerate in [[verts[0]; 3], [verts[0], verts[1], verts[0]]] {
            assert!(strict.cost(0, &g, degenerate) < 1e3);
            assert_eq!(strict.cost(0, &g, degenerate), loose.cost(0, &g, degenerate));
        }
        // The test is on orientation, not on the order the source happens to use.
        let reversed = [verts[0], verts[2], verts[1]];
        let strict_rev = SourceSamples::new(&t, &reversed, &[[0, 1, 2]], true);
        assert!(strict_rev.cost(0, &g, reversed) < 1e-9);
        assert_eq!(
            strict_rev.cost(0, &g, [mirrored[0], mirrored[2], mirrored[1]]),
            FOLD_COST
        );
    }

    #[test]
    fn bilinear_sampling_is_exact_at_pixel_centres_and_linear_between() {
        let t = tile(|x, _| [x as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        assert_eq!(t.sample(3.5, 7.5)[0], 3.0);
        assert!((t.sample(4.0, 7.5)[0] - 3.5).abs() < 1e-6);
        assert_eq!(t.sample(-5.0, 2.0), [0.0; 7]);
    }

    #[test]
    fn the_vector_path_gives_the_portable_paths_bits() {
        // A textured target and source with every channel varying, triangles anywhere (in,
        // across the border, far outside), limits from none to tight.
        let target = tile(|x, y| {
            let f = |k: u32| (((x * 7 + y * 13 + k * 29) % 97) as f32) / 97.0;
            [
                f(0),
                f(1),
                f(2),
                f(3),
                f(4),
                f(5),
                if (x + y) % 11 < 8 { 1.0 } else { 0.3 },
            ]
        });
        let source = tile(|x, y| {
            let f = |k: u32| (((x * 5 + y * 3 + k * 17) % 89) as f32) / 89.0;
            [f(0), f(1), f(2), f(3), f(4), f(5), 1.0]
        });
        let grid = TargetGrid::new(&target);
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) as f32 / (1u64 << 31) as f32) * 28.0 - 6.0
        };
        let vertices: Vec<[f32; 2]> = (0..6).map(|_| [next().abs(), next().abs()]).collect();
        let triangles = [[0, 1, 2], [2, 3, 4], [4, 5, 0], [1, 3, 5]];
        let samples = SourceSamples::new(&source, &vertices, &triangles, false);
        let mut exits = 0;
        for _ in 0..2000 {
            let p = [[next(), next()], [next(), next()], [next(), next()]];
            for t in 0..triangles.len() {
                for limit in [f32::INFINITY, 40.0, 5.0, 0.5] {
                    let a = samples.ssd(t, &grid, p, limit);
                    let b = samples.ssd_portable(t, &grid, p, limit);
                    if b >= limit {
                        assert!(a >= limit, "the vector path missed the limit: {a} vs {b}");
                        exits += 1;
                    } else {
                        assert_eq!(a.to_bits(), b.to_bits(), "triangle {t} onto {p:?}: {a} vs {b}");
                    }
                }
            }
        }
        assert!(exits > 100 && exits < 2000 * 4 * 4, "limits reached {exits} times");
    }

    #[test]
    fn the_padded_grid_samples_like_the_tile() {
        let t = tile(|x, y| {
            let v = ((x * 7 + y * 13) % 11) as f32 / 11.0;
            [v, 1.0 - v, 0.3, v * 0.5, 0.2, 0.9, 1.0]
        });
        let g = TargetGrid::new(&t);
        for &(x, y) in &[
            (0.0, 0.0),
            (0.5, 0.5),
            (3.3, 7.9),
            (15.9, 16.0),
            (16.0, 0.2),
            (-3.0, 5.0),
            (40.0, 40.0),
        ] {
            let a = weighted(t.sample(x, y));
            let b = g.sample(x, y);
            for k in 0..8 {
                assert!((a[k] - b[k]).abs() < 1e-4, "({x}, {y}) lane {k}: {} vs {}", a[k], b[k]);
            }
        }
    }
}
