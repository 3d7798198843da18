//! A small CPU rasteriser for polypostors: textured 2D triangles drawn in order over an
//! image (painter's algorithm), used to measure the fit error against the ground truth and
//! to draw debug images. Pixel centres at `i + 0.5`; a pixel is covered when its centre is
//! inside the triangle (top-left rule not needed for error statistics).

use crate::bake::image_cost::PartTile;

/// Coverage below which a sampled texel is not drawn (the shaders' alpha test).
pub const ALPHA_CUTOFF: f32 = 0.5;

/// An RGBA float image (colour in 0..1, alpha = coverage).
#[derive(Clone, Debug, PartialEq)]
pub struct Canvas {
    pub size: u32,
    pub px: Vec<[f32; 4]>,
}

impl Canvas {
    pub fn new(size: u32) -> Self {
        Self {
            size,
            px: vec![[0.0; 4]; (size * size) as usize],
        }
    }

    /// Draws triangle `pos` textured from `texture` at `uv` (both in pixels).
    pub fn draw_textured(&mut self, pos: [[f32; 2]; 3], uv: [[f32; 2]; 3], texture: &PartTile) {
        self.draw_textured_where(pos, uv, texture, &|_, _| true);
    }

    /// [`Canvas::draw_textured`] on the pixels `keep(x, y)` accepts (a cross-fade's share).
    pub fn draw_textured_where(
        &mut self,
        pos: [[f32; 2]; 3],
        uv: [[f32; 2]; 3],
        texture: &PartTile,
        keep: &dyn Fn(u32, u32) -> bool,
    ) {
        let n = self.size as i64;
        self.draw_clipped(pos, uv, texture, keep, [0, 0, n, n]);
    }

    /// [`Canvas::draw_textured`] on the pixels of the box `[x0, x1) × [y0, y1)` only.
    pub fn draw_textured_in(&mut self, pos: [[f32; 2]; 3], uv: [[f32; 2]; 3], texture: &PartTile, clip: [i64; 4]) {
        self.draw_clipped(pos, uv, texture, &|_, _| true, clip);
    }

