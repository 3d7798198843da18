//! Frames where a part barely moves are fitted with narrower candidate windows
//! (`PartFitOptions::near_still_px2`): less work for nearly the same answer. Its own test
//! binary, since it reads the process-wide count of triangle costs.

use polypostor::bake::image_cost::PartTile;
use polypostor::bake::part_fit::{PartFitOptions, evaluations, fit_part};

/// A textured ellipse (stripes and gradients attached to the shape) at frame `f`: it drifts
/// `drift` pixels a frame to the right and breathes slightly.
fn tile(f: usize, drift: f32) -> PartTile {
    let size = 64u32;
    let (cx, cy) = (28.0 + drift * f as f32, 32.0);
    let (rx, ry) = (12.0 + 0.1 * (f as f32 * 0.7).sin(), 20.0);
    let px = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f32 + 0.5, (i / size) as f32 + 0.5);
            let (u, v) = ((x - cx) / rx, (y - cy) / ry);
            if u * u + v * v < 1.0 {
                let stripe = if ((v + 1.0) * 4.0).floor() as i32 % 2 == 0 {
                    1.0
                } else {
                    0.2
                };
                [
                    stripe,
                    v * 0.5 + 0.5,
                    u * 0.5 + 0.5,
                    0.5 + 0.3 * u,
                    0.5 + 0.3 * v,
                    1.0,
                    1.0,
                ]
            } else {
                [0.0; 7]
            }
        })
        .collect();
    PartTile { size, px }
}

/// Total fitted cost and triangle costs evaluated.
fn fit(tiles: &[PartTile], options: &PartFitOptions) -> (f64, u64) {
    let before = evaluations();
    let total = fit_part(tiles, 0, options, &[]).expect("fit").total_cost();
    (total, evaluations() - before)
}

#[test]
fn near_still_frames_cost_less_work_for_nearly_the_same_fit() {
    let off = PartFitOptions {
        near_still_px2: 0.0,
        ..Default::default()
    };
    let on = PartFitOptions::default();
    assert!(on.near_still_px2 > 0.0, "narrowing is on by default");
    // A part drifting a third of a pixel a frame: every frame is near its neighbour.
    let slow: Vec<PartTile> = (0..8).map(|f| tile(f, 0.3)).collect();
    let (full_cost, full_work) = fit(&slow, &off);
    let (narrow_cost, narrow_work) = fit(&slow, &on);
    assert!(
        (narrow_work as f64) < 0.85 * full_work as f64,
        "narrow windows evaluated {narrow_work} triangle costs, full ones {full_work}"
    );
    assert!(
        narrow_cost <= 1.01 * full_cost + 1e-6,
        "narrow windows cost {narrow_cost}, full ones {full_cost}"
    );
    // A part moving four pixels a frame is never near its neighbour: the same fit, the same
    // work, whichever setting.
    let fast: Vec<PartTile> = (0..6).map(|f| tile(f, 4.0)).collect();
    let (a, wa) = fit(&fast, &off);
    let (b, wb) = fit(&fast, &on);
    assert_eq!((a, wa), (b, wb));
}
