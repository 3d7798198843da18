//! The built-in default character: deterministic, stored, and what the issue asks for.

mod common;

use polypostor::animation::{Pose, skin_vertices};
use polypostor::default_character::{DEFAULT_CHARACTER_PATH, generate, generate_glb};

#[test]
fn regeneration_is_deterministic_and_matches_the_stored_asset() {
    let a = generate_glb();
    let b = generate_glb();
    assert_eq!(a, b, "two generations differ");
    let stored = std::fs::read(common::repo_path(DEFAULT_CHARACTER_PATH)).expect("stored default character");
    assert!(
        stored == a,
        "the stored {DEFAULT_CHARACTER_PATH} is out of date: run `polypostor generate-default`"
    );
}

#[test]
fn default_character_meets_the_brief() {
    let c = polypostor::import_path(&common::repo_path(DEFAULT_CHARACTER_PATH)).unwrap();
    assert!(c.warnings.is_empty(), "{:?}", c.warnings);
    let tris = c.triangle_count();
    assert!((2000..=6000).contains(&tris), "{tris} triangles");
    assert!(c.skeleton.joint_count() >= 15);
    for name in [
        "Hips",
        "Spine",
        "Chest",
        "Neck",
        "Head",
        "LeftUpperArm",
        "RightLowerArm",
        "LeftHand",
        "RightUpperLeg",
        "LeftFoot",
    ] {
        assert!(c.skeleton.find(name).is_some(), "missing joint {name}");
    }
    let walk = c.find_clip("Walk").expect("a Walk clip");
    assert!(c.clips.len() >= 2);
    // The walk loops: the pose at the end equals the pose at the start.
    let clip = &c.clips[walk];
    let (p0, _) = skin_vertices(&c, &Pose::sample(&c, clip, 0.0));
    let (p1, _) = skin_vertices(&c, &Pose::sample(&c, clip, clip.duration_secs - 1e-4));
    let max_gap = p0
        .iter()
        .zip(&p1)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0f32, f32::max);
    assert!(max_gap < 0.01, "walk does not loop: {max_gap} m");
    // It moves: the feet travel during the walk.
    let (pm, _) = skin_vertices(&c, &Pose::sample(&c, clip, clip.duration_secs * 0.25));
    let moved = p0
        .iter()
        .zip(&pm)
        .map(|(a, b)| (*a - *b).length())
        .fold(0.0f32, f32::max);
    assert!(moved > 0.1, "walk barely moves: {moved} m");
    // Height of a person, standing on the ground.
    let (min, max) = c.bind_bounds();
    assert!(
        (1.6..1.95).contains(&(max.y - min.y)) && min.y.abs() < 0.03,
        "{min} {max}"
    );
    // A texture with real detail: many distinct colours.
    let t = &c.textures[0];
    assert!(t.width >= 256 && t.height >= 256);
    let mut colours: Vec<u32> = t
        .rgba8
        .chunks_exact(4)
        .map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]]))
        .collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 2000, "only {} distinct colours", colours.len());
}

#[test]
fn generated_character_round_trips_through_glb() {
    let original = generate();
    let imported = polypostor::import::import_slice(&generate_glb(), None, "x").unwrap();
    assert_eq!(imported.name, original.name);
    assert_eq!(imported.indices, original.indices);
    assert_eq!(imported.skeleton.nodes.len(), original.skeleton.nodes.len());
    for (a, b) in imported.vertices.iter().zip(&original.vertices) {
        assert!((a.position - b.position).length() < 1e-6);
        assert_eq!(a.bones, b.bones);
    }
    assert_eq!(imported.clips.len(), original.clips.len());
    for (a, b) in imported.clips.iter().zip(&original.clips) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.channels.len(), b.channels.len());
        let (pa, _) = skin_vertices(&imported, &Pose::sample(&imported, a, 0.37));
        let (pb, _) = skin_vertices(&original, &Pose::sample(&original, b, 0.37));
        let gap = pa
            .iter()
            .zip(&pb)
            .map(|(x, y)| (*x - *y).length())
            .fold(0.0f32, f32::max);
        assert!(gap < 1e-4, "{}: {gap}", a.name);
    }
    assert_eq!(imported.textures[0].rgba8, original.textures[0].rgba8);
}
