//! The bake end to end on a few views: every part fitted in every view, sensible errors.

mod common;

use std::sync::atomic::AtomicBool;

use polypostor::bake::caps::CapOverrides;
use polypostor::bake::pipeline::{BakeOptions, KeyFrame, bake};
use polypostor::bake::segment::auto_segment;

#[test]
fn small_bake_of_the_default_character() {
    let ctx = common::gpu();
    let c = polypostor::default_character::generate();
    let seg = auto_segment(&c);
    let options = BakeOptions {
        views: 3,
        resolution: 96,
        key_frame: KeyFrame::Auto,
        key_frame_probe_views: 1,
        ..Default::default()
    };
    let t = std::time::Instant::now();
    let (_, b) = common::bake_default(&ctx, &options);
    eprintln!(
        "bake: {:.1} s, stages {:?}, key frame {}",
        t.elapsed().as_secs_f64(),
        b.stage_secs,
        b.key_frame
    );
    assert_eq!(b.views.len(), 3);
    assert_eq!(b.frame_times.len(), 10);
    // Auto tries every second frame of the ten.
    assert!(b.key_frame % 2 == 0 && b.key_frame < 10, "key frame {}", b.key_frame);
    let mut all = Vec::new();
    for (v, view) in b.views.iter().enumerate() {
        let mut order = view.order.clone();
        order.sort();
        assert_eq!(order, (0..seg.parts.len()).collect::<Vec<_>>());
        for (p, part) in view.parts.iter().enumerate() {
            let fit = part
                .fit
                .as_ref()
                .unwrap_or_else(|| panic!("view {v} part {p}: {:?}", part.problem));
            assert!(fit.kept.len() <= polypostor::bake::part_fit::DEFAULT_POLYGON_VERTICES && fit.kept.len() >= 3);
            // The outline's triangles and two more for each vertex inside.
            assert_eq!(fit.triangles.len(), fit.kept.len() - 2 + 2 * fit.interior.len());
            assert!(fit.interior.len() <= polypostor::bake::part_fit::DEFAULT_INTERIOR_VERTICES);
        }
        eprintln!(
            "view {v}: psnr {:?} order {:?}",
            view.error
                .psnr
                .iter()
                .map(|x| (x * 10.0).round() / 10.0)
                .collect::<Vec<_>>(),
            view.order
        );
        all.extend(view.error.psnr.iter().copied());
    }
    if std::env::var_os("POLYPOSTOR_TEST_IMAGES").is_some() {
        use polypostor::bake::image_cost::PartTile;
        let v = &b.views[0];
        let keys: Vec<PartTile> = v
            .parts
            .iter()
            .map(|p| PartTile::from_images(&p.key_color, &p.key_normal))
            .collect();
        for f in [b.key_frame, (b.key_frame + 5) % 10] {
            let img = polypostor::bake::pipeline::render_polypostor(&v.parts, &keys, &v.order, f, 96).to_image();
            img.save(std::env::temp_dir().join(format!("poly-{f}.png"))).unwrap();
        }
        for (p, part) in v.parts.iter().enumerate() {
            part.key_color
                .save(std::env::temp_dir().join(format!("key-{p}.png")))
                .unwrap();
        }
    }
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    // Baseline: the key-frame polygons left where they are (no fitting). The fitted
    // polygons must follow the animation better on the other frames.
    let (mut fitted, mut frozen, mut n) = (0.0, 0.0, 0);
    for view in &b.views {
        for f in (0..b.frame_times.len()).filter(|&f| f != b.key_frame) {
            fitted += view.error.psnr[f];
            frozen += view.error.psnr_static[f];
            n += 1;
        }
    }
    eprintln!(
        "mean PSNR {mean:.2} dB; other frames: fitted {:.2} dB, frozen {:.2} dB",
        fitted / n as f64,
        frozen / n as f64
    );
    assert!(
        fitted > frozen + n as f64 * 0.5,
        "fitting does not beat frozen polygons"
    );
    assert!(mean > 12.0, "mean PSNR {mean}");
}

