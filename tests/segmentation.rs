//! Automatic segmentation of the real characters: the paper's parts where the rig allows.

mod common;

use polypostor::animation::{Pose, skin_vertices};
use polypostor::bake::segment::auto_segment;

#[test]
fn real_characters_segment_into_sensible_parts() {
    for f in common::real_characters() {
        let c = polypostor::import_path(&f).unwrap();
        let s = auto_segment(&c);
        let names: Vec<&str> = s.parts.iter().map(|p| p.name.as_str()).collect();
        let sizes = s.part_sizes();
        eprintln!("{}: {:?} {:?}", f.display(), names, sizes);
        assert_eq!(s.labels.len(), c.triangle_count());
        assert!(sizes.iter().all(|&n| n > 0));
        let stem = f.file_stem().unwrap().to_string_lossy().to_string();
        match stem.as_str() {
            "RiggedSimple" => assert_eq!(s.parts.len(), 1),
            _ => {
                assert_eq!(s.parts.len(), 5, "{stem}: {names:?}");
                for want in ["Torso", "Left Arm", "Right Arm", "Left Leg", "Right Leg"] {
                    assert!(names.contains(&want), "{stem}: {names:?}");
                }
                // The names match the body: the lowest point of the mesh (a foot, even an IK
                // foot outside the leg chain) is in a leg, and the legs sit below the arms
                // (RobotExpressive's long arms reach lower than its knees).
                let rest = skin_vertices(&c, &Pose::rest(&c)).0;
                let tri_y = |t: usize| (0..3).map(|k| rest[c.indices[3 * t + k] as usize].y).sum::<f32>() / 3.0;
                let lowest = (0..c.triangle_count())
                    .min_by(|&a, &b| tri_y(a).total_cmp(&tri_y(b)))
                    .unwrap();
                let name_of = |t: usize| s.parts[s.labels[t] as usize].name.as_str();
                assert!(
                    name_of(lowest).ends_with("Leg"),
                    "{stem}: lowest triangle in {}",
                    name_of(lowest)
                );
                let mean_y = |kind: &str| {
                    let ts: Vec<usize> = (0..c.triangle_count())
                        .filter(|&t| name_of(t).ends_with(kind))
                        .collect();
                    ts.iter().map(|&t| tri_y(t)).sum::<f32>() / ts.len() as f32
                };
                assert!(mean_y("Leg") < mean_y("Arm"), "{stem}: legs above arms");
            }
        }
    }
}
