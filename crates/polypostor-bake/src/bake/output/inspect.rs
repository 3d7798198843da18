//! What the fit inspector shows, computed without a user interface: a part's polygon at any
//! time (vertices interpolated between frames, as the crowd renderer does), the per-pixel
//! error of a part against its render, and the composited view at any time.

use crate::bake::image_cost::PartTile;
use crate::bake::part_fit::PartFit;
use crate::bake::pipeline::PartResult;
use crate::bake::raster::{Canvas, crossfade_threshold, tile_canvas};

/// The fitted polygon's vertices at time `t` (in frames; wraps around the clip), linearly
/// interpolated between the two frames around it.
pub fn positions_at(fit: &PartFit, t: f32) -> Vec<[f32; 2]> {
    let frames = fit.targets.len().max(1);
    let t = t.rem_euclid(frames as f32);
    let f0 = (t.floor() as usize).min(frames - 1);
    let f1 = (f0 + 1) % frames;
    let a = t - f0 as f32;
    let (p0, p1) = (fit.positions(f0), fit.positions(f1));
    p0.iter()
        .zip(&p1)
        .map(|(x, y)| [x[0] + (y[0] - x[0]) * a, x[1] + (y[1] - x[1]) * a])
        .collect()
}

/// One part's polypostor at time `t`, textured from its key tile.
pub fn part_canvas(fit: &PartFit, key_tile: &PartTile, t: f32) -> Canvas {
    let mut c = Canvas::new(key_tile.size);
    let pos = positions_at(fit, t);
    let uv = fit.uvs();
    for tri in &fit.triangles {
        c.draw_textured(tri.map(|i| pos[i]), tri.map(|i| uv[i]), key_tile);
    }
    c
}

/// Every part drawn in `order` at time `t`, each from the key that draws the frames around
/// `t` (`tiles[p][f]`: part `p`'s tile at frame `f`): where the two frames are drawn from
/// different keys, both keys' polygons are drawn, each on its share of the pixels
/// ([`crossfade_threshold`]), as the run time does.
pub fn composite_at(parts: &[PartResult], tiles: &[Vec<PartTile>], order: &[usize], t: f32, size: u32) -> Canvas {
    let mut c = Canvas::new(size);
    for &p in order {
        let Some(part) = parts.get(p) else { continue };
        let Some(fit) = part.fit.as_ref() else { continue };
        let frames = fit.targets.len().max(1);
        let tt = t.rem_euclid(frames as f32);
        let f0 = (tt.floor() as usize).min(frames - 1);
        let f1 = (f0 + 1) % frames;
        let a = tt - f0 as f32;
        let (Some(k0), Some(k1)) = (part.fit_at(f0), part.fit_at(f1)) else {
            continue;
        };
        let same = std::ptr::eq(k0.0, k1.0);
        for (n, (fit, key)) in [k0, k1].into_iter().enumerate() {
            if same && n == 1 {
                break;
            }
            let Some(tile) = tiles.get(p).and_then(|t| t.get(key)) else {
                continue;
            };
            let pos = positions_at(fit, t);
            let uv = fit.uvs();
            let keep = |x: u32, y: u32| same || ((crossfade_threshold(x, y) < a) == (n == 1));
            for tri in &fit.triangles {
                c.draw_textured_where(tri.map(|i| pos[i]), tri.map(|i| uv[i]), tile, &keep);
            }
        }
    }
    c
}

/// Per-pixel error of a part's polypostor at frame `f` against its render: a heat map
/// (transparent where neither covers; black: exact; through red and yellow to white: a full
/// unit of colour wrong) and the root mean square — the bake's measure (premultiplied colour,
/// over the pixels either covers), so its PSNR is the part's PSNR at that frame.
pub fn error_map(fit: &PartFit, key_tile: &PartTile, target: &PartTile, f: usize) -> (image::RgbaImage, f64) {
    let drawn = part_canvas(fit, key_tile, f as f32);
    let truth = tile_canvas(target);
    let size = target.size;
    let mut img = image::RgbaImage::new(size, size);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, (a, b)) in drawn.px.iter().zip(&truth.px).enumerate() {
        if a[3] < 0.5 && b[3] < 0.5 {
            continue;
        }
        let e = (0..3).map(|k| (a[k] * a[3] - b[k] * b[3]).powi(2)).sum::<f32>() / 3.0;
        sum += e as f64;
        n += 1;
        let x = e.sqrt().min(1.0);
        let heat = [
            (x * 3.0).min(1.0),
            (x * 3.0 - 1.0).clamp(0.0, 1.0),
            (x * 3.0 - 2.0).clamp(0.0, 1.0),
        ];
        img.put_pixel(
            i as u32 % size,
            i as u32 / size,
            image::Rgba([
                (heat[0] * 255.0) as u8,
                (heat[1] * 255.0) as u8,
                (heat[2] * 255.0) as u8,
                255,
            ]),
        );
    }
    (img, if n > 0 { (sum / n as f64).sqrt() } else { 0.0 })
}

