//! Image error measures shared by the bake report, `compare`, the quality sheet and the
//! editor: PSNR (see [`crate::bake::raster::psnr`]) and SSIM, both over the pixels either
//! image covers.
//!
//! SSIM is the standard one (Wang, Bovik, Sheikh & Simoncelli 2004, "Image quality
//! assessment: from error visibility to structural similarity"), as scikit-image's
//! `structural_similarity(..., gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
//! data_range=1)` computes it:
//! - local statistics under an 11 × 11 Gaussian window, σ = 1.5 (separable, normalised,
//!   truncated at 3.5 σ), the image extended by mirror reflection at its borders
//!   (`d c b a | a b c d`);
//! - `C1 = (0.01 L)²`, `C2 = (0.03 L)²` with `L = 1` (colours in 0..1);
//! - population (not sample) variances;
//! - colour images: the map of each channel, averaged over the channels.
//!
//! What differs from the whole-image mean: our images are a character on an empty background,
//! so the mean of the SSIM map is taken over the **union of both coverage masks** (pixels
//! either image covers), as the RMSE is. Uncovered pixels enter the local statistics as black
//! (colour × coverage), so a missing limb or a stray shard lowers the score of the covered
//! pixels around it. Averaging over the whole frame instead would let the empty background
//! (SSIM 1) hide most of the error.

/// Standard deviation of the Gaussian window.
pub const SSIM_SIGMA: f64 = 1.5;
/// Half-width of the window (`int(3.5 σ + 0.5)`): the window is 11 × 11.
pub const SSIM_RADIUS: usize = 5;
const C1: f64 = 0.01 * 0.01;
const C2: f64 = 0.03 * 0.03;

