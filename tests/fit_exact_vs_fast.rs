//! The fast fitting mode against the exact dynamic programme on real renders of the default
//! character and CesiumMan, and over two of the default character's clips one after another:
//! the exact DP is never beaten frame by frame, and the fast mode's total stays within the
//! bound it currently achieves.

mod common;

use std::sync::atomic::AtomicBool;

use polypostor::bake::caps::{CapOverrides, find_caps};
use polypostor::bake::image_cost::PartTile;
use polypostor::bake::part_fit::{PartFitOptions, fit_part};
use polypostor::bake::renders::{frame_times, merge_parts, sample_frames, view_cameras};
use polypostor::bake::segment::auto_segment;
use polypostor::bake::viewpoints::{Coverage, directions};
use polypostor::gpu::*;

/// Issue 3's bound: the fast mode's total within 2 % of the exact optimum. (Over whole
/// bakes the fast mode measures 1.019 on the default character and 1.012 on CesiumMan with
/// 24 views, see the README.)
const FAST_MODE_BOUND: f64 = 1.02;

/// Fast against exact on views 1 and 4 of 7 over the frames of `clips` one after another (as
/// a whole-character pack lays them out: the first frame of each clip follows the last of the
/// one before, a different pose).
fn compare(ctx: &GpuContext, c: &polypostor::Character, label: &str, clips: &[usize]) {
    let seg = auto_segment(c);
    let caps = find_caps(c, &seg);
    let (merged, ranges) = merge_parts(c, &seg, &caps, &CapOverrides::default());
    let (mut poses, mut points, mut times) = (Vec::new(), Vec::new(), Vec::new());
    for &clip in clips {
        let t = frame_times(c.clips[clip].duration_secs, 10.0);
        let (p, q) = sample_frames(&merged, Some(clip), &t);
        poses.extend(p);
        points.extend(q);
        times.extend(t);
    }
    let views = directions(7, Coverage::UpperHemisphere);
    let cameras = view_cameras(&points, &views);
    let renderer = CharacterRenderer::new(&ctx.device);
    let batch = PartRenderer::new(&renderer, &ctx.device, &ctx.queue, &merged, ranges, &poses, 128);
    let (mut fast_total, mut exact_total) = (0.0, 0.0);
    for v in [1usize, 4] {
        let img = batch
            .render_view(&renderer, &ctx.device, &ctx.queue, &cameras[v])
            .unwrap();
        // Every part over the whole clip (the fast mode's chains reach half-way round the
        // loop from the key frame; the far frames are where it is weakest).
        let frames = times.len();
        for p in 0..seg.parts.len() {
            let tiles: Vec<PartTile> = (0..frames)
                .map(|f| PartTile::from_images(&img.tile(&img.color, p, f), &img.tile(&img.normal, p, f)))
                .collect();
            let fast = fit_part(&tiles, 0, &PartFitOptions::default(), &[]).unwrap();
            let exact = fit_part(
                &tiles,
                0,
                &PartFitOptions {
                    exhaustive: true,
                    ..Default::default()
                },
                &[],
            )
            .unwrap();
            eprintln!(
                "{label} view {v} part {p}: fast {:.3} exact {:.3}",
                fast.total_cost(),
                exact.total_cost()
            );
            if std::env::var_os("FIT_DEBUG").is_some() {
                for f in 0..frames {
                    eprintln!(
                        "  f{f} costs fast {:.3} exact {:.3}\n  fast  {:?}\n  exact {:?}",
                        fast.costs[f], exact.costs[f], fast.mappings[f], exact.mappings[f]
                    );
                }
                eprintln!("  m = {:?}", fast.targets.iter().map(|t| t.len()).collect::<Vec<_>>());
            }
            fast_total += fast.total_cost();
            exact_total += exact.total_cost();
            // Frame by frame the exact DP is never beaten (same S, same T).
            for f in 0..frames {
                assert!(
                    exact.costs[f] <= fast.costs[f] + 1e-9,
                    "{label}: exact worse than fast at frame {f}"
                );
            }
        }
    }
    let ratio = fast_total / exact_total;
    eprintln!("{label}: fast/exact = {ratio:.4}");
    assert!(
        ratio <= FAST_MODE_BOUND,
        "{label}: fast mode is {:.2}% above the exact optimum",
        (ratio - 1.0) * 100.0
    );
}

#[test]
fn fast_mode_within_two_percent_on_real_characters() {
    let _ = AtomicBool::new(false);
    let ctx = common::gpu();
    compare(&ctx, &polypostor::default_character::generate(), "default", &[0]);
    if let Some(shared) = common::shared_dir() {
        let c = polypostor::import_path(&shared.join("assets/characters/CesiumMan.glb")).unwrap();
        compare(&ctx, &c, "CesiumMan", &[0]);
    }
    // Two clips one after another (the default character's Run, then Idle: the first idle
    // frame follows the last running one): the frames where a clip starts, far from their
    // fitted neighbour, are seeded by the fitted frame with the nearest outline as well
    // (`PartFitOptions::similar_seed_px2`), and the fast mode stays within the bound. (In
    // this test, not one of its own: the count is the process's.)
    let c = polypostor::default_character::generate();
    let clip = |name: &str| c.clips.iter().position(|k| k.name == name).expect("default clip");
    let before = similar_seeds();
    compare(&ctx, &c, "default Run + Idle", &[clip("Run"), clip("Idle")]);
    assert!(
        similar_seeds() > before,
        "no frame was seeded by a similar frame across the clip boundary"
    );
}

fn similar_seeds() -> u64 {
    polypostor::bake::profile::snapshot()
        .0
        .get("frames seeded by a similar frame")
        .map_or(0, |c| c.1)
}
