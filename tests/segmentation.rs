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
                // RobotExpressive's big head turns on its own in its clips (110° against its
                // chest): a part of its own; the others' heads move with their chests.
                let head = stem == "RobotExpressive";
                assert_eq!(s.parts.len(), 5 + head as usize, "{stem}: {names:?}");
                assert_eq!(names.contains(&"Head"), head, "{stem}: {names:?}");
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
                if head {
                    assert!(mean_y("Head") > mean_y("Torso"), "{stem}: head below the torso");
                }
            }
        }
    }
}

/// A humanoid whose rig also holds IK and control chains, as game rigs do: paired two-joint
/// chains hanging from the root at ground level that carry no mesh (foot IK targets, knee
/// poles). The legs are still legs and the controls make no parts.
#[test]
fn ik_and_control_chains_do_not_rename_the_legs() {
    use glam::{Quat, Vec3};
    use polypostor::character::{Node, Transform};
    let mut c = polypostor::default_character::generate();
    let world = c.skeleton.rest_world();
    let root = (0..c.skeleton.nodes.len())
        .find(|&n| {
            c.skeleton.nodes[n].is_joint && c.skeleton.nodes[n].parent.is_none_or(|p| !c.skeleton.nodes[p].is_joint)
        })
        .expect("a root joint");
    let root_y = world[root].w_axis.y;
    let mut add = |name: String, parent: usize, t: Vec3| {
        c.skeleton.nodes.push(Node {
            name,
            parent: Some(parent),
            rest: Transform {
                translation: t,
                rotation: Quat::IDENTITY,
                scale: Vec3::ONE,
            },
            is_joint: true,
        });
        c.skeleton.nodes.len() - 1
    };
    for (side, x) in [("L", 0.1f32), ("R", -0.1)] {
        // Foot IK: root -> IK_Foot (on the ground) -> IK_Toe.
        let foot = add(format!("IK_Foot_{side}"), root, Vec3::new(x, 0.02 - root_y, 0.0));
        add(format!("IK_Toe_{side}"), foot, Vec3::new(0.0, 0.0, 0.12));
        // Knee pole: root -> ctrl_KneePole (in front, below the knee) -> its end.
        let pole = add(format!("ctrl_KneePole_{side}"), root, Vec3::new(x, -0.5 * root_y, 0.5));
        add(format!("ctrl_KneePole_{side}_end"), pole, Vec3::new(0.0, 0.0, 0.1));
    }
    let s = auto_segment(&c);
    let names: Vec<&str> = s.parts.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(s.parts.len(), 5, "{names:?}");
    for want in ["Torso", "Left Arm", "Right Arm", "Left Leg", "Right Leg"] {
        assert!(names.contains(&want), "{names:?}");
    }
    // Same labels as without the controls.
    let plain = auto_segment(&polypostor::default_character::generate());
    let named = |s: &polypostor::bake::segment::Segmentation| -> Vec<String> {
        s.labels.iter().map(|&l| s.parts[l as usize].name.clone()).collect()
    };
    assert_eq!(named(&s), named(&plain));
}

/// The generated quadruped (`polypostor::samples`): a horizontal spine along +z (the head end
/// in front), four legs hanging to the ground (front pair off the chest, hind pair off the
/// hips), a neck and head in front, a tail behind; joint names as a Blender rig writes them
/// ("b_" prefixes, ".L"); a smoothly skinned mesh.
fn quadruped() -> polypostor::Character {
    polypostor::samples::quadruped()
}

