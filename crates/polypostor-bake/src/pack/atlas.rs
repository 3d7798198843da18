//! Atlas packing: each part's key-frame image cropped to its polygon's bounds (plus padding),
//! packed on shelves into a colour atlas and a half-resolution normal atlas with the same
//! layout, with the empty texels around each polygon filled by dilation so filtering never
//! bleeds in the background.

/// A placed rectangle: where the source crop `src` (in tile pixels) went in the atlas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasRect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
    /// Top-left of the crop in the source tile.
    pub src_x: u32,
    pub src_y: u32,
    /// The crop is stored transposed (its x runs down the atlas), when that packs tighter.
    pub transposed: bool,
}

impl AtlasRect {
    /// Where the tile point `q` (pixels) lies in the atlas (pixels).
    pub fn to_atlas(&self, q: [f32; 2]) -> [f32; 2] {
        let (dx, dy) = (q[0] - self.src_x as f32, q[1] - self.src_y as f32);
        if self.transposed {
            [self.x as f32 + dy, self.y as f32 + dx]
        } else {
            [self.x as f32 + dx, self.y as f32 + dy]
        }
    }
}

/// A packed atlas: `color` is `width × height`, `normal` the same layout at half resolution
/// (`width / 2 × height / 2`; shading normals are smooth, so a quarter of the texels serves).
pub struct Atlas {
    pub width: u32,
    pub height: u32,
    pub color: image::RgbaImage,
    pub normal: image::RgbaImage,
    pub rects: Vec<Option<AtlasRect>>,
}

/// Padding texels around each crop: one is all bilinear filtering reads past the polygon's
/// bounds. Crops are an even number of texels on each side and sit at even positions, so
/// each maps onto whole texels of the half-resolution normal atlas and a normal sampled
/// anywhere in the polygon never reads a neighbouring crop (it was 2, with crops anywhere).
pub const PADDING: u32 = 1;

/// Both sides of every colour atlas are multiples of this, so that the colour atlas and the
/// half-resolution normal atlas are whole 4 × 4 blocks (BC7 compresses them block by block).
pub const SIDE_MULTIPLE: u32 = 8;