    fn draw_clipped(
        &mut self,
        pos: [[f32; 2]; 3],
        uv: [[f32; 2]; 3],
        texture: &PartTile,
        keep: &dyn Fn(u32, u32) -> bool,
        clip: [i64; 4],
    ) {
        let area =
            (pos[1][0] - pos[0][0]) * (pos[2][1] - pos[0][1]) - (pos[1][1] - pos[0][1]) * (pos[2][0] - pos[0][0]);
        if area.abs() < 1e-9 {
            return;
        }
        let min_x = pos.iter().map(|p| p[0]).fold(f32::INFINITY, f32::min).floor().max(0.0) as i64;
        let max_x = pos
            .iter()
            .map(|p| p[0])
            .fold(f32::NEG_INFINITY, f32::max)
            .ceil()
            .min(self.size as f32) as i64;
        let min_y = pos.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min).floor().max(0.0) as i64;
        let max_y = pos
            .iter()
            .map(|p| p[1])
            .fold(f32::NEG_INFINITY, f32::max)
            .ceil()
            .min(self.size as f32) as i64;
        let (min_x, max_x) = (min_x.max(clip[0]), max_x.min(clip[2]));
        let (min_y, max_y) = (min_y.max(clip[1]), max_y.min(clip[3]));
        for y in min_y..max_y {
            for x in min_x..max_x {
                if !keep(x as u32, y as u32) {
                    continue;
                }
                // Each corner's weight from its own edge function, in f64 (exact for the
                // whole and half pixels polygons often sit on): a pixel centre on an edge two
                // triangles share is drawn by both, never by neither (a weight found as
                // 1 - w0 - w1 could come out a rounding below zero in both, leaving a line of
                // undrawn pixels across a part).
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let edge = |a: [f32; 2], b: [f32; 2]| {
                    let (a, b) = ([a[0] as f64, a[1] as f64], [b[0] as f64, b[1] as f64]);
                    (a[0] - px) * (b[1] - py) - (a[1] - py) * (b[0] - px)
                };
                let area = {
                    let q = pos.map(|p| [p[0] as f64, p[1] as f64]);
                    (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0])
                };
                let (w0, w1, w2) = (
                    edge(pos[1], pos[2]) / area,
                    edge(pos[2], pos[0]) / area,
                    edge(pos[0], pos[1]) / area,
                );
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let (w0, w1, w2) = (w0 as f32, w1 as f32, w2 as f32);
                let u = w0 * uv[0][0] + w1 * uv[1][0] + w2 * uv[2][0];
                let v = w0 * uv[0][1] + w1 * uv[1][1] + w2 * uv[2][1];
                let s = texture.sample(u, v);
                // Texture values are premultiplied by coverage; un-premultiply the colour.
                // Texels less than half covered are not drawn, as the run time's shaders
                // discard them (`polypostor.wgsl`): the polygon's outline alone does not
                // decide what shows, the key image's own edge does too.
                let a = s[6];
                if a < ALPHA_CUTOFF {
                    continue;
                }
                self.px[(y as u32 * self.size + x as u32) as usize] = [s[0] / a, s[1] / a, s[2] / a, 1.0];
            }
        }
    }

    /// Root-mean-square colour error against `other` over pixels covered in either image
    /// (uncovered pixels count as black), and the number of such pixels.
    pub fn rmse(&self, other: &Canvas) -> (f64, usize) {
        let mut sum = 0.0f64;
        let mut n = 0usize;
        for (a, b) in self.px.iter().zip(&other.px) {
            if a[3] < 0.5 && b[3] < 0.5 {
                continue;
            }
            n += 1;
            for c in 0..3 {
                let (x, y) = (a[c] * a[3], b[c] * b[3]);
                sum += ((x - y) as f64).powi(2);
            }
        }
        if n == 0 {
            (0.0, 0)
        } else {
            ((sum / (3 * n) as f64).sqrt(), n)
        }
    }

    /// [`crate::metrics::silhouette_iou`] with `other`, a pixel covered when its coverage is
    /// at least a half.
    pub fn silhouette_iou(&self, other: &Canvas) -> f64 {
        crate::metrics::silhouette_iou(self.px.iter().zip(&other.px).map(|(a, b)| (a[3] >= 0.5, b[3] >= 0.5)))
    }

    /// The brightest channel of each covered pixel (coverage at least a half), summed, and the
    /// number of those pixels.
    pub fn brightness(&self) -> (f64, usize) {
        self.px
            .iter()
            .filter(|p| p[3] >= 0.5)
            .fold((0.0, 0), |(s, n), p| (s + p[0].max(p[1]).max(p[2]) as f64, n + 1))
    }

    /// SSIM against `other` over the pixels covered in either image (colour × coverage), as
    /// [`Canvas::rmse`] measures; see [`crate::metrics`]. 1 when neither covers anything.
    pub fn ssim(&self, other: &Canvas) -> f64 {
        let n = self.size as usize;
        if other.size != self.size {
            return 0.0;
        }
        crate::metrics::ssim_rgba_f32(&self.px, &other.px, n, n)
    }

    pub fn to_image(&self) -> image::RgbaImage {
        let mut img = image::RgbaImage::new(self.size, self.size);
        for (p, q) in img.pixels_mut().zip(&self.px) {
            *p = image::Rgba(q.map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8));
        }
        img
    }
}

/// The cross-fade between two key images of a part: the pixel at `(x, y)` shows the key the
/// interval ends with when `crossfade_threshold(x, y) < a` (`a`: how far into the interval),
/// else the key it starts with. An 8×8 ordered-dither (Bayer) matrix, the same in
/// `shaders/crowd_common.wgsl`: no blending order to get right, no background showing through
/// where the two keys overlap, and on average exactly `(1 − a)·first + a·second`. 64 levels
/// rather than 16: a cross-fade lasting more than 16 frames trades an even share of the
/// pixels every frame instead of a sixteenth every other frame (temporal stability).
pub fn crossfade_threshold(x: u32, y: u32) -> f32 {
    (bayer_8x8(x, y) as f32 + 0.5) / 64.0
}

/// The entry of [`BAYER_8X8`] at `(x mod 8, y mod 8)`, computed the way the shaders do: the
/// bits of `x ⊕ y` and `y` interleaved, lowest first (no table: a GPU keeps a dynamically
/// indexed local array in slow per-thread memory, filled anew by every pixel).
pub fn bayer_8x8(x: u32, y: u32) -> u32 {
    let (x, y) = (x & 7, y & 7);
    let z = x ^ y;
    ((z & 1) << 5) | ((y & 1) << 4) | ((z & 2) << 2) | ((y & 2) << 1) | ((z & 4) >> 1) | ((y & 4) >> 2)
}

