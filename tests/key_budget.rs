//! The pack-wide key budget (`pipeline::share_key_budget`): what views leave unspent goes to
//! the worst views, the pack never spends more than the per-view budgets allowed in all, and
//! a view given more keeps its budget, so fitting it again from scratch (the inspector, a
//! re-bake) chooses exactly the keys the bake wrote.

mod common;

use polypostor::bake::caps::CapOverrides;
use polypostor::bake::keys::ViewBytes;
use polypostor::bake::pipeline::{BakeOptions, KeyFrame, Prepared, refit_view, view_key_bytes};
use polypostor::bake::segment::auto_segment;

#[test]
fn unspent_key_budget_goes_to_the_worst_views_and_refits_reproduce_it() {
    let ctx = common::gpu();
    let options = BakeOptions {
        views: 10,
        resolution: 64,
        fps: 10.0,
        key_frame: KeyFrame::Frame(0),
        ..Default::default()
    };
    let base = options.keys.budget;
    assert!(options.keys.max_keys > 1 && base > 0.0, "keys on by default");
    let (c, bake) = common::bake_default(&ctx, &options);
    let mean = |p: &[f64]| p.iter().sum::<f64>() / p.len() as f64;
    // The ratio rule leaves a 10-frame clip's views at the settings' budget (their packs are
    // already under 58× below impostors), so the bounds below are the settings'.
    for (v, view) in bake.views.iter().enumerate() {
        let parts = view.parts.iter().filter(|p| p.fit.is_some()).count();
        let bytes = ViewBytes::new(
            view_key_bytes(view).0,
            parts,
            bake.frame_times.len(),
            1,
            options.resolution,
            options.fit.final_vertices,
        );
        assert_eq!(options.keys.view_budget(bytes), base, "view {v}");
    }

    // Never more than the per-view budgets in all.
    let (first, extra): (f64, f64) = bake
        .views
        .iter()
        .map(view_key_bytes)
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    assert!(
        extra <= base * first * (1.0 + 1e-9),
        "added {extra} B, allowed {} B",
        base * first
    );
    let granted: Vec<usize> = (0..bake.views.len())
        .filter(|&v| bake.views[v].key_budget.is_some())
        .collect();
    assert!(
        !granted.is_empty(),
        "no view was given more budget: the test tests nothing"
    );
    assert!(granted.len() <= 1, "at most a tenth of 10 views, rounded up");
    // The worst view by its own budget's fit is the one given more.
    let seg = auto_segment(&c);
    let prepared = Prepared::new(&ctx, &c, &seg, &CapOverrides::default(), &options).unwrap();
    let mut own_means = Vec::new();
    for (v, view) in bake.views.iter().enumerate() {
        let data = prepared.render(&ctx, v).unwrap();
        // From scratch with the budget the bake recorded: the same keys, the same error.
        let keys = polypostor::bake::keys::KeyOptions {
            budget: view.key_budget.unwrap_or(base),
            ..options.keys
        };
        let fit = refit_view(&data, bake.key_frame, &options.fit, &keys, None, None);
        assert_eq!(
            fit.error.psnr, view.error.psnr,
            "view {v}: a refit differs from the bake"
        );
        for (a, b) in fit.parts.iter().zip(&view.parts) {
            assert_eq!(a.key_frames(), b.key_frames(), "view {v}");
            assert_eq!(a.frame_key, b.frame_key, "view {v}");
        }
        // With the settings' budget alone: what the view had before the sharing.
        let alone = refit_view(&data, bake.key_frame, &options.fit, &options.keys, None, None);
        own_means.push(mean(&alone.error.psnr));
        if let Some(b) = view.key_budget {
            assert!(b > base, "view {v}: given {b}, base {base}");
            assert!(
                mean(&view.error.psnr) >= mean(&alone.error.psnr) - 1e-9,
                "view {v}: more budget made it worse ({} vs {})",
                mean(&view.error.psnr),
                mean(&alone.error.psnr)
            );
        }
    }
    let worst = (0..own_means.len())
        .min_by(|&a, &b| own_means[a].total_cmp(&own_means[b]))
        .unwrap();
    assert_eq!(granted[0], worst, "means by own budget: {own_means:?}");
}

/// The ratio rule (`KeyOptions::ratio`): a view whose pack has room below the ratio to one
/// clip's impostors spends more than the settings' budget, never more than its own
/// (`KeyOptions::view_budget`), and fitting it again from scratch (the inspector, a re-bake)
/// computes the same budget and chooses the same keys.
#[test]
fn the_key_ratio_gives_views_with_room_more_and_refits_reproduce_it() {
    let ctx = common::gpu();
    // A ratio low enough that the default's 10-frame views have room (45 gives them none);
    // no sharing, so each view spends only its own.
    let keys = polypostor::bake::keys::KeyOptions {
        ratio: 8.0,
        share: 0.0,
        ..Default::default()
    };
    let options = BakeOptions {
        views: 6,
        resolution: 64,
        fps: 10.0,
        key_frame: KeyFrame::Frame(0),
        keys,
        ..Default::default()
    };
    let (c, bake) = common::bake_default(&ctx, &options);
    let seg = auto_segment(&c);
    let prepared = Prepared::new(&ctx, &c, &seg, &CapOverrides::default(), &options).unwrap();
    let mut raised = 0;
    let mut past_base = 0;
    for (v, view) in bake.views.iter().enumerate() {
        assert_eq!(view.key_budget, None, "view {v}: nothing shared");
        let (first, extra) = view_key_bytes(view);
        let parts = view.parts.iter().filter(|p| p.fit.is_some()).count();
        let bytes = ViewBytes::new(
            first,
            parts,
            bake.frame_times.len(),
            1,
            options.resolution,
            options.fit.final_vertices,
        );
        let budget = keys.view_budget(bytes);
        assert!(budget >= keys.budget, "view {v}: {budget}");
        raised += (budget > keys.budget) as usize;
        assert!(
            extra <= budget * first * (1.0 + 1e-9),
            "view {v}: added {extra} B, allowed {} B",
            budget * first
        );
        past_base += (extra > keys.budget * first) as usize;
        let data = prepared.render(&ctx, v).unwrap();
        let fit = refit_view(&data, bake.key_frame, &options.fit, &keys, None, None);
        assert_eq!(
            fit.error.psnr, view.error.psnr,
            "view {v}: a refit differs from the bake"
        );
        for (a, b) in fit.parts.iter().zip(&view.parts) {
            assert_eq!(a.key_frames(), b.key_frames(), "view {v}");
        }
    }
    assert!(raised > 0, "no view had room: the test tests nothing");
    assert!(past_base > 0, "no view spent past the settings' budget");
}