/// Packs `items` (per part: colour tile, normal tile, polygon bounds `[min_x, min_y, max_x,
/// max_y]` in tile pixels, or `None`).
pub fn pack_atlas(items: &[Option<(&image::RgbaImage, &image::RgbaImage, [f32; 4])>]) -> Atlas {
    // Crop rectangles.
    let crops: Vec<Option<(u32, u32, u32, u32)>> = items
        .iter()
        .map(|it| {
            it.map(|(c, _, b)| {
                let (tw, th) = (c.width() as i64, c.height() as i64);
                let x0 = (b[0].floor() as i64 - PADDING as i64).clamp(0, tw - 1);
                let y0 = (b[1].floor() as i64 - PADDING as i64).clamp(0, th - 1);
                let x1 = (b[2].ceil() as i64 + PADDING as i64).clamp(x0 + 1, tw);
                let y1 = (b[3].ceil() as i64 + PADDING as i64).clamp(y0 + 1, th);
                // Even sides: one more texel after (or before, at the tile's edge).
                let even = |lo: i64, hi: i64, side: i64| match (hi - lo) % 2 {
                    0 => (lo, hi),
                    _ if hi < side => (lo, hi + 1),
                    _ if lo > 0 => (lo - 1, hi),
                    _ => (lo, hi),
                };
                let (x0, x1) = even(x0, x1, tw);
                let (y0, y1) = even(y0, y1, th);
                (x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32)
            })
        })
        .collect();
    // Skyline packing (each crop, tallest first, goes where the skyline under it is lowest),
    // tried over a range of atlas widths; the smallest atlas wins.
    let area: u64 = crops.iter().flatten().map(|c| c.2 as u64 * c.3 as u64).sum();
    let widest = crops.iter().flatten().map(|c| c.2).max().unwrap_or(1);
    let present: Vec<usize> = (0..crops.len()).filter(|&i| crops[i].is_some()).collect();
    let size = |i: usize| crops[i].map_or((0, 0), |c| (c.2, c.3));
    // Orders to try: tallest, widest, largest first.
    let orders: Vec<Vec<usize>> = [0usize, 1, 2]
        .iter()
        .map(|&k| {
            let mut o = present.clone();
            o.sort_by_key(|&i| {
                let (w, h) = size(i);
                let key = [h as u64, w as u64, w as u64 * h as u64][k];
                (std::cmp::Reverse(key), i)
            });
            o
        })
        .collect();
    let skyline = |width: u32, order: &[usize]| -> (u32, Vec<Option<AtlasRect>>) {
        let mut sky = vec![0u32; width as usize];
        let mut rects = vec![None; crops.len()];
        for &i in order {
            let (sx, sy, cw, ch) = crops[i].unwrap();
            // Lowest top edge over both orientations, then leftmost.
            let mut best: Option<(u32, u32, u32, bool)> = None;
            for transposed in [false, true] {
                let (w, h) = if transposed { (ch, cw) } else { (cw, ch) };
                if w > width || (transposed && cw == ch) {
                    continue;
                }
                // Even positions only (crops are even, so the skyline stays even).
                for (x, y) in window_maxima(&sky, w as usize).into_iter().enumerate().step_by(2) {
                    if best.is_none_or(|(_, by, bh, _)| (y + h, y) < (by + bh, by)) {
                        best = Some((x as u32, y, h, transposed));
                    }
                }
            }
            let (x, y, _, transposed) = best.expect("the width fits the widest crop");
            let (w, h) = if transposed { (ch, cw) } else { (cw, ch) };
            sky[x as usize..(x + w) as usize].fill(y + h);
            rects[i] = Some(AtlasRect {
                x,
                y,
                w,
                h,
                src_x: sx,
                src_y: sy,
                transposed,
            });
        }
        // Sides in multiples of 8: the normal atlas is exactly half, in whole 4 × 4 blocks.
        let height = sky
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .max(SIDE_MULTIPLE)
            .next_multiple_of(SIDE_MULTIPLE);
        (height, rects)
    };
    // At most ~48 widths, so large resolutions stay cheap.
    let lo = widest.max(SIDE_MULTIPLE).next_multiple_of(SIDE_MULTIPLE);
    let hi = (((area as f64).sqrt() * 2.0).ceil() as u32).max(lo);
    let step = ((hi - lo) / 48).max(SIDE_MULTIPLE).next_multiple_of(SIDE_MULTIPLE);
    let (width, (height, rects)) = (lo..=hi)
        .step_by(step as usize)
        .flat_map(|w| orders.iter().map(move |o| (w, o)))
        .map(|(w, o)| (w, skyline(w, o)))
        .min_by_key(|(w, (h, _))| (*w as u64 * *h as u64, *w))
        .expect("at least one width");
    let mut color = image::RgbaImage::new(width, height);
    let mut normal_full = image::RgbaImage::new(width, height);
    for (i, r) in rects.iter().enumerate() {
        let (Some(r), Some((c, n, _))) = (r, items[i]) else {
            continue;
        };
        for (image, src) in [(&mut color, c), (&mut normal_full, n)] {
            let mut block = image::RgbaImage::new(r.w, r.h);
            for yy in 0..r.h {
                for xx in 0..r.w {
                    let (u, v) = if r.transposed { (yy, xx) } else { (xx, yy) };
                    block.put_pixel(xx, yy, *src.get_pixel(r.src_x + u, r.src_y + v));
                }
            }
            dilate(&mut block, PADDING + 2);
            image::imageops::replace(image, &block, r.x as i64, r.y as i64);
        }
    }
    Atlas {
        width,
        height,
        color,
        normal: half_normals(&normal_full),
        rects,
    }
}

/// The maximum of every window of `w` consecutive values (`values.len() - w + 1` of them), in
/// linear time (a deque of candidate maxima).
fn window_maxima(values: &[u32], w: usize) -> Vec<u32> {
    let mut out = Vec::with_capacity(values.len().saturating_sub(w) + 1);
    let mut deque: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    for (i, &v) in values.iter().enumerate() {
        while deque.back().is_some_and(|&j| values[j] <= v) {
            deque.pop_back();
        }
        deque.push_back(i);
        if deque.front().is_some_and(|&j| j + w <= i) {
            deque.pop_front();
        }
        if i + 1 >= w {
            out.push(values[*deque.front().expect("holds i")]);
        }
    }
    out
}

/// Box-filters an encoded normal image (`n × 0.5 + 0.5`, alpha = coverage) to half size,
/// renormalising the averaged normals.
pub fn half_normals(img: &image::RgbaImage) -> image::RgbaImage {
    let (w, h) = (img.width() / 2, img.height() / 2);
    image::RgbaImage::from_fn(w.max(1), h.max(1), |x, y| {
        let mut n = [0.0f32; 3];
        let mut a = 0u32;
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let p = img.get_pixel((2 * x + dx).min(img.width() - 1), (2 * y + dy).min(img.height() - 1));
            for c in 0..3 {
                n[c] += p[c] as f32 / 255.0 * 2.0 - 1.0;
            }
            a += p[3] as u32;
        }
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let enc = |v: f32| (((if len > 1e-6 { v / len } else { 0.0 }) * 0.5 + 0.5) * 255.0).round() as u8;
        image::Rgba([enc(n[0]), enc(n[1]), enc(n[2]), ((a + 2) / 4) as u8])
    })
}