/// The 8×8 Bayer matrix (row by row): `M₂ₙ = [[4M, 4M + 2], [4M + 3, 4M + 1]]` from `M₁ = [0]`.
pub const BAYER_8X8: [u32; 64] = [
    0, 32, 8, 40, 2, 34, 10, 42, 48, 16, 56, 24, 50, 18, 58, 26, 12, 44, 4, 36, 14, 46, 6, 38, 60, 28, 52, 20, 62, 30,
    54, 22, 3, 35, 11, 43, 1, 33, 9, 41, 51, 19, 59, 27, 49, 17, 57, 25, 15, 47, 7, 39, 13, 45, 5, 37, 63, 31, 55, 23,
    61, 29, 53, 21,
];

/// PSNR in dB for an RMSE on a 0..1 scale (capped at 99 dB for a perfect match).
pub fn psnr(rmse: f64) -> f64 {
    if rmse <= 1e-5 {
        99.0
    } else {
        (20.0 * (1.0 / rmse).log10()).min(99.0)
    }
}

/// A part tile as a canvas (colour un-premultiplied).
pub fn tile_canvas(tile: &PartTile) -> Canvas {
    Canvas {
        size: tile.size,
        px: tile
            .px
            .iter()
            .map(|p| {
                if p[6] > 1e-3 {
                    [p[0] / p[6], p[1] / p[6], p[2] / p[6], p[6]]
                } else {
                    [0.0; 4]
                }
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Silhouette agreement and brightness by hand on 4 × 4 canvases: a black pixel that
    /// PSNR cannot see (black against the black background) halves the agreement.
    #[test]
    fn the_silhouette_sees_what_colour_against_black_does_not() {
        let mut a = Canvas::new(4);
        let mut b = Canvas::new(4);
        assert_eq!(a.silhouette_iou(&b), 1.0, "nothing covered");
        a.px[0] = [0.8, 0.2, 0.4, 1.0];
        b.px[0] = [0.8, 0.2, 0.4, 1.0];
        b.px[5] = [0.0, 0.0, 0.0, 1.0];
        assert_eq!(a.rmse(&b).0, 0.0, "black on black background: no colour error");
        assert_eq!(a.silhouette_iou(&b), 0.5);
        assert_eq!(b.silhouette_iou(&a), 0.5);
        // Coverage under a half counts as uncovered.
        b.px[6] = [1.0, 1.0, 1.0, 0.4];
        assert_eq!(a.silhouette_iou(&b), 0.5);
        // Brightest channels 0.8 and 0 over the two covered pixels.
        let (sum, n) = b.brightness();
        assert_eq!(n, 2);
        assert!((sum - 0.8).abs() < 1e-6, "{sum}");
    }

    /// The dither: every level once; each 2×2 block holds one threshold of each quarter
    /// (so any fraction is spread evenly, not in clumps); the share of pixels kept below a
    /// threshold `a` is `a` to within one level; and the shader's table is this one.
    #[test]
    fn the_dither_matrix_is_an_even_bayer_matrix_shared_with_the_shaders() {
        let mut seen = BAYER_8X8.to_vec();
        seen.sort_unstable();
        assert_eq!(seen, (0..64).collect::<Vec<u32>>());
        for by in 0..4 {
            for bx in 0..4 {
                let mut q: Vec<u32> = (0..4)
                    .map(|k| BAYER_8X8[((2 * by + k / 2) * 8 + 2 * bx + k % 2) as usize] / 16)
                    .collect();
                q.sort_unstable();
                assert_eq!(q, [0, 1, 2, 3], "block ({bx}, {by})");
            }
        }
        for k in 0..=128 {
            let a = k as f32 / 128.0;
            let kept = (0..64).filter(|&i| crossfade_threshold(i % 8, i / 8) < a).count();
            assert!((kept as f32 / 64.0 - a).abs() <= 1.0 / 64.0, "{a}: {kept}");
        }
        // Periodic in 8 pixels.
        assert_eq!(crossfade_threshold(3, 5), crossfade_threshold(3 + 8, 5 + 16));
        // The bit formula is the table, and the shader computes the same formula.
        for i in 0..64u32 {
            assert_eq!(bayer_8x8(i % 8, i / 8), BAYER_8X8[i as usize], "({}, {})", i % 8, i / 8);
        }
        let wgsl =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders/crowd_common.wgsl")).unwrap();
        let squeeze = |s: &str| s.chars().filter(|c| !c.is_whitespace()).collect::<String>();
        let formula = "((z&1u)<<5u)|((y&1u)<<4u)|((z&2u)<<2u)|((y&2u)<<1u)|((z&4u)>>1u)|((y&4u)>>2u)";
        assert!(
            squeeze(&wgsl).contains(formula),
            "crowd_common.wgsl's crossfade_threshold is not the bit formula"
        );
        assert!(squeeze(&wgsl).contains("letz=x^y;"));
    }

    /// Polygons on whole pixels (as a still part's covering polygon is), cut into a fan of
    /// triangles whose shared edges run through pixel centres: every pixel centre inside the
    /// polygon is drawn (brute force against the polygon), none is left between two
    /// triangles. (A weight found as 1 - w0 - w1 came out a rounding below zero on both sides
    /// of such an edge: a still alien's view read 36.7 dB instead of 99.)
    #[test]
    fn triangles_sharing_an_edge_through_pixel_centres_leave_no_gap() {
        let size = 64u32;
        let tex = PartTile {
            size,
            px: vec![[0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 1.0]; (size * size) as usize],
        };
        let mut seed = 5u64;
        let mut rnd = |n: u32| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) % u64::from(n)) as f32
        };
        let mut missed_total = 0;
        for _ in 0..300 {
            // A convex polygon: points on a circle, rounded to whole pixels.
            let (cx, cy, r) = (32.0, 32.0, 10.0 + rnd(20));
            let n = 5 + rnd(12) as usize;
            let mut poly: Vec<[f32; 2]> = (0..n)
                .map(|k| {
                    let t = (k as f32 + rnd(100) / 200.0) * std::f32::consts::TAU / n as f32;
                    [(cx + r * t.cos()).round(), (cy + r * t.sin()).round()]
                })
                .collect();
            poly.dedup();
            if poly.len() < 3 {
                continue;
            }
            // Cut as the bake cuts polygons, and as a fan from a random vertex (shared edges
            // opposite every corner slot), each drawn on its own.
            let Ok(cdt) = crate::bake::triangulate::triangulate(&poly) else {
                continue;
            };
            let m = poly.len();
            let start = rnd(m as u32) as usize;
            let fan: Vec<[usize; 3]> = (1..m - 1)
                .map(|k| [start, (start + k) % m, (start + k + 1) % m])
                .collect();
            let sign = if crate::bake::contour::signed_area2(&poly) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            for triangles in [&cdt, &fan] {
                let mut c = Canvas::new(size);
                for t in triangles.iter() {
                    let tri = t.map(|i| poly[i]);
                    c.draw_textured(tri, tri, &tex);
                }
                for y in 0..size {
                    for x in 0..size {
                        let p = [x as f64 + 0.5, y as f64 + 0.5];
                        // Strictly inside every edge by a margin: certainly covered.
                        let inside = (0..m).all(|i| {
                            let (a, b) = (poly[i], poly[(i + 1) % m]);
                            let cross = (b[0] - a[0]) as f64 * (p[1] - a[1] as f64)
                                - (b[1] - a[1]) as f64 * (p[0] - a[0] as f64);
                            let len = (((b[0] - a[0]) as f64).powi(2) + ((b[1] - a[1]) as f64).powi(2)).sqrt();
                            sign * cross > 1e-3 * len
                        });
                        if inside && c.px[(y * size + x) as usize][3] < 0.5 {
                            missed_total += 1;
                        }
                    }
                }
            }
        }
        assert_eq!(missed_total, 0, "pixel centres inside a polygon left undrawn");
    }

    #[test]
    fn identity_texturing_reproduces_the_texture() {
        let size = 32;
        let tex = PartTile {
            size,
            px: (0..size * size)
                .map(|i| {
                    [
                        (i % size) as f32 / 32.0,
                        (i / size) as f32 / 32.0,
                        0.5,
                        0.5,
                        0.5,
                        1.0,
                        1.0,
                    ]
                })
                .collect(),
        };
        let mut c = Canvas::new(size);
        let quad = [[0.0, 0.0], [32.0, 0.0], [32.0, 32.0], [0.0, 32.0]];
        c.draw_textured([quad[0], quad[1], quad[2]], [quad[0], quad[1], quad[2]], &tex);
        c.draw_textured([quad[0], quad[2], quad[3]], [quad[0], quad[2], quad[3]], &tex);
        let (rmse, n) = c.rmse(&tile_canvas(&tex));
        assert_eq!(n, (size * size) as usize);
        assert!(rmse < 1e-4, "{rmse}");
        assert_eq!(psnr(rmse), 99.0);
        // Shifting the texture costs accuracy.
        let mut d = Canvas::new(size);
        let off = quad.map(|p| [p[0] + 3.0, p[1]]);
        d.draw_textured([off[0], off[1], off[2]], [quad[0], quad[1], quad[2]], &tex);
        d.draw_textured([off[0], off[2], off[3]], [quad[0], quad[2], quad[3]], &tex);
        assert!(psnr(d.rmse(&tile_canvas(&tex)).0) < 30.0);
    }
}
