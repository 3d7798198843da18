//! Atlas packing: each part's key-frame image cropped to its polygon's bounds (plus padding),
//! packed on shelves, colour in the left half and normal in the right, with the empty texels
//! around each polygon filled by dilation so filtering never bleeds in the background.

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
}

/// A packed atlas: `image` is `2 * width × height` (colour | normal).
pub struct Atlas {
    pub width: u32,
    pub height: u32,
    pub image: image::RgbaImage,
    pub rects: Vec<Option<AtlasRect>>,
}

/// Padding texels around each crop.
pub const PADDING: u32 = 2;

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
                (x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32)
            })
        })
        .collect();
    // Shelf packing, tallest first, into a width that fits the widest crop.
    let area: u64 = crops.iter().flatten().map(|c| c.2 as u64 * c.3 as u64).sum();
    let widest = crops.iter().flatten().map(|c| c.2).max().unwrap_or(1);
    let width = ((area as f64).sqrt().ceil() as u32).max(widest).next_multiple_of(4);
    let mut order: Vec<usize> = (0..crops.len()).filter(|&i| crops[i].is_some()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(crops[i].unwrap().3), i));
    let mut rects = vec![None; crops.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for i in order {
        let (sx, sy, w, h) = crops[i].unwrap();
        if x + w > width {
            x = 0;
            y += shelf;
            shelf = 0;
        }
        rects[i] = Some(AtlasRect {
            x,
            y,
            w,
            h,
            src_x: sx,
            src_y: sy,
        });
        x += w;
        shelf = shelf.max(h);
    }
    let height = (y + shelf).max(1).next_multiple_of(4);
    let mut image = image::RgbaImage::new(width * 2, height);
    for (i, r) in rects.iter().enumerate() {
        let (Some(r), Some((c, n, _))) = (r, items[i]) else {
            continue;
        };
        for (half, src) in [(0, c), (width, n)] {
            let mut block = image::RgbaImage::new(r.w, r.h);
            for yy in 0..r.h {
                for xx in 0..r.w {
                    block.put_pixel(xx, yy, *src.get_pixel(r.src_x + xx, r.src_y + yy));
                }
            }
            dilate(&mut block, PADDING + 2);
            image::imageops::replace(&mut image, &block, (half + r.x) as i64, r.y as i64);
        }
    }
    Atlas {
        width,
        height,
        image,
        rects,
    }
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

#[cfg(test)]
mod tests {
    use super::*;

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
            // The crop covers the polygon bounds and copies the tile (colour and normal halves).
            let b = bounds[i];
            assert!(r.src_x as f32 <= b[0] && (r.src_x + r.w) as f32 >= b[2].min(64.0));
            let (cx, cy) = (r.src_x + r.w / 2, r.src_y + r.h / 2);
            assert_eq!(
                a.image.get_pixel(r.x + r.w / 2, r.y + r.h / 2),
                tiles[i].get_pixel(cx, cy)
            );
            assert_eq!(
                a.image.get_pixel(a.width + r.x + r.w / 2, r.y + r.h / 2),
                tiles[i].get_pixel(cx, cy)
            );
        }
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