/// A quadruped's parts are named by what they are: front and hind legs (front = the end of
/// the trunk the head is on), the tail, the torso with the head; no "Leg 2" and no rig
/// prefixes. Facing the other way (mirrored along z), front and hind follow the head.
#[test]
fn quadruped_parts_are_named_by_what_they_are() {
    let c = quadruped();
    let s = auto_segment(&c);
    let names: Vec<&str> = s.parts.iter().map(|p| p.name.as_str()).collect();
    for want in [
        "Torso",
        "Front Left Leg",
        "Front Right Leg",
        "Hind Left Leg",
        "Hind Right Leg",
        "Tail",
        "Head",
    ] {
        assert!(names.contains(&want), "{names:?}");
    }
    // (Its head turns and nods on its neck as it walks: a part of its own.)
    assert_eq!(s.parts.len(), 7, "{names:?}");
    // The front legs are the ones under the head end.
    let rest = skin_vertices(&c, &Pose::rest(&c)).0;
    let mean_z = |name: &str| {
        let p = s.parts.iter().position(|p| p.name == name).unwrap();
        let ts = s.triangles_of(p);
        ts.iter()
            .map(|&t| (0..3).map(|k| rest[c.indices[3 * t + k] as usize].z).sum::<f32>() / 3.0)
            .sum::<f32>()
            / ts.len() as f32
    };
    assert!(mean_z("Front Left Leg") > mean_z("Hind Left Leg"));
    assert!(mean_z("Tail") < mean_z("Hind Left Leg"));
    assert!(mean_z("Head") > mean_z("Front Left Leg"));
    // Turned round (the head towards −z): the names follow the head, not the axis.
    let mut turned = quadruped();
    for n in &mut turned.skeleton.nodes {
        n.rest.translation.z = -n.rest.translation.z;
    }
    for v in &mut turned.vertices {
        v.position.z = -v.position.z;
    }
    for b in &mut turned.bones {
        let t = b.inverse_bind.w_axis;
        b.inverse_bind.w_axis = glam::Vec4::new(t.x, t.y, -t.z, t.w);
    }
    let s2 = auto_segment(&turned);
    let label = |s: &polypostor::bake::segment::Segmentation| -> Vec<String> {
        s.labels.iter().map(|&l| s.parts[l as usize].name.clone()).collect()
    };
    assert_eq!(label(&s2), label(&s), "the same triangles get the same names");
}

/// An animated prop (no skin; its animation turns one node): the piece that turns is a part of
/// its own, named after its node, carrying the node below it that does not move by itself; what
/// does not move is the body.
#[test]
fn an_animated_prop_gets_a_part_per_moving_piece() {
    let c = polypostor::import::import_slice(common::TURNING_PROP.as_bytes(), None, "windmill").unwrap();
    assert_eq!(c.triangle_count(), 3);
    let seg = auto_segment(&c);
    let names: Vec<&str> = seg.parts.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["Body", "Rotor"]);
    // Triangles in node order: the tower's, the rotor's, the hub's (which follows the rotor).
    assert_eq!(seg.labels, [0, 1, 1]);
    // Without the animation the same file is one static piece: the usual segmentation.
    let s = polypostor::import::import_slice(common::still_prop().as_bytes(), None, "still").unwrap();
    assert_eq!(auto_segment(&s).parts.len(), 1);
    // The whole prop turning (the animation on its top node): one part, named after it.
    let whole = common::TURNING_PROP.replace(r#""target": {"node": 1"#, r#""target": {"node": 0"#);
    let w = polypostor::import::import_slice(whole.as_bytes(), None, "whole").unwrap();
    let seg = auto_segment(&w);
    assert_eq!(seg.parts.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["Tower"]);
    assert_eq!(seg.labels, [0, 0, 0]);
}