/// A part tile as an image (colour un-premultiplied, coverage as alpha).
pub fn tile_image(tile: &PartTile) -> image::RgbaImage {
    tile_canvas(tile).to_image()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::part_fit::{PartFitOptions, fit_part};

    /// A disc that moves right by 2 pixels per frame, as tiles.
    fn moving_disc(frames: usize) -> Vec<PartTile> {
        (0..frames)
            .map(|f| {
                let size = 48u32;
                let mut color = image::RgbaImage::new(size, size);
                let mut normal = image::RgbaImage::new(size, size);
                for y in 0..size {
                    for x in 0..size {
                        let (dx, dy) = (x as f32 - 16.0 - 2.0 * f as f32, y as f32 - 24.0);
                        if dx * dx + dy * dy < 100.0 {
                            color.put_pixel(x, y, image::Rgba([200, (x * 5) as u8, 60, 255]));
                            normal.put_pixel(x, y, image::Rgba([128, 128, 255, 255]));
                        }
                    }
                }
                PartTile::from_images(&color, &normal)
            })
            .collect()
    }

    #[test]
    fn positions_interpolate_between_frames_and_match_them_at_integers() {
        let tiles = moving_disc(4);
        let fit = fit_part(&tiles, 0, &PartFitOptions::default(), &[]).unwrap();
        for f in 0..4 {
            assert_eq!(positions_at(&fit, f as f32), fit.positions(f));
        }
        let mid = positions_at(&fit, 1.5);
        let (a, b) = (fit.positions(1), fit.positions(2));
        for ((m, x), y) in mid.iter().zip(&a).zip(&b) {
            assert!((m[0] - 0.5 * (x[0] + y[0])).abs() < 1e-4);
            assert!((m[1] - 0.5 * (x[1] + y[1])).abs() < 1e-4);
        }
        // Past the last frame it wraps to the first.
        assert_eq!(positions_at(&fit, 4.0), fit.positions(0));
    }

    #[test]
    fn the_error_map_is_small_where_the_fit_is_good_and_large_when_shifted() {
        let tiles = moving_disc(3);
        let fit = fit_part(&tiles, 0, &PartFitOptions::default(), &[]).unwrap();
        let (img, rmse) = error_map(&fit, &tiles[0], &tiles[2], 2);
        assert_eq!(img.dimensions(), (48, 48));
        // The bake's own measure gives the same number.
        let same = part_canvas(&fit, &tiles[0], 2.0).rmse(&tile_canvas(&tiles[2])).0;
        assert!((rmse - same).abs() < 1e-6, "{rmse} vs {same}");
        // Against a frame the polygon was not fitted to (shifted by 4 px), the error grows.
        let (_, wrong) = error_map(&fit, &tiles[0], &tiles[2], 0);
        assert!(rmse < wrong, "{rmse} vs {wrong}");
        assert!(rmse < 0.25, "{rmse}");
    }

    #[test]
    fn the_composite_at_a_frame_matches_the_bake_renderer() {
        let tiles = moving_disc(3);
        let fit = fit_part(&tiles, 0, &PartFitOptions::default(), &[]).unwrap();
        let part = PartResult {
            fit: Some(fit),
            problem: None,
            psnr: vec![],
            ssim: vec![],
            key_color: image::RgbaImage::new(1, 1),
            key_normal: image::RgbaImage::new(1, 1),
            sse: vec![],
            extra: vec![],
            frame_key: vec![],
            outline_error: 0.0,
        };
        let parts = vec![part];
        let keys = vec![tiles[0].clone()];
        let all = vec![tiles.clone()];
        for f in 0..3 {
            let a = composite_at(&parts, &all, &[0], f as f32, 48);
            let b = crate::bake::pipeline::render_polypostor(&parts, &keys, &[0], f, 48);
            assert_eq!(a.px, b.px);
        }
    }
}
