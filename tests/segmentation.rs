//! Automatic segmentation of the real characters: the paper's parts where the rig allows.

mod common;

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
            }
        }
    }
}