/// The legs found for measuring strides are the parts named legs, and on RobotExpressive they
/// give the crowd a run: its Running slides its feet along the floor both ways (no contact
/// speed), so its speed comes from the legs' sweep, faster than its Walking by at least the
/// crowd's run ratio; its jumps (the standing leap WalkJump too), punch and dances stay put;
/// and a copy a hundred times larger runs a hundred times faster.
#[test]
fn legs_are_found_and_robot_expressive_runs() {
    use polypostor::crowd::{Gait, Gaits};
    use polypostor::timeline::{Timeline, measure_clips};
    for f in common::real_characters() {
        let c = polypostor::import_path(&f).unwrap();
        let s = auto_segment(&c);
        let legs = polypostor::bake::segment::leg_vertices(&c);
        let stem = f.file_stem().unwrap().to_string_lossy().to_string();
        if stem == "RiggedSimple" {
            assert!(legs.is_empty(), "{stem}");
            continue;
        }
        assert_eq!(legs.iter().flatten().max(), Some(&1), "{stem}: two legs");
        // Every vertex of a triangle the segmentation calls a leg is mostly a leg's, and the
        // other way about, but for the seams between parts.
        let (mut agree, mut all) = (0usize, 0usize);
        for t in 0..c.triangle_count() {
            let leg_part = s.parts[s.labels[t] as usize].name.ends_with("Leg");
            for k in 0..3 {
                all += 1;
                agree += (legs[c.indices[3 * t + k] as usize].is_some() == leg_part) as usize;
            }
        }
        assert!(agree as f64 > 0.95 * all as f64, "{stem}: {agree} of {all}");
        if stem != "RobotExpressive" {
            continue;
        }
        let m = measure_clips(&c);
        let clip = |name: &str| c.find_clip(name).unwrap();
        let (walking, running) = (m[clip("Walking")], m[clip("Running")]);
        assert!(walking.is_locomotion() && !walking.is_stride_estimate(), "{walking:?}");
        assert!(!running.is_locomotion() && running.is_stride_estimate(), "{running:?}");
        assert!(
            running.ground_speed() >= polypostor::crowd::RUN_OVER_WALK * walking.ground_speed(),
            "run {} walk {}",
            running.ground_speed(),
            walking.ground_speed()
        );
        for name in [
            "WalkJump", "Jump", "Punch", "Dance", "Idle", "Wave", "Yes", "No", "ThumbsUp", "Death", "Sitting",
        ] {
            assert_eq!(m[clip(name)].ground_speed(), 0.0, "{name}: {:?}", m[clip(name)]);
        }
        let all_clips: Vec<Option<usize>> = (0..c.clips.len()).map(Some).collect();
        let t = Timeline::measured(&c, &all_clips, 10.0).unwrap();
        let gaits = Gaits::new(&t.spans, t.fps);
        assert_eq!(gaits.clip_for(Gait::Walk, 0.0), Some(clip("Walking")));
        assert_eq!(gaits.clip_for(Gait::Run, 0.0), Some(clip("Running")));
        // A hundred times larger (a model in centimetres).
        let mut big = c.clone();
        for n in big.skeleton.nodes.iter_mut().filter(|n| n.parent.is_none()) {
            n.rest.scale *= 100.0;
            n.rest.translation *= 100.0;
        }
        let roots: Vec<usize> = (0..big.skeleton.nodes.len())
            .filter(|&i| big.skeleton.nodes[i].parent.is_none())
            .collect();
        for k in &mut big.clips {
            for ch in k.channels.iter_mut().filter(|ch| roots.contains(&ch.node)) {
                if let polypostor::character::ChannelValues::Translation(v) = &mut ch.values {
                    v.iter_mut().for_each(|x| *x *= 100.0);
                }
            }
        }
        let mb = measure_clips(&big);
        for (a, b) in m.iter().zip(&mb) {
            let (va, vb) = (a.ground_speed(), b.ground_speed());
            assert!(
                (vb - 100.0 * va).abs() <= 0.01 * vb.max(1e-3),
                "{va} × 100 against {vb}"
            );
        }
    }
}

/// A rig whose names say nothing (every joint `n000`, `n001`, …, as some exporters and
/// retargeting tools leave them) gets the same parts, by the same names, on the same
/// triangles as with its names: mirror pairs found by shape take their side from where they
/// hang (glTF's left is +x), legs and arms from what reaches the ground.
#[test]
fn a_rig_without_telling_names_gets_the_same_part_names() {
    let mut characters: Vec<(String, polypostor::Character)> = vec![
        ("default".into(), polypostor::default_character::generate()),
        ("quadruped".into(), quadruped()),
    ];
    for f in common::real_characters() {
        let stem = f.file_stem().unwrap().to_string_lossy().to_string();
        characters.push((stem, polypostor::import_path(&f).unwrap()));
    }
    let label = |s: &polypostor::bake::segment::Segmentation| -> Vec<String> {
        s.labels.iter().map(|&l| s.parts[l as usize].name.clone()).collect()
    };
    for (stem, c) in characters {
        let named = auto_segment(&c);
        let mut anonymous = c.clone();
        for (i, n) in anonymous.skeleton.nodes.iter_mut().enumerate() {
            n.name = format!("n{i:03}");
        }
        let plain = auto_segment(&anonymous);
        let names: Vec<&str> = plain.parts.iter().map(|p| p.name.as_str()).collect();
        eprintln!("{stem}: {names:?}");
        // Tails are named by their joints' names alone: a renamed tail is a "Part".
        let same = |a: &str, b: &str| a == b || (a == "Tail" && b.starts_with("Part"));
        let (a, b) = (label(&named), label(&plain));
        let differ = a.iter().zip(&b).filter(|(x, y)| !same(x, y)).count();
        let mut pairs: Vec<(&String, &String)> = a.iter().zip(&b).filter(|(x, y)| !same(x, y)).collect();
        pairs.dedup();
        eprintln!("{stem}: {differ} differ {:?}", &pairs[..pairs.len().min(5)]);
        assert_eq!(differ, 0, "{stem}: {names:?} against {:?}", named.parts);
    }
}

