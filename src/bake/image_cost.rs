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
    pub fn mask(&self) -> super::contour::Mask {
        super::contour::Mask {
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
        Self { stride, px }
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
}

impl SourceSamples {
    /// `fold_free`: a mapping that turns a triangle inside out (its target has the opposite
    /// orientation beyond [`FOLD_TOLERANCE`]) costs [`FOLD_COST`]; degenerate targets are
    /// still allowed, as in the paper.
    pub fn new(key: &PartTile, vertices: &[[f32; 2]], triangles: &[[usize; 3]], fold_free: bool) -> Self {
        let mut values = Vec::with_capacity(triangles.len());
        let mut weights = Vec::with_capacity(triangles.len());
        let mut orientation = Vec::with_capacity(triangles.len());
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
        }
    }

    /// Area of the source polygon in pixels (the sum of the triangle weights).
    pub fn area(&self) -> f64 {
        self.weights.iter().sum()
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
                return f64::INFINITY;
            }
        }
        scale * ssd as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