/// Fills transparent texels from covered neighbours, `steps` rings deep (alpha stays 0, so
/// coverage is unchanged; only colour bleeds outwards).
pub fn dilate(img: &mut image::RgbaImage, steps: u32) {
    let (w, h) = img.dimensions();
    let mut filled: Vec<bool> = img.pixels().map(|p| p[3] > 0).collect();
    for _ in 0..steps {
        let snapshot = img.clone();
        let was = filled.clone();
        for y in 0..h {
            for x in 0..w {
                if was[(y * w + x) as usize] {
                    continue;
                }
                let mut sum = [0u32; 3];
                let mut n = 0;
                for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx >= 0
                        && ny >= 0
                        && (nx as u32) < w
                        && (ny as u32) < h
                        && was[(ny as u32 * w + nx as u32) as usize]
                    {
                        let p = snapshot.get_pixel(nx as u32, ny as u32);
                        for c in 0..3 {
                            sum[c] += p[c] as u32;
                        }
                        n += 1;
                    }
                }
                if n > 0 {
                    let p = img.get_pixel_mut(x, y);
                    for c in 0..3 {
                        p[c] = (sum[c] / n) as u8;
                    }
                    filled[(y * w + x) as usize] = true;
                }
            }
        }
    }
}

/// Fills every transparent texel with the colour of the nearest covered ones, ring by ring
/// as [`dilate`] does but until nothing is left (alpha stays 0). For images projected onto
/// geometry that may reach past their silhouette (NP3D's key images): there the surface shows
/// the nearest edge colour instead of the background's black. Linear in the texel count.
pub fn fill_background(img: &mut image::RgbaImage) {
    let (w, h) = img.dimensions();
    let (w, h) = (w as usize, h as usize);
    let mut filled: Vec<bool> = img.pixels().map(|p| p[3] > 0).collect();
    if !filled.iter().any(|&f| f) {
        return;
    }
    let neighbours = |i: usize| {
        let (x, y) = (i % w, i / w);
        [
            (x + 1 < w).then(|| i + 1),
            (x > 0).then(|| i - 1),
            (y + 1 < h).then(|| i + w),
            (y > 0).then(|| i - w),
        ]
    };
    let mut queued = filled.clone();
    let mut ring: Vec<usize> = Vec::new();
    for i in 0..w * h {
        if !filled[i] && neighbours(i).into_iter().flatten().any(|n| filled[n]) {
            queued[i] = true;
            ring.push(i);
        }
    }
    let mut colours: Vec<[u8; 3]> = Vec::new();
    while !ring.is_empty() {
        colours.clear();
        for &i in &ring {
            let mut sum = [0u32; 3];
            let mut n = 0;
            for j in neighbours(i).into_iter().flatten().filter(|&j| filled[j]) {
                let p = img.as_raw();
                for c in 0..3 {
                    sum[c] += p[4 * j + c] as u32;
                }
                n += 1;
            }
            colours.push(std::array::from_fn(|c| (sum[c] / n.max(1)) as u8));
        }
        let raw: &mut [u8] = &mut *img;
        for (&i, c) in ring.iter().zip(&colours) {
            raw[4 * i..4 * i + 3].copy_from_slice(c);
            filled[i] = true;
        }
        let mut next = Vec::new();
        for &i in &ring {
            for j in neighbours(i).into_iter().flatten() {
                if !queued[j] {
                    queued[j] = true;
                    next.push(j);
                }
            }
        }
        ring = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filling_the_background_matches_dilating_until_full() {
        // An independent answer: the ring-by-ring dilation repeated until no texel is left.
        let mut img = image::RgbaImage::new(23, 17);
        for (x, y) in [(3u32, 4u32), (4, 4), (15, 12), (20, 2)] {
            img.put_pixel(x, y, image::Rgba([(x * 11) as u8, (y * 13) as u8, 200, 255]));
        }
        let mut expected = img.clone();
        dilate(&mut expected, 64);
        let mut filled = img.clone();
        fill_background(&mut filled);
        assert_eq!(filled, expected);
        assert!(
            filled.pixels().filter(|p| p[3] == 0).all(|p| p[2] == 200),
            "every texel coloured"
        );
        // An empty image stays empty, a full one unchanged.
        let mut empty = image::RgbaImage::new(5, 5);
        fill_background(&mut empty);
        assert!(empty.pixels().all(|p| p.0 == [0; 4]));
    }

    #[test]
    fn rectangles_do_not_overlap_and_keep_their_pixels() {
        let tiles: Vec<image::RgbaImage> = (0..5)
            .map(|k| image::RgbaImage::from_fn(64, 64, |x, y| image::Rgba([x as u8 * 4, y as u8 * 4, k * 40, 255])))
            .collect();
        let bounds = [
            [10.0, 5.0, 30.0, 60.0],
            [0.0, 0.0, 63.0, 63.0],
            [40.0, 40.0, 50.0, 45.0],
            [20.0, 20.0, 21.0, 21.0],
            [5.0, 30.0, 60.0, 40.0],
        ];
        let items: Vec<Option<(&image::RgbaImage, &image::RgbaImage, [f32; 4])>> =
            (0..5).map(|k| Some((&tiles[k], &tiles[k], bounds[k]))).collect();
        let a = pack_atlas(&items);
        let rects: Vec<AtlasRect> = a.rects.iter().map(|r| r.unwrap()).collect();
        for (i, r) in rects.iter().enumerate() {
            assert!(r.x + r.w <= a.width && r.y + r.h <= a.height);
            for s in &rects[i + 1..] {
                let apart = r.x + r.w <= s.x || s.x + s.w <= r.x || r.y + r.h <= s.y || s.y + s.h <= r.y;
                assert!(apart, "{r:?} overlaps {s:?}");
            }
            // The crop covers the polygon bounds and copies the tile (texel centres map
            // onto texel centres, transposed or not).
            let b = bounds[i];
            let (cw, ch) = if r.transposed { (r.h, r.w) } else { (r.w, r.h) };
            assert!(r.src_x as f32 <= b[0] && (r.src_x + cw) as f32 >= b[2].min(64.0));
            assert!(r.src_y as f32 <= b[1] && (r.src_y + ch) as f32 >= b[3].min(64.0));
            for (tx, ty) in [(r.src_x, r.src_y), (r.src_x + cw - 1, r.src_y + ch / 2)] {
                let q = r.to_atlas([tx as f32 + 0.5, ty as f32 + 0.5]);
                assert_eq!(
                    a.color.get_pixel(q[0] as u32, q[1] as u32),
                    tiles[i].get_pixel(tx, ty),
                    "{r:?}"
                );
            }
        }
        assert_eq!(a.normal.dimensions(), (a.width / 2, a.height / 2));
        // Even places and sides (each crop on whole texels of the half-resolution normals),
        // and one texel of padding at least round every polygon, inside its tile.
        for (r, b) in rects.iter().zip(&bounds) {
            assert!(r.x % 2 == 0 && r.y % 2 == 0 && r.w % 2 == 0 && r.h % 2 == 0, "{r:?}");
            let (cw, ch) = if r.transposed { (r.h, r.w) } else { (r.w, r.h) };
            let pad = |lo: u32, len: u32, b0: f32, b1: f32| {
                (lo == 0 || lo as f32 <= b0.floor() - 1.0) && (lo + len == 64 || (lo + len) as f32 >= b1.ceil() + 1.0)
            };
            assert!(
                pad(r.src_x, cw, b[0], b[2]) && pad(r.src_y, ch, b[1], b[3]),
                "{r:?} round {b:?}"
            );
        }
    }

    #[test]
    fn window_maxima_match_brute_force() {
        let values: Vec<u32> = (0..40u32).map(|i| (i * 37 + 11) % 23).collect();
        for w in 1..=values.len() {
            let brute: Vec<u32> = values.windows(w).map(|s| *s.iter().max().unwrap()).collect();
            assert_eq!(window_maxima(&values, w), brute, "w {w}");
        }
    }

    #[test]
    fn half_normals_average_and_renormalise() {
        // Left column points +x, right column +y: the average is the unit diagonal.
        let img = image::RgbaImage::from_fn(2, 2, |x, _| {
            if x == 0 {
                image::Rgba([255, 128, 128, 255])
            } else {
                image::Rgba([128, 255, 128, 0])
            }
        });
        let h = half_normals(&img);
        assert_eq!(h.dimensions(), (1, 1));
        let p = h.get_pixel(0, 0);
        let d = |v: u8| v as f32 / 255.0 * 2.0 - 1.0;
        let (x, y, z) = (d(p[0]), d(p[1]), d(p[2]));
        assert!((x * x + y * y + z * z - 1.0).abs() < 0.03, "{p:?}");
        assert!((x - y).abs() < 0.02 && x > 0.6, "{p:?}");
        assert_eq!(p[3], 128);
    }

    #[test]
    fn dilation_fills_colour_but_not_coverage() {
        let mut img = image::RgbaImage::new(8, 8);
        img.put_pixel(4, 4, image::Rgba([200, 100, 50, 255]));
        dilate(&mut img, 2);
        assert_eq!(*img.get_pixel(5, 4), image::Rgba([200, 100, 50, 0]));
        assert_eq!(*img.get_pixel(6, 4), image::Rgba([200, 100, 50, 0]));
        assert_eq!(img.get_pixel(7, 4)[0], 0);
    }
}