/// `c` with every triangle cut into four at its edges' midpoints (attributes averaged; a
/// midpoint's influences the two ends' strongest four), as a film-quality export of the same
/// character is denser.
fn subdivided(c: &polypostor::Character) -> polypostor::Character {
    use std::collections::HashMap;
    let mut out = c.clone();
    let mut mids: HashMap<(u32, u32), u32> = HashMap::new();
    let mut mid = |out: &mut polypostor::Character, a: u32, b: u32| -> u32 {
        *mids.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let (p, q) = (c.vertices[a as usize], c.vertices[b as usize]);
            let mut inf: Vec<(u16, f32)> = Vec::new();
            for v in [p, q] {
                for k in 0..4 {
                    match inf.iter_mut().find(|e| e.0 == v.bones[k]) {
                        Some(e) => e.1 += v.weights[k] / 2.0,
                        None => inf.push((v.bones[k], v.weights[k] / 2.0)),
                    }
                }
            }
            inf.sort_by(|x, y| y.1.total_cmp(&x.1));
            inf.resize(4, (0, 0.0));
            let sum: f32 = inf.iter().map(|e| e.1).sum::<f32>().max(1e-9);
            let avg4 = |x: [f32; 4], y: [f32; 4]| std::array::from_fn(|i| (x[i] + y[i]) / 2.0);
            out.vertices.push(polypostor::character::Vertex {
                position: (p.position + q.position) / 2.0,
                normal: (p.normal + q.normal).normalize_or_zero(),
                uv: [(p.uv[0] + q.uv[0]) / 2.0, (p.uv[1] + q.uv[1]) / 2.0],
                color: avg4(p.color, q.color),
                bones: std::array::from_fn(|i| inf[i].0),
                weights: std::array::from_fn(|i| inf[i].1 / sum),
            });
            (out.vertices.len() - 1) as u32
        })
    };
    let mut indices = Vec::with_capacity(c.indices.len() * 4);
    for t in c.indices.chunks_exact(3) {
        let (a, b, d) = (t[0], t[1], t[2]);
        let (ab, bd, da) = (mid(&mut out, a, b), mid(&mut out, b, d), mid(&mut out, d, a));
        indices.extend([a, ab, da, ab, b, bd, da, bd, d, ab, bd, da]);
    }
    out.indices = indices;
    for s in &mut out.submeshes {
        s.first_index *= 4;
        s.index_count *= 4;
    }
    out
}

/// The automatic parts of a character cut twice as finely have the same seams: as many cuts
/// (caps) per part as the character itself. Labelling each triangle by its skin weights
/// leaves single triangles of one part inside another where weights cross evenly, each a cut
/// of its own (CesiumMan cut into 16 had 10 cuts instead of 8) until small islands joined the
/// part around them (`segment::tidy_islands`).
#[test]
fn a_denser_mesh_is_cut_at_the_same_seams() {
    let mut characters = vec![("default".to_string(), polypostor::default_character::generate())];
    for f in common::real_characters() {
        characters.push((f.display().to_string(), polypostor::import_path(&f).unwrap()));
    }
    for (name, c) in characters {
        let cuts = |c: &polypostor::Character| {
            let seg = auto_segment(c);
            let mut per_part = vec![0usize; seg.parts.len()];
            for cap in polypostor::bake::caps::find_caps(c, &seg) {
                per_part[cap.part] += 1;
            }
            (seg.parts.iter().map(|p| p.name.clone()).collect::<Vec<_>>(), per_part)
        };
        let once = subdivided(&c);
        let twice = subdivided(&once);
        let (names, base) = cuts(&c);
        for (level, dense) in [(1, &once), (2, &twice)] {
            let (dense_names, got) = cuts(dense);
            assert_eq!(dense_names, names, "{name} cut {level}×");
            assert_eq!(got, base, "{name} cut {level}×: cuts per part {names:?}");
        }
    }
}
