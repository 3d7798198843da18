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

/// A quadruped made here: a horizontal spine along +z (the head end in front), four legs
/// hanging to the ground (front pair off the chest, hind pair off the hips), a neck and head
/// in front, a tail behind; joint names as a Blender rig writes them ("b_" prefixes, ".L").
/// Every bone carries a box of mesh.
fn quadruped() -> polypostor::Character {
    use glam::{Mat4, Vec3};
    use polypostor::character::*;
    // (name, parent, head position)
    let mut joints: Vec<(String, Option<usize>, Vec3)> = vec![
        ("b_Hips".into(), None, Vec3::new(0.0, 0.8, -0.5)),
        ("b_Spine".into(), Some(0), Vec3::new(0.0, 0.82, 0.0)),
        ("b_Chest".into(), Some(1), Vec3::new(0.0, 0.85, 0.5)),
        ("b_Neck".into(), Some(2), Vec3::new(0.0, 1.0, 0.75)),
        ("b_Head".into(), Some(3), Vec3::new(0.0, 1.15, 0.9)),
        ("b_HeadEnd".into(), Some(4), Vec3::new(0.0, 1.15, 1.15)),
    ];
    let add = |joints: &mut Vec<(String, Option<usize>, Vec3)>, name: String, parent: usize, p: Vec3| {
        joints.push((name, Some(parent), p));
        joints.len() - 1
    };
    for (side, x) in [("L", 0.2f32), ("R", -0.2)] {
        for (end, parent, z) in [("Front", 2usize, 0.5f32), ("Back", 0, -0.5)] {
            let a = add(&mut joints, format!("b_{end}Leg1.{side}"), parent, Vec3::new(x, 0.7, z));
            let b = add(&mut joints, format!("b_{end}Leg2.{side}"), a, Vec3::new(x, 0.4, z));
            let c = add(&mut joints, format!("b_{end}Leg3.{side}"), b, Vec3::new(x, 0.1, z));
            add(
                &mut joints,
                format!("b_{end}Foot.{side}"),
                c,
                Vec3::new(x, 0.0, z + 0.05),
            );
        }
    }
    let t1 = add(&mut joints, "b_Tail01".into(), 0, Vec3::new(0.0, 0.8, -0.7));
    let t2 = add(&mut joints, "b_Tail02".into(), t1, Vec3::new(0.0, 0.75, -0.95));
    let t3 = add(&mut joints, "b_Tail03".into(), t2, Vec3::new(0.0, 0.7, -1.2));
    add(&mut joints, "b_Tail04".into(), t3, Vec3::new(0.0, 0.65, -1.4));
    let nodes: Vec<Node> = joints
        .iter()
        .map(|(name, parent, head)| Node {
            name: name.clone(),
            parent: *parent,
            rest: Transform {
                translation: *head - parent.map_or(Vec3::ZERO, |p| joints[p].2),
                ..Transform::IDENTITY
            },
            is_joint: true,
        })
        .collect();
    let bones: Vec<Bone> = joints
        .iter()
        .enumerate()
        .map(|(i, j)| Bone {
            node: i,
            inverse_bind: Mat4::from_translation(-j.2),
        })
        .collect();
    // A box around every bone from its head to its child's, weighted to the bone.
    let (mut vertices, mut indices) = (Vec::new(), Vec::<u32>::new());
    for (i, (_, parent, head)) in joints.iter().enumerate() {
        let Some(p) = parent else { continue };
        let (a, b) = (joints[*p].2, *head);
        let r = if joints[*p].0.contains("Leg") || joints[*p].0.contains("Foot") {
            0.05
        } else {
            0.12
        };
        let lo = a.min(b) - Vec3::splat(r);
        let hi = a.max(b) + Vec3::splat(r);
        let base = vertices.len() as u32;
        for k in 0..8 {
            let pos = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            vertices.push(Vertex {
                position: pos,
                normal: (pos - (lo + hi) * 0.5).normalize_or(Vec3::Y),
                uv: [0.5, 0.5],
                color: [1.0; 4],
                bones: [*p as u16, 0, 0, 0],
                weights: [1.0, 0.0, 0.0, 0.0],
            });
        }
        for q in [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ] {
            indices.extend([q[0], q[1], q[2], q[0], q[2], q[3]].map(|v| base + v));
        }
        let _ = i;
    }
    Character {
        name: "Quadruped".into(),
        submeshes: vec![Submesh {
            first_index: 0,
            index_count: indices.len() as u32,
            material: 0,
        }],
        vertices,
        indices,
        materials: vec![Material {
            name: "Fur".into(),
            base_color_factor: [0.6, 0.5, 0.4, 1.0],
            base_color_texture: None,
            double_sided: false,
        }],
        textures: Vec::new(),
        skeleton: Skeleton { nodes },
        bones,
        clips: Vec::new(),
        warnings: Vec::new(),
    }
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
    ] {
        assert!(names.contains(&want), "{names:?}");
    }
    assert_eq!(s.parts.len(), 6, "{names:?}");
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
