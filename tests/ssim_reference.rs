//! SSIM against an established implementation: scikit-image 0.26.0 (numpy 2.4.6),
//! `skimage.metrics.structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=1.0, channel_axis=-1, full=True)` on float64 copies
//! of the float32 fixtures below. `cropped` is the value that call returns (the mean of the
//! map without the 5-pixel border, averaged over the channels); `masked` is the map averaged
//! over the channels and then over the mask (`S.mean(axis=2)[mask].mean()`), which is how
//! this project reports SSIM; `pixel` is that channel-averaged map at x = 3, y = 4.
//!
//! The script (Python 3.11, `pip install scikit-image`):
//! ```text
//! import numpy as np
//! from skimage.metrics import structural_similarity as ssim
//! def pattern(w, h, seed):                      # the LCG of `pattern` below
//!     s = seed; out = []
//!     for _ in range(w * h * 3):
//!         s = (s * 1103515245 + 12345) & 0xffffffff
//!         out.append(((s >> 16) & 0xff) / 255.0)
//!     return np.array(out, dtype=np.float32).reshape(h, w, 3)
//! def smooth(w, h, phase):                      # `smooth` below
//!     y, x = np.mgrid[0:h, 0:w]
//!     r = 0.5 + 0.4 * np.sin(x * 0.45 + phase) * np.cos(y * 0.3)
//!     g = 0.5 + 0.4 * np.cos(x * 0.2 - y * 0.35 + phase)
//!     b = (x + 2 * y) / (w + 2 * h)
//!     return np.stack([r, g, b], axis=-1).astype(np.float32)
//! def run(name, a, b, mask):
//!     a = a.astype(np.float64); b = b.astype(np.float64)
//!     m, S = ssim(a, b, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
//!                 data_range=1.0, channel_axis=-1, full=True)
//!     smap = S.mean(axis=2)
//!     print(name, m, smap[mask].mean(), smap[4, 3])
//! # the fixtures: as in each test below
//! ```

use polypostor::metrics::{masked_mean, ssim_map};

fn pattern(w: usize, h: usize, seed: u32) -> Vec<f32> {
    let mut s = seed;
    (0..w * h * 3)
        .map(|_| {
            s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
            ((s >> 16) & 0xff) as f32 / 255.0
        })
        .collect()
}

fn smooth(w: usize, h: usize, phase: f64) -> Vec<f32> {
    let mut v = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let (xf, yf) = (x as f64, y as f64);
            v.push((0.5 + 0.4 * (xf * 0.45 + phase).sin() * (yf * 0.3).cos()) as f32);
            v.push((0.5 + 0.4 * (xf * 0.2 - yf * 0.35 + phase).cos()) as f32);
            v.push(((xf + 2.0 * yf) / (w as f64 + 2.0 * h as f64)) as f32);
        }
    }
    v
}

/// The mean of the map without its `SSIM_RADIUS`-pixel border (scikit-image's return value).
fn cropped(map: &[f64], w: usize, h: usize) -> f64 {
    let r = polypostor::metrics::SSIM_RADIUS;
    let mut sum = 0.0;
    let mut n = 0;
    for y in r..h - r {
        for x in r..w - r {
            sum += map[y * w + x];
            n += 1;
        }
    }
    sum / n as f64
}

fn check(name: &str, a: &[f32], b: &[f32], w: usize, h: usize, mask: &[bool], expect: [f64; 3]) {
    let map = ssim_map(a, b, w, h, 3);
    let got = [cropped(&map, w, h), masked_mean(&map, mask).unwrap(), map[4 * w + 3]];
    for (k, (g, e)) in got.iter().zip(expect).enumerate() {
        assert!(
            (g - e).abs() < 1e-6,
            "{name}: {} is {g:.10}, scikit-image gives {e:.10}",
            ["cropped mean", "masked mean", "pixel (3, 4)"][k]
        );
    }
}

#[test]
fn noise_against_noise() {
    let (w, h) = (16, 16);
    let mask = vec![true; w * h];
    check(
        "noise16",
        &pattern(w, h, 1),
        &pattern(w, h, 2),
        w,
        h,
        &mask,
        [-0.0389040355, 0.0423393516, -0.0039359192],
    );
}

#[test]
fn smooth_against_shifted_phase() {
    let (w, h) = (24, 20);
    let mask = vec![true; w * h];
    check(
        "smooth24x20",
        &smooth(w, h, 0.0),
        &smooth(w, h, 0.3),
        w,
        h,
        &mask,
        [0.9533618336, 0.9500609286, 0.9675288475],
    );
}

#[test]
fn smallest_image_with_noise_added() {
    // b = clip(a + 0.1 (noise − 0.5), 0, 1), computed in float32 as numpy does.
    let (w, h) = (13, 11);
    let a = smooth(w, h, 0.0);
    let noise = pattern(w, h, 5);
    let b: Vec<f32> = a
        .iter()
        .zip(&noise)
        .map(|(x, n)| (x + 0.1 * (n - 0.5)).clamp(0.0, 1.0))
        .collect();
    let mask = vec![true; w * h];
    check(
        "small13x11",
        &a,
        &b,
        w,
        h,
        &mask,
        [0.9685383719, 0.9629075622, 0.9772282838],
    );
}

#[test]
fn a_shifted_square_on_black_over_the_union_of_masks() {
    // A 12 × 12 `smooth` square on black in a 32 × 32 frame at (10, 9); b has it at (12, 9).
    let (w, h, size) = (32, 32, 12);
    let tile = smooth(size, size, 0.0);
    let square = |x0: usize, y0: usize| {
        let mut img = vec![0.0f32; w * h * 3];
        let mut mask = vec![false; w * h];
        for y in 0..size {
            for x in 0..size {
                let i = (y0 + y) * w + x0 + x;
                img[i * 3..i * 3 + 3].copy_from_slice(&tile[(y * size + x) * 3..(y * size + x) * 3 + 3]);
                mask[i] = true;
            }
        }
        (img, mask)
    };
    let (a, ma) = square(10, 9);
    let (b, mb) = square(12, 9);
    let mask: Vec<bool> = ma.iter().zip(&mb).map(|(x, y)| *x || *y).collect();
    check(
        "shifted_square32",
        &a,
        &b,
        w,
        h,
        &mask,
        [0.5503435955, 0.5221034719, 1.0],
    );
}
