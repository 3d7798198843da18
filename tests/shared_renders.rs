//! `--representation all` renders each view once: the impostor sheets and NP3D images are
//! composited from the Polypostor bake's part renders. They must match what rendering the
//! whole character gives (the independent answer) on the default character and on every
//! shared character: same cameras, nearly every pixel the same colour, coverage and body
//! part (the parts' caps, inside the body, may show on a few silhouette pixels).

mod common;

use std::sync::atomic::AtomicBool;

use common::images::differing;
use polypostor::bake::caps::CapOverrides;
use polypostor::bake::keys::KeyOptions;
use polypostor::bake::pipeline::{BakeOptions, KeyFrame, ViewRenders, bake_sharing};
use polypostor::bake::segment::auto_segment;
use polypostor::reps::RepSet;
use polypostor::reps::bake::{RepsOptions, SharedRenders, bake_representations, bake_representations_sharing};

fn check(character: &polypostor::Character, label: &str) {
    let ctx = common::gpu();
    let seg = auto_segment(character);
    let clip = (!character.clips.is_empty()).then_some(0);
    let options = BakeOptions {
        views: 5,
        resolution: 64,
        clip,
        key_frame: KeyFrame::Frame(0),
        keys: KeyOptions::SINGLE,
        ..Default::default()
    };
    let frames =
        polypostor::bake::renders::frame_times(clip.map_or(0.0, |i| character.clips[i].duration_secs), options.fps)
            .len();
    let mut shared = SharedRenders::new(options.views, frames, options.resolution, RepSet::ALL);
    let mut seen = Vec::new();
    let bake = bake_sharing(
        &ctx,
        character,
        &seg,
        &CapOverrides::default(),
        &options,
        &|_| {},
        &AtomicBool::new(false),
        &mut |v: &ViewRenders| {
            seen.push(v.view);
            shared.add(v);
        },
    )
    .unwrap();
    assert_eq!(
        seen,
        (0..options.views).collect::<Vec<_>>(),
        "{label}: every view once, in order"
    );
    let reps_options = RepsOptions {
        views: options.views,
        coverage: options.coverage,
        resolution: options.resolution,
        fps: options.fps,
        clip,
        extra_clips: Vec::new(),
        key_frame: bake.key_frame,
        set: RepSet::ALL,
        np3d_triangles: 400,
        part_labels: seg.labels.iter().map(|&l| l as u32).collect(),
    };
    let no = AtomicBool::new(false);
    let from_parts =
        bake_representations_sharing(&ctx, character, None, None, &reps_options, Some(shared), &|_| {}, &no).unwrap();
    let rendered = bake_representations(&ctx, character, None, None, &reps_options, &|_| {}, &no).unwrap();
    // The same cameras (the bake's framing of the capped character is the character's).
    for (a, b) in from_parts.manifest.views.iter().zip(&rendered.manifest.views) {
        let scale = b.camera.half_size.max(1e-6);
        for (x, y) in a.camera.center.iter().zip(&b.camera.center) {
            assert!(
                (x - y).abs() < 1e-4 * scale,
                "{label}: camera centres {:?} vs {:?}",
                a.camera,
                b.camera
            );
        }
        assert!((a.camera.half_size - b.camera.half_size).abs() < 1e-4 * scale);
    }
    let (ia, ib) = (from_parts.impostor.unwrap(), rendered.impostor.unwrap());
    assert_eq!((ia.columns, ia.rows), (ib.columns, ib.rows));
    for v in 0..options.views {
        let colour = differing(&ia.color[v], &ib.color[v], 0..4, 3);
        let normal = differing(&ia.normal[v], &ib.normal[v], 0..3, 3);
        let part = differing(&ia.normal[v], &ib.normal[v], 3..4, 0);
        assert!(
            colour < 0.005 && normal < 0.005 && part < 0.005,
            "{label} view {v}: {:.2} % of colour, {:.2} % of normal, {:.2} % of part texels differ",
            colour * 100.0,
            normal * 100.0,
            part * 100.0
        );
        // Not a blank sheet on both sides.
        assert!(
            ia.color[v].pixels().any(|p| p[3] > 127),
            "{label} view {v}: empty sheet"
        );
    }
    let (na, nb) = (from_parts.np3d.unwrap(), rendered.np3d.unwrap());
    for (a, b) in na.images.iter().zip(&nb.images) {
        assert!(differing(a, b, 0..4, 3) < 0.005, "{label}: NP3D key images differ");
    }
}

#[test]
fn shared_renders_match_whole_character_renders() {
    check(&polypostor::default_character::generate(), "default");
    for path in common::real_characters() {
        let c = polypostor::import_path(&path).unwrap();
        check(&c, &path.display().to_string());
    }
}

#[test]
fn an_incomplete_collection_is_not_used() {
    let ctx = common::gpu();
    let c = polypostor::default_character::generate();
    let seg = auto_segment(&c);
    let options = RepsOptions {
        views: 3,
        coverage: polypostor::bake::viewpoints::Coverage::UpperHemisphere,
        resolution: 32,
        fps: 10.0,
        clip: Some(0),
        extra_clips: Vec::new(),
        key_frame: 0,
        set: RepSet::ALL,
        np3d_triangles: 400,
        part_labels: seg.labels.iter().map(|&l| l as u32).collect(),
    };
    let no = AtomicBool::new(false);
    // Nothing added: the images are rendered, exactly as without a collection.
    let empty = SharedRenders::new(3, 10, 32, RepSet::ALL);
    let a = bake_representations_sharing(&ctx, &c, None, None, &options, Some(empty), &|_| {}, &no).unwrap();
    let b = bake_representations(&ctx, &c, None, None, &options, &|_| {}, &no).unwrap();
    let (ia, ib) = (a.impostor.unwrap(), b.impostor.unwrap());
    for v in 0..3 {
        assert_eq!(ia.color[v], ib.color[v]);
        assert_eq!(ia.normal[v], ib.normal[v]);
    }
}