/// The normalised 1D Gaussian taps (length `2 * SSIM_RADIUS + 1`).
fn gaussian_taps() -> [f64; 2 * SSIM_RADIUS + 1] {
    let mut taps = [0.0; 2 * SSIM_RADIUS + 1];
    for (i, t) in taps.iter_mut().enumerate() {
        let x = i as f64 - SSIM_RADIUS as f64;
        *t = (-0.5 * x * x / (SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let sum: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= sum);
    taps
}

/// Index `i` (possibly outside `0..n`) mirrored into `0..n` (scipy's "reflect" mode).
fn reflect(mut i: isize, n: usize) -> usize {
    let n = n as isize;
    if n == 1 {
        return 0;
    }
    loop {
        if i < 0 {
            i = -i - 1;
        } else if i >= n {
            i = 2 * n - i - 1;
        } else {
            return i as usize;
        }
    }
}

/// Separable Gaussian blur of a `w × h` plane.
fn blur(plane: &[f64], w: usize, h: usize, taps: &[f64], tmp: &mut Vec<f64>, out: &mut Vec<f64>) {
    let r = SSIM_RADIUS as isize;
    tmp.clear();
    tmp.resize(w * h, 0.0);
    // Each row with its mirrored borders laid out once, so the taps read a plain slice (the
    // same sums in the same order as reflecting every index).
    let mut padded = vec![0.0f64; w + 2 * SSIM_RADIUS];
    for y in 0..h {
        let row = &plane[y * w..(y + 1) * w];
        for (i, p) in padded.iter_mut().enumerate() {
            *p = row[reflect(i as isize - r, w)];
        }
        for (x, out) in tmp[y * w..(y + 1) * w].iter_mut().enumerate() {
            let window = &padded[x..x + taps.len()];
            let mut s = 0.0;
            for (t, v) in taps.iter().zip(window) {
                s += t * v;
            }
            *out = s;
        }
    }
    out.clear();
    out.resize(w * h, 0.0);
    for y in 0..h {
        for (k, t) in taps.iter().enumerate() {
            let src = reflect(y as isize + k as isize - r, h) * w;
            let (dst_row, src_row) = (&mut out[y * w..(y + 1) * w], &tmp[src..src + w]);
            for (d, s) in dst_row.iter_mut().zip(src_row) {
                *d += t * s;
            }
        }
    }
}

/// The SSIM map of two `w × h` colour images (`channels` interleaved values a pixel, in
/// 0..1), averaged over the channels: one value a pixel, in −1..1.
///
/// # Panics
/// If the slices do not hold `w * h * channels` values.
pub fn ssim_map(a: &[f32], b: &[f32], w: usize, h: usize, channels: usize) -> Vec<f64> {
    let n = w * h;
    assert!(
        a.len() == n * channels && b.len() == n * channels,
        "ssim_map: image sizes disagree"
    );
    let taps = gaussian_taps();
    let mut map = vec![0.0f64; n];
    if n == 0 || channels == 0 {
        return map;
    }
    let (mut tmp, mut mx, mut my, mut sxx, mut syy, mut sxy) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut plane = vec![0.0f64; n];
    for c in 0..channels {
        let x: Vec<f64> = (0..n).map(|i| a[i * channels + c] as f64).collect();
        let y: Vec<f64> = (0..n).map(|i| b[i * channels + c] as f64).collect();
        blur(&x, w, h, &taps, &mut tmp, &mut mx);
        blur(&y, w, h, &taps, &mut tmp, &mut my);
        plane.iter_mut().zip(&x).for_each(|(p, v)| *p = v * v);
        blur(&plane, w, h, &taps, &mut tmp, &mut sxx);
        plane.iter_mut().zip(&y).for_each(|(p, v)| *p = v * v);
        blur(&plane, w, h, &taps, &mut tmp, &mut syy);
        plane
            .iter_mut()
            .zip(x.iter().zip(&y))
            .for_each(|(p, (u, v))| *p = u * v);
        blur(&plane, w, h, &taps, &mut tmp, &mut sxy);
        for i in 0..n {
            let (ux, uy) = (mx[i], my[i]);
            let vx = sxx[i] - ux * ux;
            let vy = syy[i] - uy * uy;
            let cxy = sxy[i] - ux * uy;
            let s = ((2.0 * ux * uy + C1) * (2.0 * cxy + C2)) / ((ux * ux + uy * uy + C1) * (vx + vy + C2));
            map[i] += s / channels as f64;
        }
    }
    map
}

/// Silhouette agreement: the pixels both images cover over the pixels either covers, from
/// each pixel's (covered in the first, covered in the second); 1 when neither covers any.
/// Whatever the colours: the shape's agreement, which PSNR and SSIM weigh by colour against a
/// black background and so cannot see on a dark character.
pub fn silhouette_iou(covered: impl Iterator<Item = (bool, bool)>) -> f64 {
    let (mut both, mut either) = (0usize, 0usize);
    for (a, b) in covered {
        both += usize::from(a && b);
        either += usize::from(a || b);
    }
    if either == 0 { 1.0 } else { both as f64 / either as f64 }
}

/// Mean SSIM over the pixels where `mask` is true (`None` when it selects none).
pub fn masked_mean(map: &[f64], mask: &[bool]) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0usize);
    for (s, &m) in map.iter().zip(mask) {
        if m {
            sum += s;
            n += 1;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// Mean SSIM over `mask` of two `w × h` RGB images (3 values a pixel, 0..1): the map is
/// computed only over the mask's bounding box grown by the window radius (clamped to the
/// image), which gives exactly the full map's values on the mask (every window around a
/// masked pixel lies inside that box, and where the box meets the image border the mirror
/// is the same). 1 when the mask is empty.
pub fn masked_ssim(a: &[f32], b: &[f32], mask: &[bool], w: usize, h: usize) -> f64 {
    assert!(
        a.len() == w * h * 3 && b.len() == w * h * 3 && mask.len() == w * h,
        "masked_ssim: sizes disagree"
    );
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for y in 0..h {
        for x in 0..w {
            if mask[y * w + x] {
                x0 = x0.min(x);
                y0 = y0.min(y);
                x1 = x1.max(x + 1);
                y1 = y1.max(y + 1);
            }
        }
    }
    if x0 == usize::MAX {
        return 1.0;
    }
    let r = SSIM_RADIUS;
    let (x0, y0, x1, y1) = (
        x0.saturating_sub(r),
        y0.saturating_sub(r),
        (x1 + r).min(w),
        (y1 + r).min(h),
    );
    let (cw, ch) = (x1 - x0, y1 - y0);
    let crop = |img: &[f32]| -> Vec<f32> {
        (y0..y1)
            .flat_map(|y| img[(y * w + x0) * 3..(y * w + x1) * 3].iter().copied())
            .collect()
    };
    let m: Vec<bool> = (y0..y1)
        .flat_map(|y| mask[y * w + x0..y * w + x1].iter().copied())
        .collect();
    let map = ssim_map(&crop(a), &crop(b), cw, ch, 3);
    masked_mean(&map, &m).unwrap_or(1.0)
}

/// SSIM of two RGBA8 images as the bake and `compare` measure them: colour × coverage (a
/// pixel is covered when its alpha is over half), mean over the pixels either image covers.
/// 1 when neither covers anything; `None` when the sizes differ.
pub fn ssim_rgba8(a: &image::RgbaImage, b: &image::RgbaImage) -> Option<f64> {
    if a.dimensions() != b.dimensions() {
        return None;
    }
    let (w, h) = (a.width() as usize, a.height() as usize);
    let rgb = |img: &image::RgbaImage| -> (Vec<f32>, Vec<bool>) {
        let mut v = Vec::with_capacity(w * h * 3);
        let mut m = Vec::with_capacity(w * h);
        for p in img.pixels() {
            let covered = p[3] > 127;
            m.push(covered);
            for k in 0..3 {
                v.push(if covered { p[k] as f32 / 255.0 } else { 0.0 });
            }
        }
        (v, m)
    };
    let (va, ma) = rgb(a);
    let (vb, mb) = rgb(b);
    let mask: Vec<bool> = ma.iter().zip(&mb).map(|(x, y)| *x || *y).collect();
    Some(masked_ssim(&va, &vb, &mask, w, h))
}

/// SSIM of two RGBA float images (colour in 0..1 un-premultiplied, alpha = coverage), as
/// [`crate::bake::raster::Canvas::rmse`] measures: colour × coverage, mean over the pixels
/// either covers (alpha ≥ ½). 1 when neither covers anything.
pub fn ssim_rgba_f32(a: &[[f32; 4]], b: &[[f32; 4]], w: usize, h: usize) -> f64 {
    let flat = |px: &[[f32; 4]]| -> Vec<f32> {
        px.iter()
            .flat_map(|p| [p[0] * p[3], p[1] * p[3], p[2] * p[3]])
            .collect()
    };
    let mask: Vec<bool> = a.iter().zip(b).map(|(p, q)| p[3] >= 0.5 || q[3] >= 0.5).collect();
    masked_ssim(&flat(a), &flat(b), &mask, w, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The deterministic test pattern shared with the reference script in
    /// `tests/ssim_reference.rs` (see there).
    fn pattern(w: usize, h: usize, seed: u32) -> Vec<f32> {
        let mut s = seed;
        (0..w * h * 3)
            .map(|_| {
                s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
                ((s >> 16) & 0xff) as f32 / 255.0
            })
            .collect()
    }

    #[test]
    fn identical_images_score_one_and_symmetry_holds() {
        let a = pattern(20, 13, 1);
        let b = pattern(20, 13, 2);
        let same = ssim_map(&a, &a, 20, 13, 3);
        assert!(same.iter().all(|s| (s - 1.0).abs() < 1e-12));
        let ab = ssim_map(&a, &b, 20, 13, 3);
        let ba = ssim_map(&b, &a, 20, 13, 3);
        for (x, y) in ab.iter().zip(&ba) {
            assert!((x - y).abs() < 1e-12);
            assert!(*x <= 1.0 + 1e-12 && *x >= -1.0 - 1e-12);
        }
        let mean = ab.iter().sum::<f64>() / ab.len() as f64;
        assert!(mean < 0.5, "unrelated noise should score low, got {mean}");
    }

    #[test]
    fn taps_are_normalised_and_symmetric() {
        let t = gaussian_taps();
        assert!((t.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        for i in 0..t.len() {
            assert_eq!(t[i], t[t.len() - 1 - i]);
        }
        assert_eq!(reflect(-1, 5), 0);
        assert_eq!(reflect(-3, 5), 2);
        assert_eq!(reflect(5, 5), 4);
        assert_eq!(reflect(7, 5), 2);
        assert_eq!(reflect(-7, 3), 0, "several reflections on a small image");
    }

    #[test]
    fn masked_ssim_ignores_the_empty_background() {
        let mut a = image::RgbaImage::new(40, 40);
        let mut b = image::RgbaImage::new(40, 40);
        assert_eq!(ssim_rgba8(&a, &b), Some(1.0));
        for y in 10..30 {
            for x in 10..30 {
                let c = ((x * 7 + y * 3) % 255) as u8;
                a.put_pixel(x, y, image::Rgba([c, 255 - c, 128, 255]));
                b.put_pixel(x, y, image::Rgba([c, 255 - c, 128, 255]));
            }
        }
        assert!((ssim_rgba8(&a, &b).unwrap() - 1.0).abs() < 1e-12);
        // Half the square missing in b: the masked mean is far below the whole-frame mean.
        for y in 10..30 {
            for x in 20..30 {
                b.put_pixel(x, y, image::Rgba([0, 0, 0, 0]));
            }
        }
        let masked = ssim_rgba8(&a, &b).unwrap();
        assert!(masked < 0.7, "{masked}");
        assert_eq!(ssim_rgba8(&a, &image::RgbaImage::new(3, 3)), None);
    }

    #[test]
    fn the_cropped_computation_equals_the_full_map() {
        let (w, h) = (37, 29);
        let a = pattern(w, h, 3);
        let b = pattern(w, h, 4);
        let full = ssim_map(&a, &b, w, h, 3);
        // Masks in the middle, touching each border, a single pixel, everything.
        let boxes = [
            (10, 8, 20, 15),
            (0, 0, 6, 4),
            (30, 20, 37, 29),
            (18, 14, 19, 15),
            (0, 0, 37, 29),
        ];
        for (x0, y0, x1, y1) in boxes {
            let mask: Vec<bool> = (0..w * h)
                .map(|i| (x0..x1).contains(&(i % w)) && (y0..y1).contains(&(i / w)))
                .collect();
            let fast = masked_ssim(&a, &b, &mask, w, h);
            let slow = masked_mean(&full, &mask).unwrap();
            assert!((fast - slow).abs() < 1e-12, "box {x0},{y0}-{x1},{y1}: {fast} vs {slow}");
        }
        assert_eq!(masked_ssim(&a, &b, &vec![false; w * h], w, h), 1.0);
    }
}