/// The artist's corrections reach the bake: a view's own key frame, drawing order and a
/// pinned correspondence are used there and nowhere else; corrections made for another
/// number of views are ignored.
#[test]
fn overrides_change_only_their_view() {
    use polypostor::bake::overrides::{BakeOverrides, OverrideBasis, Pin};
    let ctx = common::gpu();
    let c = polypostor::default_character::generate();
    let seg = auto_segment(&c);
    let base = BakeOptions {
        views: 3,
        resolution: 64,
        fps: 5.0,
        key_frame: KeyFrame::Frame(0),
        ..Default::default()
    };
    let run = |options: &BakeOptions| {
        bake(
            &ctx,
            &c,
            &seg,
            &CapOverrides::default(),
            options,
            &|_| {},
            &AtomicBool::new(false),
        )
        .unwrap()
    };
    let plain = run(&base);
    let frames = plain.frame_times.len();
    let basis = OverrideBasis {
        views: 3,
        full_sphere: false,
        frames,
    };
    // Pin part 0's first key vertex at the last frame onto a target vertex it does not map
    // to without the pin.
    let fit = plain.views[1].parts[0].fit.as_ref().unwrap();
    let f = frames - 1;
    let m = fit.targets[f].len();
    let free = fit.mappings[f][0];
    let pinned = (free + m / 2) % m;
    let mut overrides = BakeOverrides::default();
    let reversed: Vec<usize> = plain.views[1].order.iter().rev().copied().collect();
    {
        let v = overrides.view_mut(basis, 1);
        v.key_frame = Some(2);
        v.order = Some(reversed.clone());
        v.pins.insert(
            0,
            vec![Pin {
                frame: f,
                source: 0,
                target: pinned,
            }],
        );
    }
    let corrected = run(&BakeOptions {
        overrides: overrides.clone(),
        ..base.clone()
    });
    let view = &corrected.views[1];
    assert_eq!(view.key_frame, 2);
    assert_eq!(view.order, reversed);
    let fit = view.parts[0].fit.as_ref().unwrap();
    assert_eq!(fit.key_frame, 2);
    // The pin holds (pins refer to the key polygon of the view's key frame).
    assert_eq!(fit.mappings[f][0], pinned);
    for v in [0, 2] {
        assert_eq!(corrected.views[v].key_frame, 0);
        assert_eq!(corrected.views[v].order, plain.views[v].order);
        assert_eq!(
            corrected.views[v].parts[0].fit.as_ref().unwrap().mappings,
            plain.views[v].parts[0].fit.as_ref().unwrap().mappings
        );
    }
    // Re-baking from the plain bake with the corrections re-does view 1 only (every part:
    // its key frame changed) and gives what the full bake with them gave.
    let (again, reuse) = polypostor::bake::pipeline::rebake(
        &ctx,
        &plain,
        &c,
        &seg,
        &CapOverrides::default(),
        &BakeOptions {
            overrides: overrides.clone(),
            ..base.clone()
        },
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert!(!reuse.full);
    assert_eq!((reuse.views_refit, reuse.parts_refit), (1, seg.parts.len()));
    for (a, b) in again.views.iter().zip(&corrected.views) {
        assert_eq!(a.key_frame, b.key_frame);
        assert_eq!(a.order, b.order);
        assert_eq!(a.error.psnr, b.error.psnr);
        for (pa, pb) in a.parts.iter().zip(&b.parts) {
            assert_eq!(
                pa.fit.as_ref().map(|f| &f.mappings),
                pb.fit.as_ref().map(|f| &f.mappings)
            );
        }
    }
    // Only a pin changed since: that part alone is re-fitted.
    let mut moved = overrides.clone();
    moved.view_mut(basis, 1).pins.get_mut(&0).unwrap()[0].target = (pinned + 1) % m;
    let (_, reuse) = polypostor::bake::pipeline::rebake(
        &ctx,
        &again,
        &c,
        &seg,
        &CapOverrides::default(),
        &BakeOptions {
            overrides: moved,
            ..base.clone()
        },
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!((reuse.views_refit, reuse.parts_refit), (1, 1));
    // Every correction of view 1 removed: the re-bake goes back to the bake's key frame and
    // gives exactly the plain bake's view (one rule for the key frame everywhere).
    let (back, reuse) = polypostor::bake::pipeline::rebake(
        &ctx,
        &again,
        &c,
        &seg,
        &CapOverrides::default(),
        &base,
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!((reuse.views_refit, reuse.parts_refit), (1, seg.parts.len()));
    let (a, b) = (&back.views[1], &plain.views[1]);
    assert_eq!(a.key_frame, b.key_frame);
    assert_eq!(a.order, b.order);
    assert_eq!(a.error.psnr, b.error.psnr);
    assert_eq!(a.error.ssim, b.error.ssim);
    for (pa, pb) in a.parts.iter().zip(&b.parts) {
        assert_eq!(
            pa.fit.as_ref().map(|f| &f.mappings),
            pb.fit.as_ref().map(|f| &f.mappings)
        );
    }
    // A different segmentation bakes everything.
    let mut seg2 = seg.clone();
    seg2.labels[0] = (seg2.labels[0] + 1) % seg2.parts.len() as u16;
    let (_, reuse) = polypostor::bake::pipeline::rebake(
        &ctx,
        &again,
        &c,
        &seg2,
        &CapOverrides::default(),
        &base,
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert!(reuse.full && reuse.views_refit == 3);

    // Another basis: ignored.
    let mut other = BakeOverrides::default();
    other.view_mut(OverrideBasis { views: 24, ..basis }, 1).key_frame = Some(2);
    let ignored = run(&BakeOptions {
        overrides: other,
        ..base
    });
    assert_eq!(ignored.views[1].key_frame, 0);
}
